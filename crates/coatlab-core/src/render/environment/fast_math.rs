//! Polynomial approximations that keep libm calls out of the environment's
//! look-ups (an escape or a light sample per path vertex). Each is used only
//! where its error cannot change a result: a first guess that exact comparisons
//! correct, or a value taken only where everything within its error bound rounds
//! or falls alike (see the callers in [`super::map`] and [`super::direction`]).

use std::f64::consts::{FRAC_PI_2, PI};

/// arccos(x) for x in [−1, 1] within 7e-5 rad (Abramowitz & Stegun 4.4.45): only a
/// first guess of a map row, which the row boundaries then correct.
#[inline]
pub(super) fn acos_approx(x: f64) -> f64 {
    let a = x.abs();
    let r = (1.0 - a).max(0.0).sqrt()
        * (1.570_728_8 + a * (-0.212_114_4 + a * (0.074_261_0 - a * 0.018_729_3)));
    if x < 0.0 { PI - r } else { r }
}

/// atan2(y, x) in [−π, π] within 2e-8 rad plus rounding (the arctangent on
/// [0, 1] by Abramowitz & Stegun 4.4.49, |ε| ≤ 2e-8, then the octant); `None`
/// for (0, 0), whose angle depends on the zeros' signs. Near ±π it may answer
/// the other end of the range, which is a column edge for every map width.
#[inline]
pub(super) fn atan2_approx(y: f64, x: f64) -> Option<f64> {
    const A: [f64; 8] = [
        -0.333_331_452_8,
        0.199_935_508_5,
        -0.142_088_994_4,
        0.106_562_639_3,
        -0.075_289_640_0,
        0.042_909_613_8,
        -0.016_165_736_7,
        0.002_866_225_7,
    ];
    let (ay, ax) = (y.abs(), x.abs());
    let (num, den) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if den == 0.0 {
        return None;
    }
    let t = num / den;
    let t2 = t * t;
    let poly = A.iter().rev().fold(0.0, |acc, &a| acc * t2 + a);
    let mut angle = t + t * t2 * poly;
    if ay > ax {
        angle = FRAC_PI_2 - angle;
    }
    if x < 0.0 {
        angle = PI - angle;
    }
    Some(if y < 0.0 { -angle } else { angle })
}

/// sin and cos of `a` for |a| ≤ 4 (an azimuth in [−π, π]) by a quadrant
/// reduction (π/2 in two parts, Cody & Waite: the first has 33 bits, so k·it and
/// the subtraction are exact) and fdlibm's minimax polynomials on [−π/4, π/4]
/// (`__kernel_sin`, `__kernel_cos`: |ε| < 2⁻⁵⁸ before rounding).
#[inline]
pub(super) fn sin_cos_fast(a: f64) -> (f64, f64) {
    const PIO2_HI: f64 = 1.570_796_326_734_125_6;
    const PIO2_LO: f64 = 6.077_100_506_506_192e-11;
    const S: [f64; 6] = [
        -0.166_666_666_666_666_32,
        0.008_333_333_333_322_49,
        -0.000_198_412_698_298_579_5,
        2.755_731_370_707_006_8e-6,
        -2.505_076_025_340_686_3e-8,
        1.589_690_995_211_55e-10,
    ];
    const C: [f64; 6] = [
        0.041_666_666_666_666_6,
        -0.001_388_888_888_887_411,
        2.480_158_728_947_673e-5,
        -2.755_731_435_139_066_3e-7,
        2.087_572_321_298_175e-9,
        -1.135_964_755_778_819_5e-11,
    ];
    let k = (a * std::f64::consts::FRAC_2_PI).round_ties_even();
    let r = (a - k * PIO2_HI) - k * PIO2_LO;
    let z = r * r;
    let ps = S.iter().rev().fold(0.0, |acc, &c| acc * z + c);
    let pc = C.iter().rev().fold(0.0, |acc, &c| acc * z + c);
    let sin_r = r + r * z * ps;
    let cos_r = 1.0 - 0.5 * z + z * z * pc;
    match (k as i64).rem_euclid(4) {
        0 => (sin_r, cos_r),
        1 => (cos_r, -sin_r),
        2 => (-sin_r, -cos_r),
        _ => (-cos_r, sin_r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::test_support::uniform;

    /// The polynomial arctangent stays within its stated error in every octant.
    #[test]
    fn approximate_atan2_is_within_2e_8_rad() {
        let mut state = 3;
        let mut worst = 0.0f64;
        for _ in 0..200_000 {
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            let r = 10f64.powf(6.0 * uniform(&mut state) - 3.0);
            let (y, x) = (r * a.sin(), r * a.cos());
            let exact = y.atan2(x);
            let approx = atan2_approx(y, x).unwrap();
            // Near ±π the two may name the two ends of the range.
            let diff = (approx - exact).abs();
            worst = worst.max(diff.min((diff - 2.0 * PI).abs()));
        }
        assert!(worst < 2e-8, "worst error {worst:e} rad");
        assert_eq!(atan2_approx(0.0, -0.0), None);
        assert_eq!(atan2_approx(1.0, 0.0), Some(FRAC_PI_2));
    }

    /// The polynomial arccosine stays within its stated error.
    #[test]
    fn approximate_acos_is_within_7e_5_rad() {
        let mut state = 5;
        let mut xs: Vec<f64> = (0..200_000)
            .map(|_| 2.0 * uniform(&mut state) - 1.0)
            .collect();
        xs.extend([-1.0, -0.0, 0.0, 1.0]);
        let worst = xs
            .iter()
            .map(|&x| (acos_approx(x) - x.acos()).abs())
            .fold(0.0f64, f64::max);
        assert!(worst < 7e-5, "worst error {worst:e} rad");
    }

    /// The polynomial sine and cosine stay within 1e-15 (a quarter of
    /// [`super::super::direction::SIN_COS_MARGIN`]) of libm's over the azimuths'
    /// range, quadrant edges, zeros and ±π included.
    #[test]
    fn fast_sin_cos_is_within_1e_15_of_libm() {
        let mut state = 21;
        let mut angles: Vec<f64> = (0..1_000_000)
            .map(|_| (2.0 * uniform(&mut state) - 1.0) * PI)
            .collect();
        for k in -4..=4 {
            let edge = f64::from(k) * PI / 4.0;
            for e in [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3] {
                angles.extend([edge + e, edge - e]);
            }
        }
        angles.extend([0.0, -0.0, PI, -PI, PI.next_down(), (-PI).next_up()]);
        let mut worst = 0.0f64;
        for a in angles {
            let (s, c) = sin_cos_fast(a);
            let (ws, wc) = a.sin_cos();
            worst = worst.max((s - ws).abs()).max((c - wc).abs());
        }
        assert!(worst < 1e-15, "largest difference {worst:e}");
    }
}
