//! Longitudinal scattering M_p of d'Eon et al. 2011 (Pharr 2016 eq. 1.3) and its exact sampler
//! (d'Eon et al. 2013).
//!
//! M_p(theta_o, theta_i) = exp(-sin theta_o sin theta_i / v) I0(cos theta_o cos theta_i / v)
//!                         / (2 v sinh(1/v)),
//! normalized as a density of theta_i with measure cos(theta_i) d theta_i. It is the marginal, over
//! the cone's azimuth, of a von Mises-Fisher distribution on the sphere with concentration 1/v
//! centered on the mirror direction (inclination -theta_o), which is what makes exact sampling work.

use crate::special::i0e_parts;

/// Longitudinal variance `v` from the user roughness `beta_m` in [0, 1] (Pharr 2016 section 1.3.1,
/// pbrt-v3 = Cycles): v = (0.726 beta + 0.812 beta^2 + 3.7 beta^20)^2.
pub fn variance_from_beta_m(beta_m: f64) -> f64 {
    (0.726 * beta_m + 0.812 * beta_m * beta_m + 3.7 * beta_m.powi(20)).powi(2)
}

/// One longitudinal lobe of variance `v > 0`, with its normalization precomputed.
#[derive(Clone, Copy, Debug)]
pub struct Longitudinal {
    v: f64,
    /// 1 / (v (1 - e^(-2/v))) = e^(-1/v) / (2 v sinh(1/v)): the normalization with the e^(1/v)
    /// that would overflow for small v taken out (finite for every v > 0).
    norm: f64,
}

impl Longitudinal {
    pub fn new(v: f64) -> Longitudinal {
        // 1 - e^(-2/v): below v = 0.05 it rounds to 1; up to v = 2 (2/v >= 1) the subtraction
        // loses at most one bit, so exp serves (expm1 costs about twice as much); beyond, expm1
        // keeps the precision.
        let tail = if v < 0.05 {
            1.0
        } else if v <= 2.0 {
            1.0 - (-2.0 / v).exp()
        } else {
            -(-2.0 / v).exp_m1()
        };
        Longitudinal { v, norm: 1.0 / (v * tail) }
    }

    /// The same lobe widened by an extra variance (variances add under convolution).
    pub fn widened(&self, extra: f64) -> Longitudinal {
        Longitudinal::new(self.v + extra)
    }

    /// M_p from the sines and cosines of both inclinations, finite for every `v > 0`.
    ///
    /// With a = cos_o cos_i / v and b = sin_o sin_i / v:
    /// M_p = e^-|a| I0(a) * exp(|a| - b - 1/v) / (v (1 - e^(-2/v))), where |a| - b - 1/v <= 0,
    /// so the exponential is at most 1. This replaces pbrt's two-branch formula (Pharr 2016's `Mp`)
    /// with one that neither overflows for tiny v nor loses precision for large v.
    pub fn eval(&self, cos_i: f64, sin_i: f64, cos_o: f64, sin_o: f64) -> f64 {
        let exponent = ((cos_i * cos_o).abs() - sin_i * sin_o - 1.0) / self.v;
        let (m, e) = i0e_parts(cos_i * cos_o / self.v);
        m * (exponent + e).exp() * self.norm
    }

    /// Samples `(sin theta_i, cos theta_i)` with density M_p(theta_o, .) cos(theta_i) from two
    /// uniform numbers in [0, 1). The cone angle t about the mirror direction follows
    /// cos(t) = 1 + v ln(u1 + (1 - u1) e^(-2/v)) (d'Eon 2013), and u2 picks the azimuth on the cone.
    pub fn sample(&self, cos_o: f64, sin_o: f64, u1: f64, u2: f64) -> (f64, f64) {
        let v = self.v;
        // m = 1 - cos(t) in [0, 2], computed directly so small cone angles keep their precision.
        let m = (-v * (u1 + (1.0 - u1) * (-2.0 / v).exp()).ln()).clamp(0.0, 2.0);
        let cos_t = 1.0 - m;
        let sin_t = (m * (2.0 - m)).sqrt();
        // The mirror direction has inclination -theta_o; rotate the cone sample about it.
        let sin_i = (-cos_t * sin_o + sin_t * (std::f64::consts::TAU * u2).cos() * cos_o).clamp(-1.0, 1.0);
        (sin_i, (1.0 - sin_i * sin_i).max(0.0).sqrt())
    }
}

/// M_p for a single evaluation (see [`Longitudinal::eval`]).
pub fn mp(cos_i: f64, sin_i: f64, cos_o: f64, sin_o: f64, v: f64) -> f64 {
    Longitudinal::new(v).eval(cos_i, sin_i, cos_o, sin_o)
}
