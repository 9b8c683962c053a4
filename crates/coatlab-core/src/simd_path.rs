//! Which SIMD code the hot kernels run, chosen once per process from the CPU.
//!
//! The library is compiled for baseline x86-64 (SSE2), so one binary runs on every
//! x86-64 CPU; the hot kernels, the ray traversal ([`crate::accel::Accel`]'s
//! queries) and the paint's spectral evaluation
//! ([`crate::paint::model::SpectralPaint`]), are compiled three times: as is, with
//! AVX2 and FMA enabled, and with AVX-512 (F, VL, BW, DQ) enabled on top
//! (`#[target_feature]`, through `dispatch!`), and each call takes the path
//! chosen here. The traversal's AVX-512 copy tests a node's 8 child boxes with
//! 16-lane registers (near and far planes together) and reduces with mask
//! registers; the paint's is its AVX2 code compiled with AVX-512 enabled. Every
//! path does the same floating-point operations in the same order (Rust fuses no
//! multiply–adds and reorders no sums; the AVX-512 box test's negations are
//! exact), so they give the same results, bit for bit; the tests
//! (`tests/accel.rs`, `tests/paint_model.rs`) check that.
//!
//! The choice: AVX2 where the CPU has it (`is_x86_feature_detected!`; AVX-512 measured slower, [`SimdPath::best`]), unless the
//! environment variable `COATLAB_SIMD` names another one that it has (`portable`,
//! `avx2`, `avx512`), for tests and measurements; [`SimdPath::from_env`] says when
//! it names none, so that the app can refuse it at start-up.

use std::sync::OnceLock;

/// The traversal's SIMD code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SimdPath {
    /// Baseline x86-64 (SSE2), or whatever the target has elsewhere.
    Portable,
    /// x86-64 with AVX2 and FMA (x86-64-v3's vector features).
    Avx2,
    /// AVX2's features and AVX-512 F, VL, BW and DQ (x86-64-v4's vector features
    /// but CD, which nothing here uses).
    Avx512,
}

/// `COATLAB_SIMD` names no path this CPU has.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SimdPathError {
    #[error("COATLAB_SIMD={0:?}: expected one of `portable`, `avx2`, `avx512`")]
    Unknown(String),
    #[error("COATLAB_SIMD={0}: this CPU lacks the instructions of that path")]
    Unavailable(&'static str),
}

/// The environment variable that forces a path.
pub const SIMD_PATH_VARIABLE: &str = "COATLAB_SIMD";

impl SimdPath {
    /// Every path, slowest first.
    pub const ALL: [SimdPath; 3] = [SimdPath::Portable, SimdPath::Avx2, SimdPath::Avx512];

    /// The name in `COATLAB_SIMD`, `coatlab --version` and the render's last line.
    pub fn name(self) -> &'static str {
        match self {
            SimdPath::Portable => "portable",
            SimdPath::Avx2 => "avx2",
            SimdPath::Avx512 => "avx512",
        }
    }

    /// Whether this CPU can run the path.
    pub fn is_available(self) -> bool {
        match self {
            SimdPath::Portable => true,
            SimdPath::Avx2 => detected(false),
            SimdPath::Avx512 => detected(true),
        }
    }

    /// The paths this CPU can run, portable first.
    pub fn available() -> Vec<SimdPath> {
        SimdPath::ALL
            .into_iter()
            .filter(|p| p.is_available())
            .collect()
    }

    /// The names of [`Self::available`], in its order.
    pub fn available_names() -> Vec<&'static str> {
        SimdPath::available()
            .into_iter()
            .map(SimdPath::name)
            .collect()
    }

    /// This path where the CPU has it, else the portable one: what a caller asking
    /// for `self` is given.
    pub fn or_portable(self) -> SimdPath {
        if self.is_available() {
            self
        } else {
            SimdPath::Portable
        }
    }

    /// The path taken by default: AVX2 where the CPU has it, else the portable
    /// one. AVX-512 is taken only when `COATLAB_SIMD=avx512` asks for it: on the
    /// Xeon (Sapphire Rapids) it was measured on, its traversal traced 4–15 % fewer
    /// rays per CPU-second than the AVX2 one (`ACCEL_CPU=1` of `benches/accel.rs`).
    /// Why, as far as the code shows (the VM exposes no performance counters, so
    /// clocks and port use were not measured): the 16-lane box test halves the
    /// subtractions and products of the 8-lane one but adds three 256→512-bit
    /// inserts and an extract, so a node costs no fewer instructions; the mask
    /// registers save one `vmovmskps` a node or pack; and with AVX-512 enabled on a
    /// generic target LLVM also moves the batch's per-ray state in 512-bit
    /// registers (in the dev build about 160 of that kernel's 221 zmm instructions
    /// are moves), each of which puts the core in its 512-bit mode (no vector ALU
    /// on port 1, possibly a lower clock) for no arithmetic gained.
    pub fn best() -> SimdPath {
        if SimdPath::Avx2.is_available() {
            SimdPath::Avx2
        } else {
            SimdPath::Portable
        }
    }

    /// The path `COATLAB_SIMD` asks for (`None` when it is unset), or why it cannot
    /// be had.
    pub fn from_env() -> Result<Option<SimdPath>, SimdPathError> {
        let Some(value) = std::env::var_os(SIMD_PATH_VARIABLE) else {
            return Ok(None);
        };
        let value = value.to_string_lossy();
        let path = SimdPath::ALL
            .into_iter()
            .find(|p| p.name() == value)
            .ok_or_else(|| SimdPathError::Unknown(value.into_owned()))?;
        if !path.is_available() {
            return Err(SimdPathError::Unavailable(path.name()));
        }
        Ok(Some(path))
    }

    /// The path of this process: `COATLAB_SIMD`'s where it names one the CPU has,
    /// else [`SimdPath::best`]; decided on the first call.
    pub fn current() -> SimdPath {
        static CHOSEN: OnceLock<SimdPath> = OnceLock::new();
        *CHOSEN.get_or_init(|| {
            SimdPath::from_env()
                .ok()
                .flatten()
                .unwrap_or_else(SimdPath::best)
        })
    }
}

/// AVX2 and FMA (and the bit-manipulation instructions that x86-64-v3 adds, which
/// the AVX2 path is compiled with), and with `avx512` AVX-512 F, VL, BW and DQ too
/// (the AVX-512 path's).
fn detected(avx512: bool) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        let avx2 = has!("avx")
            && has!("avx2")
            && has!("fma")
            && has!("bmi1")
            && has!("bmi2")
            && has!("lzcnt")
            && has!("popcnt");
        avx2 && (!avx512
            || (has!("avx512f") && has!("avx512vl") && has!("avx512bw") && has!("avx512dq")))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = avx512;
        false
    }
}

/// The paths as numbers, for the kernels' const parameter `ISA` (a const generic
/// cannot be an enum on stable Rust). Ordered: `ISA >= AVX2` holds on every path
/// that has AVX2's instructions.
pub(crate) mod isa {
    pub const PORTABLE: u8 = 0;
    pub const AVX2: u8 = 1;
    pub const AVX512: u8 = 2;
}

/// Runs `kernel` in a function compiled with AVX2's features; `kernel` (an
/// `#[inline(always)]` closure) and what it inlines are compiled with them too.
/// Calls from code without those features are `unsafe`: the CPU must have them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
pub(crate) fn on_avx2<R>(kernel: impl FnOnce() -> R) -> R {
    kernel()
}

/// [`on_avx2`] with AVX-512's features as well.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,fma,bmi1,bmi2,lzcnt,popcnt,avx512f,avx512vl,avx512bw,avx512dq")]
pub(crate) fn on_avx512<R>(kernel: impl FnOnce() -> R) -> R {
    kernel()
}

/// `dispatch!(path, ISA => expression)`: the expression compiled once per path,
/// with `ISA` the path's number ([`isa`]; `_` where the expression does not use
/// it), and evaluated on `path`, which must be one this CPU has
/// ([`SimdPath::current`], [`SimdPath::or_portable`]). The one place where the
/// kernels' entry points meet the target features.
///
/// The expression runs in a closure, so what it reaches through the references the
/// closure captures (`self` above all) is not known to LLVM to be left alone by the
/// kernel's own stores, as a `&self` argument of a `#[target_feature]` method would
/// be: a kernel takes the slices its loop reads into locals before the loop, or
/// LLVM loads their address and length again at every step (`accel::wide::Nodes`:
/// that cost the batch traversal 2.8 % more instructions).
macro_rules! dispatch {
    ($path:expr, $isa:tt => $body:expr) => {{
        let path: $crate::simd_path::SimdPath = $path;
        debug_assert!(
            path.is_available(),
            "{path:?} dispatched on a CPU without it"
        );
        match path {
            #[cfg(target_arch = "x86_64")]
            $crate::simd_path::SimdPath::Avx512 => $crate::simd_path::dispatch!(@on on_avx512, AVX512, $isa => $body),
            #[cfg(target_arch = "x86_64")]
            $crate::simd_path::SimdPath::Avx2 => $crate::simd_path::dispatch!(@on on_avx2, AVX2, $isa => $body),
            _ => {
                #[allow(dead_code)]
                const $isa: u8 = $crate::simd_path::isa::PORTABLE;
                $body
            }
        }
    }};
    (@on $run:ident, $number:ident, $isa:tt => $body:expr) => {{
        #[allow(dead_code)]
        const $isa: u8 = $crate::simd_path::isa::$number;
        // SAFETY: the CPU has the path's features (the macro's contract).
        unsafe { $crate::simd_path::$run(#[inline(always)] || $body) }
    }};
}
pub(crate) use dispatch;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_the_best_path_is_available() {
        for path in SimdPath::ALL {
            assert_eq!(
                SimdPath::ALL.iter().find(|p| p.name() == path.name()),
                Some(&path)
            );
        }
        assert!(SimdPath::best().is_available());
        assert!(SimdPath::current().is_available());
        assert!(SimdPath::Portable.is_available());
    }
}
