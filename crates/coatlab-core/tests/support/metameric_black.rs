//! A metameric black for the tests of the metamerism index (core tolerance tests
//! and `coatlab measure`; included with `#[path]`).

use coatlab_core::colour::cie::{Illuminant, Observer, summation_weights};

/// `v` with its projection on the rows of the D65/10° weights removed: a
/// metameric black, invisible under D65.
pub fn metameric_black(w: &[f64], v: &[f64]) -> Vec<f64> {
    let weights =
        summation_weights(Illuminant::D65, Observer::Cie1964TenDegree, w).expect("weights");
    let n = w.len();
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let mut e = vec![0.0; n];
            e[i] = 1.0;
            let xyz = weights.xyz(&e);
            [xyz.x, xyz.y, xyz.z]
        })
        .collect();
    // Gram-Schmidt on the three weight rows, then subtract the projections.
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for k in 0..3 {
        let mut r: Vec<f64> = rows.iter().map(|row| row[k]).collect();
        for b in &basis {
            let p = dot(&r, b);
            r.iter_mut().zip(b).for_each(|(x, y)| *x -= p * y);
        }
        let norm = dot(&r, &r).sqrt();
        basis.push(r.iter().map(|x| x / norm).collect());
    }
    let mut out = v.to_vec();
    for b in &basis {
        let p = dot(&out, b);
        out.iter_mut().zip(b).for_each(|(x, y)| *x -= p * y);
    }
    out
}
