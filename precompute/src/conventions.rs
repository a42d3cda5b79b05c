//! The fiber frame and its angles: the one place where these conventions live.
//!
//! Frame (Marschner et al. 2003; pbrt-v3 hair, seed 002 section 1.1): a direction is a unit
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

/// `(sin theta, cos theta)` of a unit direction, robust to `|x|` rounding past 1.
pub fn sin_cos_theta(w: DVec3) -> (f64, f64) {
    let s = w.x.clamp(-1.0, 1.0);
    (s, (1.0 - s * s).max(0.0).sqrt())
}

/// Azimuth `phi` of a direction in the normal plane.
pub fn phi(w: DVec3) -> f64 {
    w.z.atan2(w.y)
}

/// An angle wrapped into [-pi, pi].
pub fn wrap_angle(x: f64) -> f64 {
    x - TAU * (x / TAU).round()
}

/// Luminance of a linear Rec. 709 RGB triple: the scalar the samplers use for spectral weights.
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Solid angle of the whole sphere.
pub const SPHERE: f64 = 4.0 * PI;
