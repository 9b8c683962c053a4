//! Numerical integration for the derived tables (the coat integral C, the lobe
//! normalisation, the glossmeter).
//!
//! Gauss–Legendre rules are computed once per order by Newton iteration on the
//! Legendre recurrence (accurate to a few ulp), then reused. The adaptive rule
//! compares one panel against its two halves and splits where they disagree; the
//! integrands here are smooth but can have boundary layers (large optical depth,
//! sharp lobes), which is exactly what bisection handles well.

use std::sync::OnceLock;

/// Nodes and weights of an n-point Gauss–Legendre rule on [-1, 1].
#[derive(Debug, Clone)]
pub struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    /// Computes the rule of the given order (≥ 1).
    pub fn new(order: usize) -> Self {
        let order = order.max(1);
        let mut nodes = vec![0.0; order];
        let mut weights = vec![0.0; order];
        let n = order as f64;
        for i in 0..order.div_ceil(2) {
            // Tricomi's initial guess converges in a handful of Newton steps.
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n + 0.5)).cos();
            let mut derivative = 0.0;
            for _ in 0..100 {
                let (p, dp) = legendre_with_derivative(order, x);
                derivative = dp;
                let step = p / dp;
                x -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            let (_, dp) = legendre_with_derivative(order, x);
            if dp != 0.0 {
                derivative = dp;
            }
            let w = 2.0 / ((1.0 - x * x) * derivative * derivative);
            nodes[i] = -x;
            nodes[order - 1 - i] = x;
            weights[i] = w;
            weights[order - 1 - i] = w;
        }
        Self { nodes, weights }
    }

    /// Shared 10-point rule: exact for polynomials of degree 19.
    pub fn order10() -> &'static GaussLegendre {
        static RULE: OnceLock<GaussLegendre> = OnceLock::new();
        RULE.get_or_init(|| GaussLegendre::new(10))
    }

    /// Shared 6-point rule, for the many small panels of the glossmeter.
    pub fn order6() -> &'static GaussLegendre {
        static RULE: OnceLock<GaussLegendre> = OnceLock::new();
        RULE.get_or_init(|| GaussLegendre::new(6))
    }

    /// The nodes on [-1, 1].
    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// The weights (sum to 2).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// ∫ₐᵇ f with this rule on one panel.
    pub fn integrate(&self, a: f64, b: f64, mut f: impl FnMut(f64) -> f64) -> f64 {
        let half = 0.5 * (b - a);
        let mid = 0.5 * (a + b);
        let mut sum = 0.0;
        for (x, w) in self.nodes.iter().zip(&self.weights) {
            sum += w * f(mid + half * x);
        }
        sum * half
    }

    /// Calls `visit(x, weight)` for each node mapped to [a, b]; for tensor products.
    pub fn for_each_node(&self, a: f64, b: f64, mut visit: impl FnMut(f64, f64)) {
        let half = 0.5 * (b - a);
        let mid = 0.5 * (a + b);
        for (x, w) in self.nodes.iter().zip(&self.weights) {
            visit(mid + half * x, w * half);
        }
    }
}

fn legendre_with_derivative(order: usize, x: f64) -> (f64, f64) {
    let mut p_prev = 1.0;
    let mut p = x;
    for k in 2..=order {
        let k = k as f64;
        let p_next = ((2.0 * k - 1.0) * x * p - (k - 1.0) * p_prev) / k;
        p_prev = p;
        p = p_next;
    }
    if order == 1 {
        p_prev = 1.0;
    }
    let n = order as f64;
    let dp = n * (x * p - p_prev) / (x * x - 1.0);
    (p, dp)
}

/// Adaptive Gauss–Legendre integration of a smooth integrand on [a, b].
///
/// Panels are bisected until the 10-point rule on the panel and on its two halves
/// agree to `abs_tol` scaled by the panel's share of [a, b]. `abs_tol` should be the
/// wanted relative accuracy times a rough size of the integral (the integrands here
/// are non-negative, so [`integrate_relative`] does that for the caller).
pub fn integrate_adaptive(
    f: &mut impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    abs_tol: f64,
    max_depth: u32,
) -> f64 {
    let rule = GaussLegendre::order10();
    let whole = rule.integrate(a, b, &mut *f);
    adaptive_step(f, rule, a, b, whole, abs_tol, max_depth)
}

fn adaptive_step(
    f: &mut impl FnMut(f64) -> f64,
    rule: &GaussLegendre,
    a: f64,
    b: f64,
    whole: f64,
    abs_tol: f64,
    depth_left: u32,
) -> f64 {
    let mid = 0.5 * (a + b);
    let left = rule.integrate(a, mid, &mut *f);
    let right = rule.integrate(mid, b, &mut *f);
    let halves = left + right;
    // A tolerance below the rounding noise of the panel sum can never be met;
    // accepting there keeps the recursion finite on any integrand.
    let noise_floor = 64.0 * f64::EPSILON * (left.abs() + right.abs());
    let error = (halves - whole).abs();
    if depth_left == 0 || error <= abs_tol.max(noise_floor) || mid <= a || mid >= b {
        return halves;
    }
    let tol = 0.5 * abs_tol;
    adaptive_step(f, rule, a, mid, left, tol, depth_left - 1)
        + adaptive_step(f, rule, mid, b, right, tol, depth_left - 1)
}

/// Integrates a non-negative integrand to a relative accuracy `rel_tol`.
///
/// Globally adaptive: starts from 8 equal panels and keeps bisecting the panel with
/// the largest error estimate (10-point rule against its two halves) until the
/// summed estimate is below `rel_tol` times the integral. A budget of panels bounds
/// the work on integrands that cannot meet the tolerance (rounding noise, a
/// singularity); the result is then the best estimate found.
pub fn integrate_relative(f: impl FnMut(f64) -> f64, a: f64, b: f64, rel_tol: f64) -> f64 {
    integrate_relative_from(f, a, b, rel_tol, 8)
}

/// [`integrate_relative`] starting from `initial_panels` equal panels: fewer for
/// smooth integrands evaluated often (each panel costs 30 evaluations up front).
pub fn integrate_relative_from(
    mut f: impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    rel_tol: f64,
    initial_panels: usize,
) -> f64 {
    if b <= a {
        return 0.0;
    }
    let initial_panels = initial_panels.max(1);
    const MAX_PANELS: usize = 4000;
    let rule = GaussLegendre::order10();
    let mut evaluate = |lo: f64, hi: f64| {
        let mid = 0.5 * (lo + hi);
        let whole = rule.integrate(lo, hi, &mut f);
        let left = rule.integrate(lo, mid, &mut f);
        let right = rule.integrate(mid, hi, &mut f);
        let noise_floor = 64.0 * f64::EPSILON * (left.abs() + right.abs());
        let error = ((left + right) - whole).abs();
        Panel {
            lo,
            hi,
            left,
            right,
            error: if error <= noise_floor { 0.0 } else { error },
        }
    };
    let width = (b - a) / initial_panels as f64;
    let mut panels: Vec<Panel> = (0..initial_panels)
        .map(|i| {
            let lo = a + width * i as f64;
            evaluate(
                lo,
                if i + 1 == initial_panels {
                    b
                } else {
                    lo + width
                },
            )
        })
        .collect();
    loop {
        let total: f64 = panels.iter().map(|p| p.left + p.right).sum();
        let error: f64 = panels.iter().map(|p| p.error).sum();
        if error <= rel_tol * total.abs() || panels.len() >= MAX_PANELS || !error.is_finite() {
            return total;
        }
        // Split the worst panels: all whose error exceeds an equal share of the budget.
        let share = rel_tol * total.abs() / panels.len() as f64;
        let mut next = Vec::with_capacity(panels.len() * 2);
        let mut split_any = false;
        for p in panels {
            let mid = 0.5 * (p.lo + p.hi);
            if p.error > share && mid > p.lo && mid < p.hi && next.len() + 2 < MAX_PANELS {
                next.push(evaluate(p.lo, mid));
                next.push(evaluate(mid, p.hi));
                split_any = true;
            } else {
                next.push(p);
            }
        }
        panels = next;
        if !split_any {
            return panels.iter().map(|p| p.left + p.right).sum();
        }
    }
}

struct Panel {
    lo: f64,
    hi: f64,
    left: f64,
    right: f64,
    error: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_for_polynomials_of_degree_2n_minus_1() {
        for order in [1, 2, 5, 10, 16] {
            let rule = GaussLegendre::new(order);
            let degree = 2 * order - 1;
            let got = rule.integrate(0.0, 1.0, |x| x.powi(degree as i32));
            let want = 1.0 / (degree as f64 + 1.0);
            assert!((got - want).abs() < 1e-14, "order {order}: {got} vs {want}");
            let weight_sum: f64 = rule.weights().iter().sum();
            assert!((weight_sum - 2.0).abs() < 1e-14);
        }
    }

    #[test]
    fn adaptive_resolves_a_boundary_layer() {
        // ∫₀¹ e^{-1000 (1-x)} dx = (1 - e^{-1000}) / 1000.
        let got = integrate_relative(|x| (-1000.0 * (1.0 - x)).exp(), 0.0, 1.0, 1e-12);
        assert!((got * 1000.0 - 1.0).abs() < 1e-11, "{got}");
    }

    #[test]
    fn adaptive_handles_an_endpoint_square_root() {
        // ∫₀¹ sqrt(x) dx = 2/3: algebraic singularity at 0.
        let got = integrate_relative(f64::sqrt, 0.0, 1.0, 1e-10);
        assert!((got - 2.0 / 3.0).abs() < 1e-9, "{got}");
    }
}
