//! Marschner et al. 2003 as Lemein 2020's MSc thesis uses it (section 3.2.2, eqs. 3.1-3.12), with
//! the thesis's d'Eon-style sampler (Lemein 2020 section 4.3).
//!
//! f(wo, wi) = sum_{p = R, TT, TRT} M_p N_p(phi) / cos^2 theta_d                       (eq. 3.1)
//!
//! - M_p = g(beta_p, theta_i + theta_o - alpha_p): a unit-integral Gaussian of standard deviation
//!   beta_p in the thesis's form g(beta, 2 theta_h - alpha) (eqs. 3.2-3.4; Marschner's own form is
//!   g(beta, theta_h - alpha), whose lobes are twice as wide in theta_i and carry twice the energy).
//!   Marschner's alpha_R is negative for scales that put R toward the root: alpha_R = -7.5 degrees
//!   here is a scale tilt of 3.75 degrees in [`super::FiberParams::alpha`]'s (Cycles') sign.
//! - N_p(phi) = sum over the roots h of Phi(p, h) = phi of A(p, h) / |2 dPhi/dh| (eq. 3.7 with the
//!   factor 2 it drops: then N_p integrates over phi to the mean of A over h in [-1, 1]), with
//!   Phi(p, h) = 2 p gamma_t - 2 gamma_i + p pi (eq. 3.5), gamma_i = asin h and
//!   gamma_t = asin(h / eta') (not asin(h) / eta as printed), eta' the Bravais index of theta_d.
//!   Roots are found exactly (bracketed Newton on each interval where Phi is monotone).
//! - A(0, h) = F, A(1, h) = (1 - F)^2 T, A(2, h) = (1 - F)^2 F T^2 (eqs. 3.8-3.9): F the
//!   unpolarized Fresnel reflectance at the true angle of incidence, cos = cos theta_d cos gamma_i
//!   (as pbrt computes it; Marschner splits it into two polarizations with the Bravais indices),
//!   which is also the internal reflectance; T = exp(-sigma_a l) (not exp(+sigma_a l) as printed),
//!   l = 2 cos gamma_t / cos theta_t with cos theta_t = sqrt(1 - sin^2 theta_d / eta^2) (eq. 3.6's
//!   theta_t is wrong), sigma_a per unit radius.
//! - The TRT caustic (Marschner 2003 section 4.3, which the thesis's "Glints" paragraph cites): the
//!   root sum is faded out about the caustic azimuths +-phi_c and a Gaussian glint of width w_c and
//!   scale k_G put there; above eta' = 2 the caustics merge at phi = 0 and fade out over
//!   [2, 2 + delta_eta'] (t = 1 - smoothstep; the paper prints smoothstep, which would fade them in).
//!
//! The model is not energy conserving (the Gaussians lose what falls beyond +-pi/2, and 1 /
//! cos^2 theta_d is not a normalization): its albedo over theta is measured, not assumed. It is
//! reciprocal: f(wo, wi) = f(wi, wo).
//!
//! Sampling (Lemein 2020 section 4.3): h uniform in [-1, 1]; a lobe with probability proportional to
//! the luminance of A_spec(p, h) (eqs. 4.2-4.4, at theta_o); theta_i from d'Eon 2013's cone about
//! theta_i = alpha_p - theta_o with variance beta_p^2 (eqs. 4.9-4.12); phi_i = phi_o + Phi(p, h) +
//! beta_p z with z standard normal (eq. 4.14), eta' taken at theta_o. Two densities go with it:
//! [`MarschnerPdf::Exact`], the density the sampler really has (the h integral done numerically),
//! and [`MarschnerPdf::Thesis`], the one the thesis states: the model with each A replaced by its
//! selection weight. The second is not the sampler's density, so estimates with it are biased.

use super::attenuation::fresnel_dielectric;
use super::longitudinal::Longitudinal;
use super::model::{FlawedSampler, Model, TableFeatures, r_width};
use super::params::check;
use super::{FiberHit, FiberModel, FiberParams, FiberSample, ModelKind, ParamError, SamplerKind, SpreadHit};
use crate::conventions::{phi, pick, sin_cos_theta, wrap_angle};
use crate::spectrum::Rgb;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::OnceLock;

/// Parameters of the Marschner model beyond those every model shares (absorption, eta). Angles in
/// degrees. Defaults: the thesis's (alpha_R = -7.5, beta_R = 7.5; Lemein 2020 Table 3.1) and the
/// middle of Marschner 2003's Table 1 ranges for the caustic.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MarschnerParams {
    /// Longitudinal shift of R (alpha_TT = -alpha_R / 2, alpha_TRT = -3 alpha_R / 2).
    pub alpha_r: f64,
    /// Longitudinal width of R (beta_TT = beta_R / 2, beta_TRT = 2 beta_R).
    pub beta_r: f64,
    /// Glint scale k_G.
    pub glint: f64,
    /// Azimuthal width w_c of the caustic.
    pub caustic_width: f64,
    /// Fade range delta_eta' of the caustic above eta' = 2.
    pub caustic_fade: f64,
    /// Caustic intensity limit delta_h_M.
    pub caustic_limit: f64,
}

impl Default for MarschnerParams {
    fn default() -> Self {
        MarschnerParams {
            alpha_r: -7.5,
            beta_r: 7.5,
            glint: 2.5,
            caustic_width: 15.0,
            caustic_fade: 0.3,
            caustic_limit: 0.5,
        }
    }
}

impl MarschnerParams {
    pub fn validate(&self) -> Result<(), ParamError> {
        check("marschner.alpha_r", self.alpha_r, self.alpha_r.abs() <= 20.0, "must be within +-20 degrees")?;
        check("marschner.beta_r", self.beta_r, self.beta_r > 0.0 && self.beta_r <= 30.0, "must be in (0, 30] degrees")?;
        check("marschner.glint", self.glint, self.glint >= 0.0, "must be >= 0")?;
        check(
            "marschner.caustic_width",
            self.caustic_width,
            self.caustic_width > 0.0 && self.caustic_width <= 90.0,
            "must be in (0, 90] degrees",
        )?;
        check("marschner.caustic_fade", self.caustic_fade, self.caustic_fade > 0.0, "must be > 0")?;
        check(
            "marschner.caustic_limit",
            self.caustic_limit,
            self.caustic_limit > 0.0 && self.caustic_limit <= 1.0,
            "must be in (0, 1]",
        )
    }
}

/// Which density the sampler reports (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MarschnerPdf {
    Exact,
    Thesis,
}

const LOBES: usize = 3;

/// The Marschner fiber with its per-material constants.
#[derive(Debug)]
pub struct Marschner {
    sigma_a: Rgb,
    eta: f64,
    /// Shift alpha_p and width beta_p per lobe, radians.
    alpha: [f64; LOBES],
    beta: [f64; LOBES],
    /// The sampler's longitudinal cones, variance beta_p^2.
    cones: [Longitudinal; LOBES],
    glint: f64,
    caustic_width: f64,
    caustic_fade: f64,
    caustic_limit: f64,
    pdf: MarschnerPdf,
    /// The half-circle averages of N_p that the spread response needs, built on first use.
    spread: OnceLock<SpreadTable>,
}

impl Marschner {
    pub fn new(params: &FiberParams, pdf: MarschnerPdf) -> Result<Marschner, ParamError> {
        params.validate()?;
        let m = &params.marschner;
        let (a, b) = (m.alpha_r.to_radians(), m.beta_r.to_radians());
        let beta = [b, 0.5 * b, 2.0 * b];
        Ok(Marschner {
            sigma_a: params.sigma_a(),
            eta: params.eta,
            alpha: [a, -0.5 * a, -1.5 * a],
            beta,
            cones: beta.map(|b| Longitudinal::new(b * b)),
            glint: m.glint,
            caustic_width: m.caustic_width.to_radians(),
            caustic_fade: m.caustic_fade,
            caustic_limit: m.caustic_limit,
            pdf,
            spread: OnceLock::new(),
        })
    }

    /// The normal-plane geometry and attenuation at difference angle theta_d (given by its sine
    /// and cosine): everything N_p needs.
    fn plane(&self, sin_d: f64, cos_d: f64) -> Plane {
        let cos_d = cos_d.max(1e-12);
        let eta_p = (self.eta * self.eta - sin_d * sin_d).sqrt() / cos_d;
        let sin_t = sin_d / self.eta;
        let cos_theta_t = (1.0 - sin_t * sin_t).sqrt();
        Plane { eta_p, cos_d, cos_theta_t, sigma_a: self.sigma_a, eta: self.eta }
    }

    /// N_p(phi) at a plane, the TRT caustic treated as Marschner 2003 section 4.3 does.
    fn n(&self, plane: &Plane, p: usize, phi: f64) -> Rgb {
        if p < 2 {
            return plane.root_sum(p, phi);
        }
        let c = self.caustic(plane);
        let (fade, glint) = c.profile(phi);
        let smooth = if fade > 0.0 { plane.root_sum(2, phi) * fade } else { Rgb::ZERO };
        smooth + c.glint * glint
    }

    /// Where the TRT caustic lies at a plane, and how strong its glint is.
    fn caustic(&self, plane: &Plane) -> Caustic {
        let eta_p = plane.eta_p;
        let (h_c, dh, t, phi) = if eta_p < 2.0 {
            let h = ((4.0 - eta_p * eta_p) / 3.0).sqrt();
            // d^2 Phi / dh^2 of p = 2 at h_c.
            let d2 = 4.0 * h / (eta_p * eta_p - h * h).powf(1.5) - 2.0 * h / (1.0 - h * h).max(1e-300).powf(1.5);
            let dh = if d2 != 0.0 {
                (2.0 * (2.0 * self.caustic_width / d2.abs()).sqrt()).min(self.caustic_limit)
            } else {
                self.caustic_limit
            };
            (h, dh, 1.0, wrap_angle(plane.deflection(2, h.asin())))
        } else {
            let x = ((eta_p - 2.0) / self.caustic_fade).clamp(0.0, 1.0);
            (0.0, self.caustic_limit, 1.0 - x * x * (3.0 - 2.0 * x), 0.0)
        };
        let glint = plane.attenuation(2, h_c.asin()) * (t * self.glint * dh);
        Caustic { phi, t, width: self.caustic_width, glint }
    }

    fn spread_table(&self) -> &SpreadTable {
        self.spread.get_or_init(|| SpreadTable::new(self))
    }
}

/// A unit-integral Gaussian of standard deviation `width` at `x`.
fn gaussian(width: f64, x: f64) -> f64 {
    (-0.5 * (x / width).powi(2)).exp() / (width * (TAU).sqrt())
}

/// A Gaussian of standard deviation `width` wrapped around the circle, at `x` (any real).
fn wrapped_gaussian(width: f64, x: f64) -> f64 {
    let x = wrap_angle(x);
    gaussian(width, x) + gaussian(width, x - TAU) + gaussian(width, x + TAU)
}

struct Caustic {
    phi: f64,
    t: f64,
    /// Azimuthal width w_c.
    width: f64,
    /// t k_G A(2, h_c) delta_h.
    glint: Rgb,
}

impl Caustic {
    /// At azimuth phi: the factor fading the root sum out about +-phi_c,
    /// (1 - t g(phi - phi_c) / g(0)) (1 - t g(phi + phi_c) / g(0)), and the glint's profile
    /// g(phi - phi_c) + g(phi + phi_c) (g of width w_c), which [`Caustic::glint`] scales.
    fn profile(&self, phi: f64) -> (f64, f64) {
        let g0 = gaussian(self.width, 0.0);
        let (gl, gr) =
            (gaussian(self.width, wrap_angle(phi - self.phi)), gaussian(self.width, wrap_angle(phi + self.phi)));
        ((1.0 - self.t * gl / g0) * (1.0 - self.t * gr / g0), gl + gr)
    }
}

/// The normal plane at one difference angle theta_d.
struct Plane {
    /// Bravais index eta' = sqrt(eta^2 - sin^2 theta_d) / cos theta_d.
    eta_p: f64,
    cos_d: f64,
    cos_theta_t: f64,
    sigma_a: Rgb,
    eta: f64,
}

impl Plane {
    /// Phi(p, gamma_i) (eq. 3.5), gamma_t = asin(sin gamma_i / eta').
    fn deflection(&self, p: usize, gamma: f64) -> f64 {
        let p = p as f64;
        2.0 * p * (gamma.sin() / self.eta_p).asin() - 2.0 * gamma + p * PI
    }

    /// dPhi / dgamma_i (dPhi/dh = this / cos gamma_i).
    fn slope(&self, p: usize, gamma: f64) -> f64 {
        let s = gamma.sin();
        2.0 * p as f64 * gamma.cos() / (self.eta_p * self.eta_p - s * s).sqrt() - 2.0
    }

    /// A(p, h) at h = sin gamma_i (eqs. 3.8-3.9 with the fixes in the module documentation).
    fn attenuation(&self, p: usize, gamma: f64) -> Rgb {
        let f = fresnel_dielectric(self.cos_d * gamma.cos(), self.eta);
        if p == 0 {
            return Rgb::splat(f);
        }
        let cos_gamma_t = (1.0 - (gamma.sin() / self.eta_p).powi(2)).max(0.0).sqrt();
        let l = 2.0 * cos_gamma_t / self.cos_theta_t;
        let t = self.sigma_a.map(|s| (-s * l).exp());
        let t_p = if p == 1 { t } else { t * t };
        t_p * ((1.0 - f) * (1.0 - f) * f.powi(p as i32 - 1))
    }

    /// The intervals of gamma_i in [-pi/2, pi/2] on which Phi(p, .) is monotone: dPhi/dgamma = 0
    /// where cos^2 gamma = (eta'^2 - 1) / (p^2 - 1), which has a solution only for p = 2 and
    /// eta' < 2 (the TRT caustic).
    fn monotone_intervals(&self, p: usize) -> ([f64; 4], usize) {
        if p == 2 && self.eta_p < 2.0 {
            let g = ((self.eta_p * self.eta_p - 1.0) / 3.0).sqrt().acos();
            ([-FRAC_PI_2, -g, g, FRAC_PI_2], 3)
        } else {
            ([-FRAC_PI_2, FRAC_PI_2, 0.0, 0.0], 1)
        }
    }

    /// Every gamma_i with Phi(p, gamma_i) = phi modulo 2 pi.
    fn roots(&self, p: usize, phi: f64) -> ([f64; 8], usize) {
        let mut out = ([0.0; 8], 0);
        let (ends, n) = self.monotone_intervals(p);
        for k in 0..n {
            let (a, b) = (ends[k], ends[k + 1]);
            let (fa, fb) = (self.deflection(p, a), self.deflection(p, b));
            let (lo, hi) = (fa.min(fb), fa.max(fb));
            // Half-open in the value, so a root shared by two intervals' ends counts once.
            let mut j = ((lo - phi) / TAU).ceil();
            while phi + j * TAU < hi && out.1 < out.0.len() {
                let target = phi + j * TAU;
                out.0[out.1] = self.solve(p, target, a, b, fa);
                out.1 += 1;
                j += 1.0;
            }
        }
        out
    }

    /// The gamma in [a, b] with Phi(p, gamma) = target, Phi monotone on [a, b] with Phi(a) = fa:
    /// Newton steps kept inside a shrinking bracket (bisection when a step leaves it).
    fn solve(&self, p: usize, target: f64, mut a: f64, mut b: f64, fa: f64) -> f64 {
        let rising = self.deflection(p, b) > fa;
        let mut g = 0.5 * (a + b);
        for _ in 0..100 {
            let f = self.deflection(p, g) - target;
            if (f > 0.0) == rising {
                b = g;
            } else {
                a = g;
            }
            let step = f / self.slope(p, g);
            let next = g - step;
            let next = if next > a && next < b && step.is_finite() { next } else { 0.5 * (a + b) };
            if (next - g).abs() < 1e-14 || b - a < 1e-14 {
                return next;
            }
            g = next;
        }
        g
    }

    /// sum over the roots of A(p, h) / |2 dPhi/dh| = A cos gamma / (2 |dPhi/dgamma|).
    fn root_sum(&self, p: usize, phi: f64) -> Rgb {
        let (roots, n) = self.roots(p, phi);
        roots[..n].iter().map(|&g| self.attenuation(p, g) * (g.cos() / (2.0 * self.slope(p, g).abs()).max(1e-12))).sum()
    }
}

impl Model for Marschner {
    const NAME: &'static str = "marschner";
    const HELP: &'static str = "Marschner et al. 2003 as Lemein 2020 uses it; --alpha-r, --beta-r";
    const TITLE: &'static str = "Marschner";
    const CAPTION: &'static str = "Marschner fiber";
    const FAR_FIELD: bool = true;
    const EXACT_LABEL: &'static str = "marschner-exact";
    const FLAWED: Option<FlawedSampler> = Some(FlawedSampler {
        name: "thesis",
        label: "marschner-thesis",
        help: "the sampler with the density Lemein 2020 (section 4.3) states in place of the density it has: biased",
    });

    /// With the thesis's density ([`MarschnerPdf::Thesis`]) when `flawed`.
    fn build(params: &FiberParams, flawed: bool) -> Result<Marschner, ParamError> {
        Marschner::new(params, if flawed { MarschnerPdf::Thesis } else { MarschnerPdf::Exact })
    }

    fn validate_own(params: &FiberParams) -> Result<(), ParamError> {
        params.marschner.validate()
    }

    /// The narrowest features are the TT lobe (width beta_R / 2, as Chiang's TT with
    /// v = beta_R^2) and the caustic.
    fn table_features(params: &FiberParams) -> TableFeatures {
        let beta = params.marschner.beta_r.to_radians();
        TableFeatures::new(PI / 96.0, beta * beta)
    }

    /// beta_R in degrees, with alpha_R = -2 alpha, its sign for a tilt toward the root.
    fn set_grid_roughness(params: &mut FiberParams, beta: f64) {
        params.marschner.alpha_r = -2.0 * params.alpha;
        params.marschner.beta_r = r_width(beta).to_degrees();
    }

    fn describe(params: &FiberParams) -> String {
        let m = &params.marschner;
        format!("alpha_R {} deg, beta_R {} deg, eta {}", m.alpha_r, m.beta_r, params.eta)
    }
}

impl SamplerKind {
    /// The Marschner model's flawed sampler (a name kept for the renderer).
    #[allow(non_upper_case_globals)]
    pub const Thesis: SamplerKind = SamplerKind::Flawed(ModelKind::Marschner);
}

/// The Marschner fiber at one hit. The model itself does not depend on h (its N_p integrates over
/// it), so this holds only what depends on wo.
pub struct MarschnerHit<'a> {
    fiber: &'a Marschner,
    theta_o: f64,
    phi_o: f64,
    /// The sampler's plane: eta' at theta_o.
    sampler_plane: Plane,
    /// The sampler's density over phi as (deflection, weight) nodes per lobe, built on first use.
    azimuth_nodes: OnceLock<[Vec<(f64, f64)>; LOBES]>,
}

impl FiberModel for Marschner {
    type Hit<'a> = MarschnerHit<'a>;

    fn at(&self, wo: DVec3, _h: f64) -> MarschnerHit<'_> {
        let (sin_o, cos_o) = sin_cos_theta(wo);
        MarschnerHit {
            fiber: self,
            theta_o: sin_o.atan2(cos_o),
            phi_o: phi(wo),
            sampler_plane: self.plane(sin_o, cos_o),
            azimuth_nodes: OnceLock::new(),
        }
    }
}

/// What the model needs of a direction wi at a hit.
struct Angles {
    theta_i: f64,
    cos_i: f64,
    sin_i: f64,
    /// phi_i - phi_o wrapped to [-pi, pi].
    phi: f64,
    plane: Plane,
}

impl MarschnerHit<'_> {
    fn angles(&self, wi: DVec3) -> Angles {
        let (sin_i, cos_i) = sin_cos_theta(wi);
        let theta_i = sin_i.atan2(cos_i);
        let theta_d = 0.5 * (self.theta_o - theta_i);
        let (sin_d, cos_d) = theta_d.sin_cos();
        Angles { theta_i, cos_i, sin_i, phi: wrap_angle(phi(wi) - self.phi_o), plane: self.fiber.plane(sin_d, cos_d) }
    }

    /// cos theta_i / cos^2 theta_d: what turns sum M_p N_p into the projected f |cos theta_i|.
    fn projection(&self, a: &Angles) -> f64 {
        a.cos_i / (a.plane.cos_d * a.plane.cos_d)
    }

    fn m(&self, p: usize, a: &Angles, extra_variance: f64) -> f64 {
        let f = self.fiber;
        gaussian((f.beta[p] * f.beta[p] + extra_variance).sqrt(), a.theta_i + self.theta_o - f.alpha[p])
    }

    /// Selection weights of the lobes at h = sin gamma on `plane`: A_spec by luminance, normalized
    /// (Lemein 2020 eqs. 4.2-4.7).
    fn weights(plane: &Plane, gamma: f64) -> [f64; LOBES] {
        let y: [f64; LOBES] = std::array::from_fn(|p| plane.attenuation(p, gamma).luminance());
        let total: f64 = y.iter().sum();
        if total > 0.0 { y.map(|y| y / total) } else { [1.0, 0.0, 0.0] }
    }

    /// The thesis's stated density (Lemein 2020 section 4.3, "Finding the PDF"): its eq. 4.1 (M_p,
    /// the sampled cone, times N_p) with each A replaced by its selection weight: the roots of
    /// the given direction weighted w_p(h) / |2 dPhi/dh|. It leaves out the Gaussian azimuth of
    /// eq. 4.14 that the sampler adds, and finds the roots at theta_d where the sampler deflects
    /// at theta_o.
    fn thesis_pdf(&self, a: &Angles) -> f64 {
        (0..LOBES)
            .map(|p| {
                let (roots, n) = a.plane.roots(p, a.phi);
                let np: f64 = roots[..n]
                    .iter()
                    .map(|&g| Self::weights(&a.plane, g)[p] * g.cos() / (2.0 * a.plane.slope(p, g).abs()).max(1e-12))
                    .sum();
                self.cone(p, a) * np
            })
            .sum()
    }

    /// The sampler's longitudinal density of lobe p at wi (per unit solid angle, with a density
    /// of azimuth): d'Eon 2013's cone about theta_i = alpha_p - theta_o.
    fn cone(&self, p: usize, a: &Angles) -> f64 {
        let (sin_c, cos_c) = (self.theta_o - self.fiber.alpha[p]).sin_cos();
        self.fiber.cones[p].eval(a.cos_i, a.sin_i, cos_c, sin_c)
    }

    /// Trapezoid nodes in gamma over [-pi/2, pi/2] for each lobe's azimuthal density
    /// n_p(phi) = int (dh / 2) w_p(h) G_beta_p(phi - Phi(p, h)), as (Phi, weight): spaced a quarter
    /// of beta_p apart in gamma (|dPhi/dgamma| <= 2, so half a width apart in phi).
    fn azimuth_nodes(&self) -> &[Vec<(f64, f64)>; LOBES] {
        self.azimuth_nodes.get_or_init(|| {
            std::array::from_fn(|p| {
                let n = ((4.0 * PI / self.fiber.beta[p]).ceil() as usize).clamp(64, 1 << 16);
                let step = PI / n as f64;
                (0..=n)
                    .map(|k| {
                        let g = -FRAC_PI_2 + k as f64 * step;
                        let end = if k == 0 || k == n { 0.5 } else { 1.0 };
                        let w = Self::weights(&self.sampler_plane, g)[p] * 0.5 * g.cos() * step * end;
                        (self.sampler_plane.deflection(p, g), w)
                    })
                    .filter(|&(_, w)| w > 0.0)
                    .collect()
            })
        })
    }

    /// The density the sampler really has, per unit solid angle.
    fn exact_pdf(&self, a: &Angles) -> f64 {
        let nodes = self.azimuth_nodes();
        (0..LOBES)
            .map(|p| {
                let m = self.cone(p, a);
                if m == 0.0 {
                    return 0.0;
                }
                let beta = self.fiber.beta[p];
                let n: f64 = nodes[p]
                    .iter()
                    .filter(|(d, _)| wrap_angle(a.phi - d).abs() < 8.0 * beta)
                    .map(|&(d, w)| w * wrapped_gaussian(beta, a.phi - d))
                    .sum();
                m * n
            })
            .sum()
    }

    /// The density of the sampler this fiber draws with.
    fn density(&self, a: &Angles) -> f64 {
        match self.fiber.pdf {
            MarschnerPdf::Exact => self.exact_pdf(a),
            MarschnerPdf::Thesis => self.thesis_pdf(a),
        }
    }

    fn value(&self, a: &Angles) -> Rgb {
        let sum: Rgb = (0..LOBES).map(|p| self.fiber.n(&a.plane, p, a.phi) * self.m(p, a, 0.0)).sum();
        sum * self.projection(a)
    }
}

impl FiberHit for MarschnerHit<'_> {
    fn eval(&self, wi: DVec3) -> Rgb {
        self.value(&self.angles(wi))
    }

    fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
        let gamma = (2.0 * u[0] - 1.0).clamp(-1.0, 1.0).asin();
        let (p, u3) = pick(&Self::weights(&self.sampler_plane, gamma), u[3]);
        let (sin_c, cos_c) = (self.theta_o - self.fiber.alpha[p]).sin_cos();
        let (sin_i, cos_i) = self.fiber.cones[p].sample(cos_c, sin_c, u[1], u[2]);
        let z = std::f64::consts::SQRT_2 * statrs::function::erf::erf_inv(2.0 * u3.clamp(1e-12, 1.0 - 1e-12) - 1.0);
        let dphi = self.sampler_plane.deflection(p, gamma) + self.fiber.beta[p] * z;
        let (sin_p, cos_p) = (self.phi_o + dphi).sin_cos();
        let wi = DVec3::new(sin_i, cos_i * cos_p, cos_i * sin_p);
        let (value, pdf) = self.eval_pdf(wi);
        (pdf > 0.0 && pdf.is_finite()).then_some(FiberSample { wi, value, pdf })
    }

    fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        let a = self.angles(wi);
        (self.value(&a), self.density(&a))
    }

    /// Without the value, which costs as much again (both solve for the azimuthal roots).
    fn pdf(&self, wi: DVec3) -> f64 {
        self.density(&self.angles(wi))
    }
}

impl SpreadHit for MarschnerHit<'_> {
    /// Each M_p widened by the spread (Gaussian variances add), each N_p averaged over the half
    /// circle of azimuths within pi/2 of wi's (tabulated over theta_d on first use).
    fn eval_spread(&self, wi: DVec3, spread: Rgb) -> Rgb {
        let a = self.angles(wi);
        let table = self.fiber.spread_table();
        let mut out = Rgb::ZERO;
        for p in 0..LOBES {
            let n = table.half_circle_mean(p, a.plane.cos_d.acos(), a.phi);
            for c in 0..3 {
                out.0[c] += n.0[c] * self.m(p, &a, spread.0[c]);
            }
        }
        out * self.projection(&a)
    }
}

/// Cumulative masses of N_p over phi per |theta_d| row, for half-circle averages.
#[derive(Debug)]
struct SpreadTable {
    /// cumulative[row][p][b]: the mass of N_p over [-pi, -pi + b delta_phi), b = 0..=BINS.
    cumulative: Vec<[Vec<Rgb>; LOBES]>,
}

const SPREAD_ROWS: usize = 91;
const SPREAD_BINS: usize = 720;
/// Uniform gamma samples per lobe and row; |dPhi/dgamma| <= 2 puts ten or more in every bin.
const SPREAD_SAMPLES: usize = 8192;

impl SpreadTable {
    /// Deposits each lobe's mass A cos gamma dgamma / 2 (times the caustic fade for TRT) into the
    /// phi bin its deflection falls in; the glint adds its Gaussian at the bin centers.
    fn new(fiber: &Marschner) -> SpreadTable {
        let dphi = TAU / SPREAD_BINS as f64;
        let cumulative = (0..SPREAD_ROWS)
            .map(|row| {
                let theta_d = FRAC_PI_2 * row as f64 / (SPREAD_ROWS - 1) as f64;
                let plane = fiber.plane(theta_d.sin(), theta_d.cos());
                let caustic = fiber.caustic(&plane);
                std::array::from_fn(|p| {
                    let mut bins = vec![Rgb::ZERO; SPREAD_BINS];
                    let step = PI / SPREAD_SAMPLES as f64;
                    for k in 0..SPREAD_SAMPLES {
                        let g = -FRAC_PI_2 + (k as f64 + 0.5) * step;
                        let d = wrap_angle(plane.deflection(p, g));
                        let fade = if p == 2 { caustic.profile(d).0 } else { 1.0 };
                        let b = (((d + PI) / dphi) as usize).min(SPREAD_BINS - 1);
                        bins[b] += plane.attenuation(p, g) * (0.5 * g.cos() * step * fade);
                    }
                    if p == 2 {
                        for (b, bin) in bins.iter_mut().enumerate() {
                            let x = -PI + (b as f64 + 0.5) * dphi;
                            *bin += caustic.glint * (caustic.profile(x).1 * dphi);
                        }
                    }
                    let mut cum = Vec::with_capacity(SPREAD_BINS + 1);
                    cum.push(Rgb::ZERO);
                    for bin in bins {
                        cum.push(*cum.last().unwrap() + bin);
                    }
                    cum
                })
            })
            .collect();
        SpreadTable { cumulative }
    }

    /// Mass of N_p over (-pi, x) for x in any turn: whole turns plus the interpolated cumulative.
    fn mass_below(cum: &[Rgb], x: f64) -> Rgb {
        let turns = ((x + PI) / TAU).floor();
        let u = (x + PI - turns * TAU) / TAU * SPREAD_BINS as f64;
        let b = (u as usize).min(SPREAD_BINS - 1);
        let f = u - b as f64;
        cum[SPREAD_BINS] * turns + cum[b] * (1.0 - f) + cum[b + 1] * f
    }

    /// (1/pi) times the mass of N_p within pi/2 of phi, at |theta_d|, linear between rows.
    fn half_circle_mean(&self, p: usize, theta_d: f64, phi: f64) -> Rgb {
        let x = (theta_d.abs() / FRAC_PI_2 * (SPREAD_ROWS - 1) as f64).clamp(0.0, (SPREAD_ROWS - 1) as f64);
        let r = (x as usize).min(SPREAD_ROWS - 2);
        let f = x - r as f64;
        let at = |row: usize| {
            let cum = &self.cumulative[row][p];
            Self::mass_below(cum, phi + FRAC_PI_2) - Self::mass_below(cum, phi - FRAC_PI_2)
        };
        (at(r) * (1.0 - f) + at(r + 1) * f) / PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The roots against a brute-force scan of Phi on a fine gamma grid: every sign change of
    /// wrap(Phi - phi) that is not a wrap-around jump brackets one root.
    #[test]
    fn roots_match_a_brute_force_scan() {
        let fiber = Marschner::new(&FiberParams::default(), MarschnerPdf::Exact).unwrap();
        for theta_d in [0.0, 0.4, 0.8, 1.2] {
            let plane = fiber.plane(f64::sin(theta_d), f64::cos(theta_d));
            for p in 0..LOBES {
                for k in 0..97 {
                    let phi = -PI + TAU * (k as f64 + 0.37) / 97.0;
                    let (roots, n) = plane.roots(p, phi);
                    for &g in &roots[..n] {
                        assert!(
                            wrap_angle(plane.deflection(p, g) - phi).abs() < 1e-9,
                            "p {p} phi {phi}: root {g} misses"
                        );
                    }
                    let steps = 200_000;
                    let f = |j: usize| wrap_angle(plane.deflection(p, -FRAC_PI_2 + PI * j as f64 / steps as f64) - phi);
                    let scan = (0..steps)
                        .filter(|&j| f(j).signum() != f(j + 1).signum() && (f(j) - f(j + 1)).abs() < 1.0)
                        .count();
                    assert_eq!(n, scan, "p {p}, theta_d {theta_d}, phi {phi}: {n} roots, scan finds {scan}");
                }
            }
        }
    }
}
