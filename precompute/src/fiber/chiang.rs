//! The energy-conserving hair BCSDF of Chiang et al. 2016 as documented in seed 002 (pbrt-v3),
//! sampled exactly after d'Eon et al. 2013.
//!
//! f(wo, wi) |cos theta_i| = sum_{p < P_MAX} M_p(theta_o + shift_p, theta_i) A_p N_p(phi)
//!                         + M_{P_MAX}(theta_o, theta_i) A_{P_MAX} / (2 pi)        (seed 002 eq. 1.1)
//!
//! Scale tilt: the lobe shifts shift_p = (2 alpha, -alpha, -4 alpha) for R, TT, TRT put the R peak
//! at theta_i = -theta_o - 2 alpha, toward the root for alpha > 0 (seed 002's text, Marschner 2003,
//! and Blender Cycles' Offset; pbrt-v3/v4's code rotates theta_o by -2 alpha, the opposite sign:
//! design section 3), and are applied to the fixed direction theta_o rather than to theta_i (as
//! pbrt-v4 does). Each tilted M_p is then still a
//! normalized density over wi, so the sampler is exact, f |cos| / pdf = 1 without absorption, and
//! the model stays energy conserving at every tilt. The price is that the model is normalized in
//! wi for fixed wo, not reciprocal: callers integrate over wi.

use super::attenuation::{P_MAX, ap};
use super::azimuthal::{TrimmedLogistic, phi_p, scale_from_beta_n};
use super::longitudinal::{Longitudinal, variance_from_beta_m};
use super::{FiberModel, FiberParams, FiberSample, ParamError, SpreadScattering};
use crate::conventions::{phi, pick, sin_cos_theta, wrap_angle};
use crate::spectrum::Rgb;
use glam::DVec3;
use std::f64::consts::{FRAC_1_PI, TAU};

/// Chiang et al. 2016 fiber with precomputed per-material constants.
#[derive(Clone, Debug)]
pub struct Chiang {
    sigma_a: Rgb,
    eta: f64,
    /// Longitudinal lobes with variances v_R = v, v_TT = v/4, v_TRT = v_residual = 4 v
    /// (seed 002 section 1.3.1).
    m: [Longitudinal; P_MAX + 1],
    /// Azimuthal distribution about each lobe's deflection.
    n: TrimmedLogistic,
    /// `(sin, cos)` of each lobe's tilt shift of theta_o.
    tilt: [(f64, f64); P_MAX],
}

/// What depends only on the fixed direction wo and the offset h.
struct Incidence {
    sin_o: f64,
    cos_o: f64,
    phi_o: f64,
    gamma_o: f64,
    gamma_t: f64,
    ap: [Rgb; P_MAX + 1],
}

impl Chiang {
    pub fn new(params: &FiberParams) -> Result<Chiang, ParamError> {
        params.validate()?;
        let v0 = variance_from_beta_m(params.beta_m);
        let alpha = params.alpha.to_radians();
        let shift = [2.0 * alpha, -alpha, -4.0 * alpha];
        Ok(Chiang {
            sigma_a: params.sigma_a(),
            eta: params.eta,
            m: [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0].map(Longitudinal::new),
            n: TrimmedLogistic::new(scale_from_beta_n(params.beta_n)),
            tilt: shift.map(f64::sin_cos),
        })
    }

    fn incidence(&self, wo: DVec3, h: f64) -> Incidence {
        let (sin_o, cos_o) = sin_cos_theta(wo);
        let h = h.clamp(-1.0, 1.0);
        // Snell in the normal plane with the modified index eta' = sqrt(eta^2 - sin^2)/cos
        // (Bravais; seed 002 1.3.2), written so that cos theta_o = 0 needs no division by it.
        let sin_gamma_t = h * cos_o / (self.eta * self.eta - sin_o * sin_o).sqrt();
        let cos_gamma_t = (1.0 - sin_gamma_t * sin_gamma_t).max(0.0).sqrt();
        Incidence {
            sin_o,
            cos_o,
            phi_o: phi(wo),
            gamma_o: h.asin(),
            gamma_t: sin_gamma_t.asin(),
            ap: ap(cos_o, sin_o, self.eta, h, self.sigma_a, cos_gamma_t),
        }
    }

    /// `(sin, cos)` of theta_o + shift_p; the cosine may turn negative past pi/2, which M_p and
    /// its sampler handle as the same cone seen from the other side.
    fn tilted(&self, inc: &Incidence, p: usize) -> (f64, f64) {
        if p == P_MAX {
            return (inc.sin_o, inc.cos_o);
        }
        let (sin_d, cos_d) = self.tilt[p];
        (inc.sin_o * cos_d + inc.cos_o * sin_d, inc.cos_o * cos_d - inc.sin_o * sin_d)
    }

    /// Direction density M_p N_p of each lobe at wi (each integrates to 1 over the sphere).
    fn lobe_densities(&self, inc: &Incidence, wi: DVec3) -> [f64; P_MAX + 1] {
        let (sin_i, cos_i) = sin_cos_theta(wi);
        let dphi = phi(wi) - inc.phi_o;
        std::array::from_fn(|p| {
            let (sin_o, cos_o) = self.tilted(inc, p);
            let n = if p < P_MAX { self.n.np(dphi, p, inc.gamma_o, inc.gamma_t) } else { 0.5 * FRAC_1_PI };
            self.m[p].eval(cos_i, sin_i, cos_o, sin_o) * n
        })
    }

    /// Each lobe's N_p averaged over the half circle of azimuths within pi/2 of wi's
    /// ([`SpreadScattering`]); each integrates to 1 over the circle.
    fn half_circle_averages(&self, inc: &Incidence, wi: DVec3) -> [f64; P_MAX + 1] {
        let dphi = phi(wi) - inc.phi_o;
        std::array::from_fn(|p| {
            if p < P_MAX {
                let c = wrap_angle(dphi - phi_p(p, inc.gamma_o, inc.gamma_t));
                self.n.half_circle_mass(c) * FRAC_1_PI
            } else {
                0.5 * FRAC_1_PI
            }
        })
    }
}

/// Lobe-selection probabilities: A_p by luminance, normalized (seed 002 section 1.4.2).
fn lobe_weights(ap: &[Rgb; P_MAX + 1]) -> [f64; P_MAX + 1] {
    let y = ap.map(Rgb::luminance);
    let total: f64 = y.iter().sum();
    y.map(|y| y / total)
}

impl FiberModel for Chiang {
    fn eval(&self, wo: DVec3, wi: DVec3, h: f64) -> Rgb {
        let inc = self.incidence(wo, h);
        let d = self.lobe_densities(&inc, wi);
        (0..=P_MAX).map(|p| inc.ap[p] * d[p]).sum()
    }

    fn sample(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<FiberSample> {
        let inc = self.incidence(wo, h);
        let w = lobe_weights(&inc.ap);
        let (p, _) = pick(&w, u[0]);
        let (sin_o, cos_o) = self.tilted(&inc, p);
        let (sin_i, cos_i) = self.m[p].sample(cos_o, sin_o, u[1], u[2]);
        let dphi = if p < P_MAX { phi_p(p, inc.gamma_o, inc.gamma_t) + self.n.sample(u[3]) } else { TAU * u[3] };
        let (sin_p, cos_p) = (inc.phi_o + dphi).sin_cos();
        let wi = DVec3::new(sin_i, cos_i * cos_p, cos_i * sin_p);

        let d = self.lobe_densities(&inc, wi);
        let pdf: f64 = (0..=P_MAX).map(|p| w[p] * d[p]).sum();
        let value = (0..=P_MAX).map(|p| inc.ap[p] * d[p]).sum();
        (pdf > 0.0 && pdf.is_finite()).then_some(FiberSample { wi, value, pdf })
    }

    fn pdf(&self, wo: DVec3, wi: DVec3, h: f64) -> f64 {
        self.eval_pdf(wo, wi, h).1
    }

    fn eval_pdf(&self, wo: DVec3, wi: DVec3, h: f64) -> (Rgb, f64) {
        let inc = self.incidence(wo, h);
        let w = lobe_weights(&inc.ap);
        let d = self.lobe_densities(&inc, wi);
        ((0..=P_MAX).map(|p| inc.ap[p] * d[p]).sum(), (0..=P_MAX).map(|p| w[p] * d[p]).sum())
    }
}

impl SpreadScattering for Chiang {
    fn eval_spread(&self, wo: DVec3, wi: DVec3, h: f64, spread: Rgb) -> Rgb {
        self.spread_at(&self.incidence(wo, h), wi, spread)
    }

    fn eval_both(&self, wo: DVec3, wi: DVec3, h: f64, spread: Rgb) -> (Rgb, Rgb) {
        let inc = self.incidence(wo, h);
        let d = self.lobe_densities(&inc, wi);
        ((0..=P_MAX).map(|p| inc.ap[p] * d[p]).sum(), self.spread_at(&inc, wi, spread))
    }
}

impl Chiang {
    /// f_s^G for the incidence `inc` (see [`SpreadScattering::eval_spread`]).
    fn spread_at(&self, inc: &Incidence, wi: DVec3, spread: Rgb) -> Rgb {
        let (sin_i, cos_i) = sin_cos_theta(wi);
        let n = self.half_circle_averages(inc, wi);
        let mut out = Rgb::ZERO;
        for (p, n) in n.into_iter().enumerate() {
            let (sin_o, cos_o) = self.tilted(inc, p);
            for c in 0..3 {
                let m = self.m[p].widened(spread.0[c]).eval(cos_i, sin_i, cos_o, sin_o);
                out.0[c] += inc.ap[p].0[c] * m * n;
            }
        }
        out
    }
}
