//! Which SIMD code the hot kernels run, chosen once per process from the CPU.
//!
//! The library is compiled for baseline x86-64 (SSE2), so one binary runs on every
//! x86-64 CPU; the hot kernels, the ray traversal ([`crate::accel::Accel`]'s
//! queries) and the paint's spectral evaluation
//! ([`crate::paint::model::SpectralPaint`]), are compiled twice, once as is and once
//! with AVX2 and FMA enabled (`#[target_feature]`), and each call takes the path
//! chosen here. Both paths do the same floating-point operations in the same order
//! (Rust fuses no multiply–adds and reorders no sums), so they give the same
//! results, bit for bit; the tests (`tests/accel.rs`, `tests/paint_model.rs`) check
//! that. (There is no AVX-512 path: no kernel here is written for it.)
//!
//! The choice: the best path the CPU has (`is_x86_feature_detected!`), unless the
//! environment variable `COATLAB_SIMD` names another one that it has (`portable`,
//! `avx2`), for tests and measurements; [`SimdPath::from_env`] says when it names
//! none, so that the app can refuse it at start-up.

use std::sync::OnceLock;

/// The traversal's SIMD code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SimdPath {
    /// Baseline x86-64 (SSE2), or whatever the target has elsewhere.
    Portable,
    /// x86-64 with AVX2 and FMA (x86-64-v3's vector features).
    Avx2,
}

/// `COATLAB_SIMD` names no path this CPU has.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SimdPathError {
    #[error("COATLAB_SIMD={0:?}: expected one of `portable`, `avx2`")]
    Unknown(String),
    #[error("COATLAB_SIMD={0}: this CPU lacks the instructions of that path")]
    Unavailable(&'static str),
}

/// The environment variable that forces a path.
pub const SIMD_PATH_VARIABLE: &str = "COATLAB_SIMD";

impl SimdPath {
    /// Every path, slowest first.
    pub const ALL: [SimdPath; 2] = [SimdPath::Portable, SimdPath::Avx2];

    /// The name in `COATLAB_SIMD`, `coatlab --version` and the render's last line.
    pub fn name(self) -> &'static str {
        match self {
            SimdPath::Portable => "portable",
            SimdPath::Avx2 => "avx2",
        }
    }

    /// Whether this CPU can run the path.
    pub fn is_available(self) -> bool {
        match self {
            SimdPath::Portable => true,
            SimdPath::Avx2 => avx2_detected(),
        }
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

    /// The fastest path this CPU has.
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
/// the AVX2 path is compiled with).
fn avx2_detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
            && std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("lzcnt")
            && std::arch::is_x86_feature_detected!("popcnt")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

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
