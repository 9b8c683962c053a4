//! The numerical pieces of the fits: the smoothness term on ρ(λ) and a projected
//! Newton minimiser over a box.
//!
//! No crate is used for the minimiser: `argmin` has no bound-constrained
//! Gauss–Newton or Levenberg–Marquardt, and the fits need bounds (ρ ∈ [0, 1], the
//! coat parameters within the paint parameter table's ranges) on some ~45–85
//! variables, where a dense Cholesky step is cheap and projected Newton
//! (Bertsekas 1982) is short and well understood.

// ---------------------------------------------------------------------------------
// The smoothness term

/// Q of the smoothness term λ·ρᵀQρ: the mean square of ρ's second divided
/// difference times (10 nm)², so the weight means the same on any wavelength step.
pub(super) fn smoothness_matrix(wavelengths_nm: &[f64]) -> Vec<f64> {
    let n = wavelengths_nm.len();
    let mut q = vec![0.0; n * n];
    if n < 3 {
        return q;
    }
    let rows = (n - 2) as f64;
    for j in 1..n - 1 {
        let (h0, h1) = (
            wavelengths_nm[j] - wavelengths_nm[j - 1],
            wavelengths_nm[j + 1] - wavelengths_nm[j],
        );
        let s = 100.0 * 2.0 / (h0 + h1);
        let d = [(j - 1, s / h0), (j, -s / h0 - s / h1), (j + 1, s / h1)];
        for &(a, da) in &d {
            for &(b, db) in &d {
                q[a * n + b] += da * db / rows;
            }
        }
    }
    q
}

pub(super) fn quadratic(q: &[f64], x: &[f64]) -> f64 {
    let n = x.len();
    (0..n)
        .map(|a| x[a] * (0..n).map(|b| q[a * n + b] * x[b]).sum::<f64>())
        .sum()
}

// ---------------------------------------------------------------------------------
// Bounded minimisation

/// What the solver needs of an objective at a point: its value, gradient and a
/// positive semi-definite (Gauss–Newton) Hessian, row-major.
pub(super) struct Local {
    pub(super) value: f64,
    pub(super) gradient: Vec<f64>,
    pub(super) hessian: Vec<f64>,
}

/// Cholesky solve of the positive definite `h` (row-major, `n`×`n`) for `b`, in
/// place; `None` when `h` is not positive definite.
fn cholesky_solve(mut h: Vec<f64>, n: usize, b: &mut [f64]) -> Option<()> {
    for j in 0..n {
        let mut d = h[j * n + j];
        for k in 0..j {
            d -= h[j * n + k] * h[j * n + k];
        }
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let d = d.sqrt();
        h[j * n + j] = d;
        for i in j + 1..n {
            let mut s = h[i * n + j];
            for k in 0..j {
                s -= h[i * n + k] * h[j * n + k];
            }
            h[i * n + j] = s / d;
        }
    }
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= h[i * n + k] * b[k];
        }
        b[i] = s / h[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= h[k * n + i] * b[k];
        }
        b[i] = s / h[i * n + i];
    }
    Some(())
}

/// Minimises over the box `lower ≤ x ≤ upper` by projected Newton steps (Bertsekas
/// 1982): the variables at a bound whose gradient points out of the box are held
/// (a variable with equal bounds always is), the others take the Newton step of
/// their block, and the step is projected and halved until the objective falls
/// enough, for at most `iterations` steps and until a step gains less than
/// `min_decrease`. With a Gauss–Newton Hessian this is a projected Gauss–Newton method; the
/// ridge added when the block is singular makes it Levenberg–Marquardt-like there.
pub(super) fn projected_newton(
    mut x: Vec<f64>,
    (lower, upper): (&[f64], &[f64]),
    (iterations, min_decrease): (usize, f64),
    local: impl Fn(&[f64]) -> Local,
    value: &impl Fn(&[f64]) -> f64,
) -> Vec<f64> {
    let n = x.len();
    for (j, v) in x.iter_mut().enumerate() {
        *v = v.clamp(lower[j], upper[j]);
    }
    for _ in 0..iterations {
        let l = local(&x);
        let free: Vec<usize> = (0..n)
            .filter(|&j| {
                let g = l.gradient[j];
                lower[j] < upper[j]
                    && !((x[j] <= lower[j] && g > 0.0) || (x[j] >= upper[j] && g < 0.0))
            })
            .collect();
        let m = free.len();
        let mut step = vec![0.0; n];
        if m > 0 {
            let mut h = vec![0.0; m * m];
            let mut largest = 0.0f64;
            for (a, &ja) in free.iter().enumerate() {
                for (b, &jb) in free.iter().enumerate() {
                    h[a * m + b] = l.hessian[ja * n + jb];
                }
                largest = largest.max(h[a * m + a]);
            }
            let mut rhs: Vec<f64> = free.iter().map(|&j| -l.gradient[j]).collect();
            let mut ridge = 1e-13 * largest.max(f64::MIN_POSITIVE);
            loop {
                let mut damped = h.clone();
                for a in 0..m {
                    damped[a * m + a] += ridge;
                }
                let mut trial = rhs.clone();
                if cholesky_solve(damped, m, &mut trial).is_some() {
                    rhs = trial;
                    break;
                }
                ridge *= 100.0;
                if ridge > 1e6 * largest.max(1.0) {
                    // Nothing to descend along: a steepest-descent step instead.
                    break;
                }
            }
            for (a, &j) in free.iter().enumerate() {
                step[j] = rhs[a];
            }
        }
        let mut alpha = 1.0;
        let mut moved = false;
        for _ in 0..40 {
            let trial: Vec<f64> = x
                .iter()
                .zip(&step)
                .enumerate()
                .map(|(j, (x, s))| (x + alpha * s).clamp(lower[j], upper[j]))
                .collect();
            let decrease: f64 = trial
                .iter()
                .zip(&x)
                .zip(&l.gradient)
                .map(|((t, x), g)| g * (t - x))
                .sum();
            let v = value(&trial);
            if v <= l.value + 1e-4 * decrease.min(0.0) && v <= l.value {
                let change: f64 = trial
                    .iter()
                    .zip(&x)
                    .map(|(t, x)| (t - x).abs())
                    .fold(0.0, f64::max);
                moved =
                    change > 1e-13 && l.value - v > min_decrease.max(1e-16 * (1.0 + l.value.abs()));
                x = trial;
                break;
            }
            alpha *= 0.5;
        }
        if !moved {
            break;
        }
    }
    x
}
