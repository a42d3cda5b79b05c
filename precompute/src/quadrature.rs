//! Deterministic quadrature: composite Gauss-Legendre rules, and the rule over a fiber's width.

use std::f64::consts::{FRAC_PI_2, PI};

/// Nodes and weights of the `n`-point Gauss-Legendre rule on [-1, 1] (Newton on P_n, f64).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    assert!(n > 0, "a quadrature rule needs at least one node");
    (0..n)
        .map(|i| {
            // Tricomi's initial guess, then Newton iterations on the Legendre recurrence.
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                // Here p1 = P_n(x) and p0 = P_{n-1}(x).
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// A composite rule on [a, b]: `panels` equal panels with an `order`-point Gauss-Legendre rule each.
/// Returns `(node, weight)` pairs whose weights sum to `b - a`.
pub fn composite(a: f64, b: f64, panels: usize, order: usize) -> Vec<(f64, f64)> {
    let rule = gauss_legendre(order);
    let width = (b - a) / panels as f64;
    (0..panels)
        .flat_map(|k| {
            let mid = a + (k as f64 + 0.5) * width;
            rule.iter().map(move |&(x, w)| (mid + 0.5 * width * x, 0.5 * width * w))
        })
        .collect()
}

/// Quadrature nodes over h with weights summing to 1/2 * 2 = 1, i.e. the mean over h in [-1, 1].
///
/// Integrated in gamma = asin(h) (dh = cos(gamma) dgamma), which removes the square-root
/// singularity of Phi(p, h) at h = +-1. The azimuthal lobes move at most ~4 radians per radian of
/// gamma, so panels a quarter of the logistic scale `s` wide resolve them; `s` comes from the
/// caller (the model's roughness), and the result is checked to 0.1% by the tests.
pub fn h_rule(s: f64, refine: usize) -> Vec<(f64, f64)> {
    let panels = ((PI / (0.25 * s)).ceil() as usize).clamp(16, 1 << 16) * refine.max(1);
    composite(-FRAC_PI_2, FRAC_PI_2, panels, 4).into_iter().map(|(g, w)| (g.sin(), 0.5 * w * g.cos())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_exactly() {
        // An n-point rule is exact for degree 2n - 1.
        for n in 1..12 {
            let rule = gauss_legendre(n);
            for deg in 0..(2 * n) {
                let got: f64 = rule.iter().map(|&(x, w)| w * x.powi(deg as i32)).sum();
                let want = if deg % 2 == 1 { 0.0 } else { 2.0 / (deg as f64 + 1.0) };
                assert!((got - want).abs() < 1e-13, "n={n} deg={deg}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn composite_integrates_sine() {
        let got: f64 = composite(0.0, std::f64::consts::PI, 7, 5).iter().map(|&(x, w)| w * x.sin()).sum();
        assert!((got - 2.0).abs() < 1e-12, "{got}");
    }
}
