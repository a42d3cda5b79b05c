//! The energy-conserving hair BCSDF of Chiang et al. 2016 as documented in Pharr 2016 (pbrt-v3's hair model),
//! sampled exactly after d'Eon et al. 2013.
//!
//! f(wo, wi) |cos theta_i| = sum_{p < P_MAX} M_p(theta_o + shift_p, theta_i) A_p N_p(phi)
//!                         + M_{P_MAX}(theta_o, theta_i) A_{P_MAX} / (2 pi)        (Pharr 2016 eq. 1.1)
//!
//! Scale tilt: the lobe shifts shift_p = (2 alpha, -alpha, -4 alpha) for R, TT, TRT put the R peak
//! at theta_i = -theta_o - 2 alpha, toward the root for alpha > 0 (Pharr 2016's text, Marschner 2003,
//! and Blender Cycles' Offset; pbrt-v3/v4's code rotates theta_o by -2 alpha, the opposite sign:
//! see [`crate::conventions`]), and are applied to the fixed direction theta_o rather than to theta_i (as
//! pbrt-v4 does). Each tilted M_p is then still a
//! normalized density over wi, so the sampler is exact, f |cos| / pdf = 1 without absorption, and
//! the model stays energy conserving at every tilt. The price is that the model is normalized in
//! wi for fixed wo, not reciprocal: callers integrate over wi.

use super::attenuation::{P_MAX, ap};
use super::azimuthal::{TrimmedLogistic, phi_p, scale_from_beta_n};
use super::longitudinal::{Longitudinal, variance_from_beta_m};
use super::model::{Model, TableFeatures, r_width};
use super::{FiberHit, FiberModel, FiberParams, FiberSample, ParamError, SpreadHit};
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
    /// (Pharr 2016 section 1.3.1); [`ChiangHit`]'s spread response relies on the last two being
    /// equal.
    m: [Longitudinal; P_MAX + 1],
    /// Azimuthal distribution about each lobe's deflection.
    n: TrimmedLogistic,
    /// `(sin, cos)` of each lobe's tilt shift of theta_o.
    tilt: [(f64, f64); P_MAX],
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
}

impl Model for Chiang {
    const NAME: &'static str = "chiang";
    const HELP: &'static str = "Chiang et al. 2016; --beta-m, --beta-n, --alpha";
    const TITLE: &'static str = "Chiang";
    const CAPTION: &'static str = "Chiang fiber";
    const FAR_FIELD: bool = false;
    const EXACT_LABEL: &'static str = "chiang-dEon2013";

    fn build(params: &FiberParams, _flawed: bool) -> Result<Chiang, ParamError> {
        Chiang::new(params)
    }

    /// Panels `width` logistic scales wide ([`crate::quadrature::h_rule`]).
    fn h_rule(params: &FiberParams, width: f64) -> Vec<(f64, f64)> {
        crate::quadrature::h_rule(width * scale_from_beta_n(params.beta_n), 1)
    }

    /// The logistic scale of beta_n and the longitudinal variance of beta_m.
    fn table_features(params: &FiberParams) -> TableFeatures {
        TableFeatures::new(scale_from_beta_n(params.beta_n), variance_from_beta_m(params.beta_m))
    }

    /// beta_m from the R lobe's variance polynomial, beta_n = beta_m.
    fn set_grid_roughness(params: &mut FiberParams, beta: f64) {
        params.beta_m = beta_m_of_width(r_width(beta));
        params.beta_n = params.beta_m;
    }

    fn describe(params: &FiberParams) -> String {
        format!("beta_m {}, beta_n {}, alpha {} deg, eta {}", params.beta_m, params.beta_n, params.alpha, params.eta)
    }
}

/// The beta_m whose R standard deviation (Pharr 2016 section 1.3.1: sqrt(v) = 0.726 b +
/// 0.812 b^2 + 3.7 b^20) is `width`, by bisection on that increasing polynomial; clamped to 1.
fn beta_m_of_width(width: f64) -> f64 {
    let sd = |b: f64| 0.726 * b + 0.812 * b * b + 3.7 * b.powi(20);
    let (mut lo, mut hi) = (0.0, 1.0);
    if sd(hi) <= width {
        return hi;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if sd(mid) < width { lo = mid } else { hi = mid }
    }
    hi
}

/// A [`Chiang`] fiber at one hit: everything that depends only on the fixed direction wo and the
/// offset h (Fresnel, absorption, refraction, the tilted inclinations, the lobes' deflections).
pub struct ChiangHit<'a> {
    fiber: &'a Chiang,
    phi_o: f64,
    /// `(sin, cos)` of theta_o + shift_p per lobe (the residual is not tilted); the cosine may
    /// turn negative past pi/2, which M_p and its sampler handle as the same cone seen from the
    /// other side.
    tilted: [(f64, f64); P_MAX + 1],
    /// Azimuthal deflection Phi(p, h) of each lobe p < P_MAX.
    deflection: [f64; P_MAX],
    ap: [Rgb; P_MAX + 1],
    /// Lobe-selection probabilities: A_p by luminance, normalized (Pharr 2016 section 1.4.2).
    weights: [f64; P_MAX + 1],
}

/// What every lobe needs of a direction wi: its inclination's sine and cosine and its azimuth
/// relative to wo's.
struct Incoming {
    sin_i: f64,
    cos_i: f64,
    dphi: f64,
}

impl ChiangHit<'_> {
    fn incoming(&self, wi: DVec3) -> Incoming {
        let (sin_i, cos_i) = sin_cos_theta(wi);
        Incoming { sin_i, cos_i, dphi: phi(wi) - self.phi_o }
    }

    /// Direction density M_p N_p of each lobe at wi (each integrates to 1 over the sphere).
    fn lobe_densities(&self, d: &Incoming) -> [f64; P_MAX + 1] {
        self.lobe_densities_with(d, &self.longitudinal(d))
    }

    /// M_p of each lobe at wi: it depends on wo and wi, not on the offset h.
    fn longitudinal(&self, d: &Incoming) -> [f64; P_MAX + 1] {
        std::array::from_fn(|p| {
            let (sin_o, cos_o) = self.tilted[p];
            self.fiber.m[p].eval(d.cos_i, d.sin_i, cos_o, sin_o)
        })
    }

    /// [`ChiangHit::lobe_densities`] with each lobe's M_p given.
    fn lobe_densities_with(&self, d: &Incoming, m: &[f64; P_MAX + 1]) -> [f64; P_MAX + 1] {
        std::array::from_fn(|p| {
            let n = if p < P_MAX { self.fiber.n.pdf(wrap_angle(d.dphi - self.deflection[p])) } else { 0.5 * FRAC_1_PI };
            m[p] * n
        })
    }

    fn value(&self, densities: &[f64; P_MAX + 1]) -> Rgb {
        (0..=P_MAX).map(|p| self.ap[p] * densities[p]).sum()
    }

    /// f_s^G at `d` (see [`SpreadHit::eval_spread`]): each N_p averaged over the half circle of
    /// azimuths within pi/2 of wi's (each still integrates to 1 over the circle), each M_p
    /// widened by the channel's spread.
    fn spread(&self, d: &Incoming, spread: Rgb) -> Rgb {
        let n: [f64; P_MAX + 1] = std::array::from_fn(|p| {
            if p < P_MAX {
                self.fiber.n.half_circle_mass(wrap_angle(d.dphi - self.deflection[p])) * FRAC_1_PI
            } else {
                0.5 * FRAC_1_PI
            }
        });
        let mut out = Rgb::ZERO;
        for c in 0..3 {
            // The residual's variance is TRT's (4 v), so it shares TRT's widened lobe.
            let widened: [Longitudinal; P_MAX] = std::array::from_fn(|p| self.fiber.m[p].widened(spread.0[c]));
            for p in 0..=P_MAX {
                let (sin_o, cos_o) = self.tilted[p];
                let m = widened[p.min(P_MAX - 1)].eval(d.cos_i, d.sin_i, cos_o, sin_o);
                out.0[c] += self.ap[p].0[c] * m * n[p];
            }
        }
        out
    }
}

impl FiberModel for Chiang {
    type Hit<'a> = ChiangHit<'a>;

    fn at(&self, wo: DVec3, h: f64) -> ChiangHit<'_> {
        let (sin_o, cos_o) = sin_cos_theta(wo);
        let h = h.clamp(-1.0, 1.0);
        // Snell in the normal plane with the modified index eta' = sqrt(eta^2 - sin^2)/cos
        // (Bravais; Pharr 2016 section 1.3.2), written so that cos theta_o = 0 needs no division by it.
        let sin_gamma_t = h * cos_o / (self.eta * self.eta - sin_o * sin_o).sqrt();
        let cos_gamma_t = (1.0 - sin_gamma_t * sin_gamma_t).max(0.0).sqrt();
        let (gamma_o, gamma_t) = (h.asin(), sin_gamma_t.asin());
        let ap = ap(cos_o, sin_o, self.eta, h, self.sigma_a, cos_gamma_t);
        let tilted = std::array::from_fn(|p| {
            if p == P_MAX {
                return (sin_o, cos_o);
            }
            let (sin_d, cos_d) = self.tilt[p];
            (sin_o * cos_d + cos_o * sin_d, cos_o * cos_d - sin_o * sin_d)
        });
        let y = ap.map(Rgb::luminance);
        let total: f64 = y.iter().sum();
        ChiangHit {
            fiber: self,
            phi_o: phi(wo),
            tilted,
            deflection: std::array::from_fn(|p| phi_p(p, gamma_o, gamma_t)),
            ap,
            weights: y.map(|y| y / total),
        }
    }

    /// Each direction's angles and M_p once for all offsets, not once per offset: the default
    /// fiber's tables take a quarter of the time (M_p's exponential was most of it).
    fn eval_h_average(&self, wo: DVec3, rule: &[(f64, f64)], wis: &[DVec3], out: &mut [Rgb]) {
        let hits: Vec<_> = rule.iter().map(|&(h, w)| (self.at(wo, h), w)).collect();
        let Some((first, _)) = hits.first() else {
            out.fill(Rgb::ZERO);
            return;
        };
        for (wi, o) in wis.iter().zip(out) {
            // phi_o and the tilted inclinations depend on wo alone: the same at every hit.
            let d = first.incoming(*wi);
            let m = first.longitudinal(&d);
            *o = hits.iter().map(|(hit, w)| hit.value(&hit.lobe_densities_with(&d, &m)) * *w).sum();
        }
    }
}

impl FiberHit for ChiangHit<'_> {
    fn eval(&self, wi: DVec3) -> Rgb {
        self.value(&self.lobe_densities(&self.incoming(wi)))
    }

    fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
        let (p, _) = pick(&self.weights, u[0]);
        let (sin_o, cos_o) = self.tilted[p];
        let (sin_i, cos_i) = self.fiber.m[p].sample(cos_o, sin_o, u[1], u[2]);
        let dphi = if p < P_MAX { self.deflection[p] + self.fiber.n.sample(u[3]) } else { TAU * u[3] };
        let (sin_p, cos_p) = (self.phi_o + dphi).sin_cos();
        let wi = DVec3::new(sin_i, cos_i * cos_p, cos_i * sin_p);
        let (value, pdf) = self.eval_pdf(wi);
        (pdf > 0.0 && pdf.is_finite()).then_some(FiberSample { wi, value, pdf })
    }

    fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        let d = self.lobe_densities(&self.incoming(wi));
        (self.value(&d), (0..=P_MAX).map(|p| self.weights[p] * d[p]).sum())
    }
}

impl SpreadHit for ChiangHit<'_> {
    fn eval_spread(&self, wi: DVec3, spread: Rgb) -> Rgb {
        self.spread(&self.incoming(wi), spread)
    }

    fn eval_both(&self, wi: DVec3, spread: Rgb) -> (Rgb, Rgb) {
        let d = self.incoming(wi);
        (self.value(&self.lobe_densities(&d)), self.spread(&d, spread))
    }
}
