//! The fiber frame and its angles: the one place where these conventions live.
//!
//! Frame (Marschner et al. 2003; pbrt-v3's hair model, Pharr 2016 section 1.1): a direction is a unit
//! vector in local fiber coordinates with `x` along the tangent `u` (root to tip) and `y`, `z`
//! spanning the normal plane (`v`, `w`).
//! - `theta` in [-pi/2, pi/2] is the inclination from the normal plane; `sin(theta) = x`, and
//!   `theta = pi/2` points along `+u`.
//! - `phi` in (-pi, pi] is the azimuth in the normal plane, measured from `+v` toward `+w`.
//! - `h` in [-1, 1] is the offset across the fiber of the hit; `gamma = asin(h)`.
//!
//! All angles are in radians, except the user-facing scale tilt `alpha`, which is in degrees.

use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// Unit direction from inclination `theta` and azimuth `phi` (radians).
pub fn direction(theta: f64, phi: f64) -> DVec3 {
    let (sin_t, cos_t) = theta.sin_cos();
    let (sin_p, cos_p) = phi.sin_cos();
    DVec3::new(sin_t, cos_t * cos_p, cos_t * sin_p)
}

/// A direction uniformly distributed over the sphere (density 1 / [`SPHERE`]) from two uniform
/// numbers in [0, 1): the x component is uniform in [-1, 1] (Archimedes), the azimuth about x too.
pub fn uniform_sphere(u: [f64; 2]) -> DVec3 {
    let x = 1.0 - 2.0 * u[0];
    let r = (1.0 - x * x).max(0.0).sqrt();
    let (s, c) = (TAU * u[1]).sin_cos();
    DVec3::new(x, r * c, r * s)
}

/// Picks index k with probability `w[k]` (weights summing to 1) from u in [0, 1), and returns u
/// rescaled to [0, 1) within the picked share so that the number can be used again.
pub fn pick(w: &[f64], u: f64) -> (usize, f64) {
    let mut rest = u;
    let mut k = 0;
    while k + 1 < w.len() && rest >= w[k] {
        rest -= w[k];
        k += 1;
    }
    let rescaled = rest / w[k];
    (k, if rescaled.is_finite() { rescaled.clamp(0.0, 1.0 - f64::EPSILON) } else { 0.5 })
}

/// `(sin theta, cos theta)` of a unit direction, robust to `|x|` rounding past 1.
pub fn sin_cos_theta(w: DVec3) -> (f64, f64) {
    let s = w.x.clamp(-1.0, 1.0);
    (s, (1.0 - s * s).max(0.0).sqrt())
}

/// Inclination `theta` of a unit direction.
pub fn theta(w: DVec3) -> f64 {
    sin_cos_theta(w).0.asin()
}

/// Azimuth `phi` of a direction in the normal plane.
pub fn phi(w: DVec3) -> f64 {
    w.z.atan2(w.y)
}

/// Offset `h = sin(gamma_o)` of a hit across the fiber, from the direction toward the viewer `wo`
/// and the surface normal `n` at the hit, both in the fiber frame.
///
/// gamma_o = phi_o - phi_n: then the mirror direction of `wo` about `n` in the normal plane has
/// azimuth phi_o - 2 gamma_o, which is the deflection Phi(0, h) = -2 gamma_o of the R lobe
/// (Pharr 2016 section 1.3.3). Returns 0 where either direction has no normal-plane component.
pub fn h_offset(wo: DVec3, n: DVec3) -> f64 {
    let (o, m) = ((wo.y, wo.z), (n.y, n.z));
    let norm = (o.0 * o.0 + o.1 * o.1).sqrt() * (m.0 * m.0 + m.1 * m.1).sqrt();
    if norm > 0.0 { ((o.1 * m.0 - o.0 * m.1) / norm).clamp(-1.0, 1.0) } else { 0.0 }
}

/// An angle wrapped into [-pi, pi].
pub fn wrap_angle(x: f64) -> f64 {
    x - TAU * (x / TAU).round()
}

/// Luminance of a linear Rec. 709 RGB triple: the scalar the samplers use for spectral weights.
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Solid angle of the whole sphere.
pub const SPHERE: f64 = 4.0 * PI;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn h_offset_matches_the_r_lobe_deflection() {
        // Reflect wo about the normal in the normal plane; its azimuth must be phi_o - 2 asin(h).
        for (phi_o, phi_n) in [(0.3, 0.9), (2.0, 1.2), (-2.9, 2.8), (0.0, -1.4)] {
            let wo = direction(0.4, phi_o);
            let n = DVec3::new(0.0, f64::cos(phi_n), f64::sin(phi_n));
            let h = h_offset(wo, n);
            let reflected = 2.0 * phi_n - phi_o;
            assert!(wrap_angle(reflected - (phi_o - 2.0 * h.asin())).abs() < 1e-12, "{phi_o} {phi_n}");
        }
    }
}
