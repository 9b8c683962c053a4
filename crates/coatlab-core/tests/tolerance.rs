//! Tolerance arithmetic (`colour::tolerance`) against published worked examples
//! and against cases derived by hand from the published formulas.
//!
//! Sources:
//! - CIEDE2000: the 34 pairs of Sharma, Wu & Dalal (2005), `tests/data/ciede2000_sharma.csv`.
//! - CMC(l:c), ΔE*ab and ΔE00 of one large pair: the worked examples in the
//!   documentation of colour-science (`colour.difference.delta_E_CMC`,
//!   `delta_E_CIE1976`, `delta_E_CIE2000`; BSD-3-Clause, licence in
//!   `tests/data/LICENSE-colour-science`), an implementation independent of ours,
//!   as printed there: 172.7047712…, 451.7133019…, 94.0356490…; and the other CMC
//!   cases of its test suite (`colour/difference/tests/test_delta_e.py`), one at
//!   l:c = 1:1.
//! - CMC's weighting functions S_L, S_C, S_H and ΔH*ab: cases worked by hand from
//!   Clarke, McDonald & Rigg (1984) and CIE 15:2004 8.2.1 (the arithmetic is in
//!   each test's comment).
//! - Metamerism index: constructed pairs whose answer is known exactly (a scaled
//!   copy, which the multiplicative correction must cancel; a metameric black added,
//!   which leaves D65 unchanged and must not leave A unchanged).

use coatlab_core::colour::Lab;
use coatlab_core::colour::cie::{Illuminant, Observer, summation_weights};
use coatlab_core::colour::tolerance::{
    Formula, METAMERIC_DE00, Tolerance, cmc, delta_hue, difference, metamerism_index,
};

#[path = "support/metameric_black.rs"]
mod metameric_black;
use metameric_black::metameric_black;

const SHARMA_CSV: &str = include_str!("data/ciede2000_sharma.csv");

fn sharma_pairs() -> Vec<(Lab, Lab, f64)> {
    SHARMA_CSV
        .lines()
        .skip(1)
        .map(|line| {
            let v: Vec<f64> = line
                .split(',')
                .map(|x| x.parse().expect("number"))
                .collect();
            (Lab::new(v[1], v[2], v[3]), Lab::new(v[4], v[5], v[6]), v[8])
        })
        .collect()
}

#[test]
fn the_sharma_pairs_give_the_published_de00_and_the_differences_add_up() {
    let pairs = sharma_pairs();
    assert_eq!(pairs.len(), 34);
    for (k, (standard, trial, published)) in pairs.into_iter().enumerate() {
        let d = difference(standard, trial);
        assert!(
            (d.de00 - published).abs() <= 1e-4,
            "pair {}: {}",
            k + 1,
            d.de00
        );
        // CIE 15:2004 8.2.1: ΔE*ab² = ΔL*² + ΔC*² + ΔH*², and Δa*, Δb* are the plain
        // differences.
        let sum = d.dl * d.dl + d.dc * d.dc + d.dh * d.dh;
        assert!(
            (sum - d.de_ab * d.de_ab).abs() <= 1e-9 * (1.0 + sum),
            "pair {}",
            k + 1
        );
        assert_eq!((d.da, d.db), (trial.a - standard.a, trial.b - standard.b));
    }
}

#[test]
fn colour_science_worked_example_for_cmc_cie1976_and_ciede2000() {
    let standard = Lab::new(100.0, 21.57210357, 272.22819350);
    let trial = Lab::new(100.0, 426.67945353, 72.39590835);
    let d = difference(standard, trial);
    assert!((d.de_cmc - 172.7047712).abs() < 1e-6, "{}", d.de_cmc);
    assert!((d.de_ab - 451.7133019).abs() < 1e-6, "{}", d.de_ab);
    assert!((d.de00 - 94.0356490).abs() < 1e-6, "{}", d.de00);
    // The other CMC cases of colour-science's tests (colour/difference/tests/
    // test_delta_e.py), one at l:c = 1:1, to their 8 decimals.
    let cases = [
        (
            standard,
            Lab::new(100.0, 74.05216981, 276.45318193),
            2.0,
            20.59732717,
        ),
        (
            standard,
            Lab::new(100.0, 8.32281957, -73.58297716),
            1.0,
            121.71841479,
        ),
        (
            Lab::new(48.99183622, -0.10561667, 400.65619925),
            Lab::new(50.65907324, -0.11671910, 402.82235718),
            2.0,
            0.89969998,
        ),
    ];
    for (s, t, l, want) in cases {
        let got = cmc(s, t, l, 1.0);
        assert!((got - want).abs() < 1e-7, "{got} vs {want}");
    }
}

#[test]
fn cmc_weights_worked_by_hand() {
    // Neutral standard at L* = 50: S_L = 0.040975·50/(1 + 0.01765·50)
    // = 2.04875/1.8825; a lightness step of 2 at l = 2 gives 2/(2 S_L) = 0.9188530.
    let grey = Lab::new(50.0, 0.0, 0.0);
    assert!((cmc(grey, Lab::new(52.0, 0.0, 0.0), 2.0, 1.0) - 0.9188530).abs() < 1e-7);
    // At l = 1 the same step counts twice as much.
    assert!((cmc(grey, Lab::new(52.0, 0.0, 0.0), 1.0, 1.0) - 1.8377059).abs() < 1e-7);
    // Below L* = 16, S_L = 0.511: 1/(2·0.511) = 0.9784736.
    let dark = Lab::new(10.0, 0.0, 0.0);
    assert!((cmc(dark, Lab::new(11.0, 0.0, 0.0), 2.0, 1.0) - 0.9784736).abs() < 1e-7);
    // A neutral standard has C = 0: S_C = 0.638 and no hue difference, so a chroma
    // step of 3 gives 3/0.638 = 4.7021944.
    assert!((cmc(grey, Lab::new(50.0, 3.0, 0.0), 2.0, 1.0) - 4.7021944).abs() < 1e-7);
    // Hue: standard C* = 60 at h = 90° (outside 164°–345°, so
    // T = 0.36 + |0.4 cos 125°| = 0.5894306), S_C = 0.0638·60/1.786 + 0.638 =
    // 2.7813371, F = √(60⁴/(60⁴ + 1900)) = 0.9999267, S_H = S_C (F T + 1 − F) =
    // 1.6394888; a 2° hue turn at equal chroma is ΔH = 120 sin 1° = 2.0942887, so
    // ΔE = 1.2774035.
    let yellowish = Lab::new(50.0, 0.0, 60.0);
    let turned = Lab::new(
        50.0,
        60.0 * 92f64.to_radians().cos(),
        60.0 * 92f64.to_radians().sin(),
    );
    assert!((cmc(yellowish, turned, 2.0, 1.0) - 1.2774035).abs() < 1e-6);
    // Inside 164°–345° the other T: h = 180°, T = 0.56 + |0.2 cos 348°| = 0.7556295.
    let green = Lab::new(50.0, -60.0, 0.0);
    let turned = Lab::new(
        50.0,
        60.0 * 182f64.to_radians().cos(),
        60.0 * 182f64.to_radians().sin(),
    );
    let s_h = 2.7813371 * (0.9999267 * 0.7556295 + 1.0 - 0.9999267);
    let got = cmc(green, turned, 2.0, 1.0);
    assert!(
        (got - 2.0942887 / s_h).abs() < 1e-6,
        "{got} vs {}",
        2.0942887 / s_h
    );
}

#[test]
fn delta_h_is_signed_by_the_hue_turn() {
    // (50, 0, 20) is at h = 90°, (50, 20, 0) at h = 0°: equal chroma, so ΔC* = 0,
    // ΔE*ab = √800 = 28.2843, all of it hue; the turn is clockwise, so ΔH* < 0.
    let d = difference(Lab::new(50.0, 0.0, 20.0), Lab::new(50.0, 20.0, 0.0));
    assert!(d.dc.abs() < 1e-12);
    assert!((d.dh + 800f64.sqrt()).abs() < 1e-9, "{}", d.dh);
    assert!(
        (delta_hue(Lab::new(50.0, 20.0, 0.0), Lab::new(50.0, 0.0, 20.0)) - 800f64.sqrt()).abs()
            < 1e-9
    );
    // Across 0°/360° the short way: 350° to 10° is +20°.
    let at = |h: f64| {
        Lab::new(
            50.0,
            30.0 * h.to_radians().cos(),
            30.0 * h.to_radians().sin(),
        )
    };
    assert!((delta_hue(at(350.0), at(10.0)) - 60.0 * 10f64.to_radians().sin()).abs() < 1e-9);
}

#[test]
fn the_tolerance_picks_the_formula_and_the_angle() {
    let t: Tolerance = "cmc:2,15=3".parse().expect("tolerance");
    let d = difference(Lab::new(50.0, 0.0, 0.0), Lab::new(52.0, 0.0, 0.0));
    assert_eq!(t.formula, Formula::Cmc);
    assert_eq!(t.formula.of(&d), d.de_cmc);
    assert_eq!((t.limit_at(Some(15.0)), t.limit_at(Some(45.0))), (3.0, 2.0));
    assert_eq!(Tolerance::default().limit_at(Some(110.0)), 1.0);
}

fn wavelengths() -> Vec<f64> {
    (0..31).map(|i| 400.0 + 10.0 * i as f64).collect()
}

fn standard(w: &[f64]) -> Vec<f64> {
    w.iter()
        .map(|nm| 0.2 + 0.3 / (1.0 + (-(nm - 580.0) / 20.0).exp()))
        .collect()
}

/// The metamerism index of `trial` against `standard` (matched under D65, 10°)
/// under `test`.
fn index_under(
    test: Illuminant,
    w: &[f64],
    standard: &[f64],
    trial: &[f64],
) -> coatlab_core::colour::tolerance::MetamerismIndex {
    metamerism_index(
        w,
        standard,
        trial,
        Illuminant::D65,
        test,
        Observer::Cie1964TenDegree,
    )
    .expect("index")
}

#[test]
fn a_scaled_copy_has_no_metamerism_after_the_multiplicative_correction() {
    let w = wavelengths();
    let s = standard(&w);
    let trial: Vec<f64> = s.iter().map(|v| v * 1.04).collect();
    for test in [Illuminant::A, Illuminant::F11] {
        let m = index_under(test, &w, &s, &trial);
        assert!(m.de00 < 1e-9 && m.de_ab < 1e-9, "{m:?}");
        assert_eq!(m.illuminant, test);
    }
}

#[test]
fn a_metameric_pair_matches_under_d65_and_not_under_a_or_f11() {
    let w = wavelengths();
    let s = standard(&w);
    let wiggle: Vec<f64> = w
        .iter()
        .map(|nm| 0.08 * ((nm - 400.0) / 40.0).sin())
        .collect();
    let black = metameric_black(&w, &wiggle);
    let trial: Vec<f64> = s.iter().zip(&black).map(|(a, b)| a + b).collect();
    let d65 = summation_weights(Illuminant::D65, Observer::Cie1964TenDegree, &w).expect("weights");
    let same = difference(d65.lab(&s), d65.lab(&trial));
    assert!(same.de00 < 1e-9, "matched under D65: {same:?}");
    let indices: Vec<f64> = [Illuminant::A, Illuminant::F11]
        .into_iter()
        .map(|test| index_under(test, &w, &s, &trial).de00)
        .collect();
    assert!(indices.iter().all(|m| *m > METAMERIC_DE00), "{indices:?}");
    // The same wiggle scaled down tenfold is ten times less metameric, to first order.
    let small: Vec<f64> = s.iter().zip(&black).map(|(a, b)| a + 0.1 * b).collect();
    let m = index_under(Illuminant::A, &w, &s, &small);
    assert!(
        (m.de00 / indices[0] - 0.1).abs() < 0.01,
        "{} vs {}",
        m.de00,
        indices[0]
    );
}
