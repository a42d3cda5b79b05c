//! Sadeghi et al. 2010's artist-friendly hair model as Ou, Xie, Krishnamachari and Pellacini 2012
//! (ISHair) give it (eq. 1), with ISHair's Cauchy sampler (section 3.2) and Hery and Ramamoorthi
//! 2011's Box-Muller sampler as ISHair's Appendices A and B describe it.
//!
//! f(wo, wi) = [I_R M_R N_R + I_TT M_TT N_TT + I_TRT M_TRT N_TRT-g + I_TRT M_TRT I_g N_g]
//!             / cos^2 theta_d                                               (ISHair eq. 1)
//!
//! - Angles: theta_h = (theta_i + theta_o) / 2, theta_d = (theta_o - theta_i) / 2, and the
//!   relative azimuth phi = phi_i - phi_o wrapped to [-pi, pi] (ISHair's phi_r - phi_i; every
//!   lobe is even in phi, so the sign does not matter). `wo` plays ISHair's omega_r.
//! - M_p = g(beta_p^2, alpha_p, theta_h) = exp(-(theta_h - alpha_p)^2 / (2 beta_p^2)), an
//!   unnormalized Gaussian in theta_h (section 3.1): a Gaussian of standard deviation 2 beta_p
//!   in theta_i, peaked at theta_i = 2 alpha_p - theta_o. alpha_p keeps Marschner 2003's sign:
//!   alpha_R < 0 puts R toward the root, alpha_R = -a being [`FiberParams::alpha`] = a (Cycles).
//!   As in Marschner 2003 (section 4.3, Table 1), alpha_TT = -alpha_R / 2, alpha_TRT =
//!   -3 alpha_R / 2, beta_TT = beta_R / 2, beta_TRT = 2 beta_R.
//! - N_R = N_TRT-g = cos(phi / 2), N_TT = g(gamma_TT^2, pi - |phi|), N_g = g(gamma_g^2, |phi| -
//!   phi_g) (section 3.1; pi - |phi| is ISHair's pi - phi for its phi in [0, 2 pi]).
//! - eval returns f |cos theta_i|. cos^2 theta_d = (1 + cos(theta_o - theta_i)) / 2 is floored
//!   at 1e-24: it vanishes only at theta_i = -theta_o = +-pi/2, where f truly diverges (erratum 1).
//!
//! Colors (not in ISHair, whose intensities are an artist's colors): the intensities follow
//! the fiber's absorption. I_p = i_p A_p / (L_p Z_p) with i_p the user's scalar, A_p the smooth
//! fiber's attenuation at normal incidence averaged over the offset h (A_R = F, A_TT = (1 - F)^2 T,
//! A_TRT = (1 - F)^2 F T^2 with T = exp(-2 sigma_a cos gamma_t): Pharr 2016 section 1.3.2 at
//! theta = 0), and L_p Z_p the lobe's integral over (theta_i, phi) on the whole line: L_p =
//! 2 sqrt(2 pi) beta_p, Z_R = Z_TRT = 4, Z_TT = sqrt(2 pi) gamma_TT. So at i_p = 1 and normal
//! incidence each lobe scatters about what a smooth fiber's R, TT and TRT do (brown and blond
//! scenes keep their colors when they switch model), and widening a lobe keeps its energy. The
//! glint keeps ISHair's form, I_g relative to TRT-g's peak: N_g's peak I_g against N_TRT-g's 1.
//!
//! Defaults: alpha_R = -7.5, beta_R = 7.5 degrees (the middle of Marschner 2003 Table 1, as
//! [`super::MarschnerParams`]); gamma_TT = 30 degrees (a smooth fiber's TT deflection 2 gamma_t -
//! 2 gamma_i + pi has an energy-weighted standard deviation of 31 to 33 degrees about pi at
//! eta = 1.55 and sigma_a 0 to 0.9); gamma_g = 15 degrees (Marschner 2003 Table 1's caustic width
//! w_c, 10 to 25); phi_g the smooth fiber's TRT caustic azimuth at normal incidence (Marschner
//! 2003 section 4.3: h_c = sqrt((4 - eta^2) / 3), phi_g = 4 gamma_t - 2 gamma_i there; 18.6 degrees
//! at eta = 1.55, 0 from eta = 2 on); I_g = 1 (glint peak as high as TRT-g's).
//! The model does not conserve energy (unnormalized Gaussians cut at the ends of theta_i, and 1 /
//! cos^2 theta_d): its albedo is measured (tests/sadeghi.rs), not assumed.
//!
//! Samplers. Both pick a lobe with probability proportional to ISHair's energy estimates
//! (section 3.2.3; luminance of the colored intensities): E_R = 4 sqrt(2 pi) beta_R I_R, E_TT =
//! 2 pi beta_TT gamma_TT I_TT, E_TRT-g = 4 sqrt(2 pi) beta_TRT I_TRT, E_g = 4 pi beta_TRT gamma_g
//! I_TRT I_g. Both report the mixture density sum_p P(p) p_p(wi) per unit solid angle, with
//! d theta_i = 2 d theta_h and d omega = cos theta_i d theta_i d phi:
//! p_p(wi) = p_p(theta_h) / 2 * p_p(phi) / cos theta_i (cos theta_i floored at 1e-12, section 3.3's
//! grazing singularity: the density is genuinely infinite at the poles; no sample is discarded).
//! - [`SadeghiSampler::Cauchy`] (sections 3.2.1, 3.2.2, supplement 3.1-3.4): each Gaussian replaced
//!   by a Cauchy of the same center and width, cut to its variable's range and renormalized, drawn
//!   by inverse CDF: theta_h over [theta_o / 2 - pi / 4, theta_o / 2 + pi / 4] (theta_i in
//!   [-pi/2, pi/2]), TT's pi - |phi| over [-pi, pi], the glint's |phi| over [0, pi] with the side
//!   drawn apart; cos(phi / 2) exactly, phi = 2 asin(2 u - 1). Exact: the reported density is the
//!   density of the drawn directions.
//! - [`SadeghiSampler::BoxMuller`] (Appendices A, B): theta_h = alpha_p + beta_p z from a
//!   Box-Muller normal pair, clamped to [-theta_max, theta_max] with theta_max = pi/2 (ISHair
//!   gives no value; pi/2 is the largest clamp after which one flip always lands in range), then
//!   theta_i = 2 theta_h - theta_o flipped about the pole (+-pi - theta_i) when past +-pi/2.
//!   Hery and Ramamoorthi sample only R; here every Gaussian is drawn the same way (TT's and the
//!   glint's azimuths from the pair's second normal, the cos(phi / 2) azimuths exactly as above).
//!   The reported density is theirs: infinite-range normal densities at the final direction,
//!   ignoring the clipped, clamped and flipped mass. It is not the density of the drawn
//!   directions, so estimates with it are biased, most at grazing theta_o.
//!
//! The dual-scattering response f_s^G ([`SpreadHit`]): each M_p widened by the spread variance of
//! theta_i (a quarter of it in theta_h), its height scaled by beta_p / beta_p' so that its integral
//! over theta is kept; each N_p replaced by its mean over the half circle within pi/2 of phi, in
//! closed form (erf for the Gaussians, on the circle).
//!
//! Errata in ISHair, each checked as stated (tests/sadeghi.rs and the unit tests below):
//! 1. Footnote 1: 1 / cos^2 theta_d is singular where theta_r and theta_i approach opposite poles
//!    (theta_d -> +-pi/2), not the same one, and cos theta_i / cos^2 theta_d is not smooth there:
//!    along theta_i = -theta_r it equals 1 / cos theta_r, unbounded (integrable over wi).
//! 2. Section 3.2.1: "beta_x" in p(theta_i) is beta.
//! 3. Supplement 3.1: A and B are printed atan((pi/2 + theta_r - alpha) / beta) and atan((-pi/2 +
//!    theta_r - alpha) / beta), and the CDF atan((theta_i + theta_r - alpha) / beta): theta_h =
//!    (theta_i + theta_r) / 2 lost its halving. With the paper's A, B (section 3.2.1, correct) the
//!    CDF is (atan(((theta_i + theta_r) / 2 - alpha) / beta) - B) / (A - B); the inversion printed
//!    there is right. Unit test `cdfs_invert_and_integrate_their_densities`.
//! 4. Figure 8(c): theta_h = 3 pi / 4 is pi / 4 (then theta_i = 2 theta_h - theta_r = 3 pi / 4 as in
//!    (d), and the flip moves theta_h from pi / 4 to 0 as the caption says).
//! 5. Section 3.2.2 and supplement 3.4 draw the glint's |phi| over [0, pi/2) only, so a glint
//!    lobe cannot draw its own tail past pi/2; we draw over [0, pi], N_g's whole range, which the
//!    single-lobe weight identity needs. The energy estimates' stated accuracy (error below 1% for
//!    beta < 30, |alpha| < 20 degrees) holds for theta_h over [-pi/2, pi/2], not over the valid range
//!    at a given theta_r, which is pi/2 wide.
//! 6. The Python pseudo-code (supplement section 5):
//!    - every sample_*: b = arctan(((pi/2 - theta_r)/2 - alpha) / beta) has the wrong sign: B is at
//!      theta_h = (-pi/2 + theta_r) / 2; as printed, a = b at theta_r = 0 and every sample lands at
//!      the top of the range;
//!    - sample_G_lobe and the compute_*_pdf: `arctan((-pi/2 + theta_r)/2 - alpha) / beta)` has
//!      unbalanced parentheses; in compute_TRT_G_pdf and compute_G_pdf the division by beta falls
//!      outside the arctan;
//!    - sample_R_lobe, sample_TRT_G_lobe: `uv[2]` indexes a pair (uv[1]); sample_TT_lobe uses an
//!      undefined `v` and C `double` declarations; sample_brdf tests undefined `u`, `v`;
//!    - sample_TT_lobe: c_TT = 2 arctan(pi / 2 / gamma_TT) draws only |phi - pi| < pi/2, against
//!      the paper's C_TT = 2 atan(pi / gamma_TT) (compute_TT_pdf's zero below pi/2 matches the
//!      code, not the paper);
//!    - compute_TT_pdf, compute_TRT_G_pdf, compute_G_pdf compute theta_pdf with alpha_R, beta_R,
//!      a_R, b_R instead of their own lobe's;
//!    - the compute_*_pdf take phi = phi_r - phi_i (or its abs) unwrapped: cos(phi / 2) turns
//!      negative past |phi| = pi, and TT and the glint see angles beyond pi;
//!    - the grazing test `pi/2 - theta_i < epsilon` guards only the +u pole (section 3.3 says both);
//!    - compute_G_pdf normalizes |phi| over [0, pi/2) but does not vanish past it, where the
//!      sampler never goes: that part of the density is not the sampler's.

use super::attenuation::ap;
use super::model::{FlawedSampler, Model, TableFeatures, r_width};
use super::params::check;
use super::{FiberHit, FiberModel, FiberParams, FiberSample, ModelKind, ParamError, SamplerKind, SpreadHit};
use crate::conventions::{direction, phi, pick, sin_cos_theta, wrap_angle};
use crate::quadrature::composite;
use crate::spectrum::Rgb;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use statrs::function::erf::{erf, erfc};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, SQRT_2, TAU};

/// Parameters of the Sadeghi model (scene files' `fiber.sadeghi`). Angles in degrees; defaults
/// and their sources in the module documentation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SadeghiParams {
    /// Longitudinal shift of R in theta_h (negative: toward the root). TT and TRT follow it.
    pub alpha_r: f64,
    /// Longitudinal width of R in theta_h. TT and TRT follow it.
    pub beta_r: f64,
    /// Azimuthal width of TT.
    pub gamma_tt: f64,
    /// Azimuthal width of each glint.
    pub gamma_g: f64,
    /// Azimuth of each glint's peak; by default the smooth fiber's caustic for `eta`.
    pub phi_g: Option<f64>,
    /// Scales of the R, TT and TRT lobes' energies (1: a smooth fiber's at normal incidence).
    pub i_r: f64,
    pub i_tt: f64,
    pub i_trt: f64,
    /// Glint peak relative to TRT-g's (ISHair's I_g).
    pub i_g: f64,
}

impl Default for SadeghiParams {
    fn default() -> Self {
        SadeghiParams {
            alpha_r: -7.5,
            beta_r: 7.5,
            gamma_tt: 30.0,
            gamma_g: 15.0,
            phi_g: None,
            i_r: 1.0,
            i_tt: 1.0,
            i_trt: 1.0,
            i_g: 1.0,
        }
    }
}

impl SadeghiParams {
    pub(super) fn validate(&self) -> Result<(), ParamError> {
        // Widths from 0.001 degrees on: below, (range / width)^2 nears overflow in the Cauchy CDFs.
        let width = |w: f64, hi: f64| (0.001..=hi).contains(&w);
        check("sadeghi.alpha_r", self.alpha_r, self.alpha_r.abs() <= 20.0, "must be within +-20 degrees")?;
        check("sadeghi.beta_r", self.beta_r, width(self.beta_r, 30.0), "must be in [0.001, 30] degrees")?;
        check("sadeghi.gamma_tt", self.gamma_tt, width(self.gamma_tt, 90.0), "must be in [0.001, 90] degrees")?;
        check("sadeghi.gamma_g", self.gamma_g, width(self.gamma_g, 90.0), "must be in [0.001, 90] degrees")?;
        if let Some(p) = self.phi_g {
            check("sadeghi.phi_g", p, (0.0..=180.0).contains(&p), "must be in [0, 180] degrees")?;
        }
        for (field, v) in [
            ("sadeghi.i_r", self.i_r),
            ("sadeghi.i_tt", self.i_tt),
            ("sadeghi.i_trt", self.i_trt),
            ("sadeghi.i_g", self.i_g),
        ] {
            check(field, v, v >= 0.0, "must be >= 0")?;
        }
        Ok(())
    }
}

/// The sampler a [`Sadeghi`] fiber draws with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SadeghiSampler {
    /// ISHair's Cauchy-lobe inverse-CDF sampler (Ou et al. 2012 section 3.2): exact.
    Cauchy,
    /// Hery and Ramamoorthi 2011's Box-Muller Gaussian sampler as Ou et al. 2012 describe it: biased.
    BoxMuller,
}

/// Lobes in the order of ISHair's eq. 1.
const R: usize = 0;
const TT: usize = 1;
const TRT: usize = 2;
const GLINT: usize = 3;
const LOBES: usize = 4;
/// The longitudinal term (R, TT, TRT) of each lobe: the glint shares TRT's.
const LONG: [usize; LOBES] = [R, TT, TRT, TRT];

/// The Sadeghi fiber with its per-material constants (angles in radians).
#[derive(Clone, Debug)]
pub struct Sadeghi {
    /// I_R, I_TT, I_TRT and the glint's I_TRT I_g.
    intensity: [Rgb; LOBES],
    /// Shift and width of M_R, M_TT, M_TRT in theta_h.
    alpha: [f64; 3],
    beta: [f64; 3],
    gamma_tt: f64,
    gamma_g: f64,
    phi_g: f64,
    /// ISHair's azimuthal Cauchys: TT's in x = pi - |phi| over [-pi, pi] (centered at 0, as ISHair's
    /// phi - pi over [0, 2 pi]), the glint's in |phi| over [0, pi].
    tt_cauchy: Cauchy,
    glint_cauchy: Cauchy,
    /// Lobe-selection probabilities from the energy estimates.
    weights: [f64; LOBES],
    sampler: SadeghiSampler,
}

impl Sadeghi {
    pub fn new(params: &FiberParams, sampler: SadeghiSampler) -> Result<Sadeghi, ParamError> {
        params.validate()?;
        let s = &params.sadeghi;
        let (a, b) = (s.alpha_r.to_radians(), s.beta_r.to_radians());
        let alpha = [a, -0.5 * a, -1.5 * a];
        let beta = [b, 0.5 * b, 2.0 * b];
        let (gamma_tt, gamma_g) = (s.gamma_tt.to_radians(), s.gamma_g.to_radians());
        let phi_g = s.phi_g.map_or_else(|| caustic_azimuth(params.eta), f64::to_radians);
        let root_2pi = TAU.sqrt();
        let attenuation = mean_attenuation(params.eta, params.sigma_a());
        let azimuthal = [4.0, root_2pi * gamma_tt, 4.0];
        let user = [s.i_r, s.i_tt, s.i_trt];
        let lobe: [Rgb; 3] =
            std::array::from_fn(|p| attenuation[p] * (user[p] / (2.0 * root_2pi * beta[p] * azimuthal[p])));
        let intensity = [lobe[R], lobe[TT], lobe[TRT], lobe[TRT] * s.i_g];
        // ISHair section 3.2.3 (with luminance for the colored intensities).
        let energy = [
            4.0 * root_2pi * beta[R] * lobe[R].luminance(),
            TAU * beta[TT] * gamma_tt * lobe[TT].luminance(),
            4.0 * root_2pi * beta[TRT] * lobe[TRT].luminance(),
            2.0 * TAU * beta[TRT] * gamma_g * intensity[GLINT].luminance(),
        ];
        let total: f64 = energy.iter().sum();
        let weights = if total > 0.0 { energy.map(|e| e / total) } else { [0.25; LOBES] };
        Ok(Sadeghi {
            intensity,
            alpha,
            beta,
            gamma_tt,
            gamma_g,
            phi_g,
            tt_cauchy: Cauchy::new(0.0, gamma_tt, -PI, PI),
            glint_cauchy: Cauchy::new(phi_g, gamma_g, 0.0, PI),
            weights,
            sampler,
        })
    }

    /// N_p at the relative azimuth phi in [-pi, pi] (ISHair section 3.1).
    fn n(&self, dphi: f64) -> [f64; LOBES] {
        let half_cos = (0.5 * dphi).cos().max(0.0);
        [half_cos, gauss(self.gamma_tt, tt_offset(dphi)), half_cos, gauss(self.gamma_g, dphi.abs() - self.phi_g)]
    }

    /// Each N_p's mean over the half circle of azimuths within pi/2 of phi (f_s^G's azimuth).
    fn n_half_circle(&self, dphi: f64) -> [f64; LOBES] {
        let half_cos = window_mass(dphi, |lo, hi| 2.0 * ((0.5 * hi).sin() - (0.5 * lo).sin()));
        let tt = window_mass(tt_offset(dphi), |lo, hi| gauss_mass(lo, hi, self.gamma_tt));
        let glint = window_mass(dphi, |lo, hi| {
            let (w, c) = (self.gamma_g, self.phi_g);
            let plus = if hi > 0.0 { gauss_mass(lo.max(0.0) - c, hi - c, w) } else { 0.0 };
            let minus = if lo < 0.0 { gauss_mass((-hi).max(0.0) - c, -lo - c, w) } else { 0.0 };
            plus + minus
        });
        [half_cos, tt, half_cos, glint].map(|m| m / PI)
    }
}

impl Model for Sadeghi {
    const NAME: &'static str = "sadeghi";
    const HELP: &'static str = "Sadeghi et al. 2010 as Ou et al. 2012 give it; --sadeghi-*";
    const TITLE: &'static str = "Sadeghi";
    const CAPTION: &'static str = "Sadeghi";
    const FAR_FIELD: bool = true;
    const EXACT_LABEL: &'static str = "sadeghi-cauchy";
    const FLAWED: Option<FlawedSampler> = Some(FlawedSampler {
        name: "box_muller",
        label: "sadeghi-box_muller",
        help: "Hery and Ramamoorthi 2011's Box-Muller sampler as Ou et al. 2012 (Appendices A, B) describe it: \
               biased at grazing angles",
    });

    /// With the Box-Muller sampler ([`SadeghiSampler::BoxMuller`]) when `flawed`.
    fn build(params: &FiberParams, flawed: bool) -> Result<Sadeghi, ParamError> {
        Sadeghi::new(params, if flawed { SadeghiSampler::BoxMuller } else { SadeghiSampler::Cauchy })
    }

    fn validate_own(params: &FiberParams) -> Result<(), ParamError> {
        params.sadeghi.validate()
    }

    /// Narrowest features: TT's longitudinal Gaussian, standard deviation 2 beta_TT = beta_R in
    /// theta_i (variance beta_R^2), and the narrower of the TT and glint azimuthal Gaussians
    /// (standard deviation gamma), resolved by phi panels 1.5 gamma wide (6 s with s = gamma / 4).
    /// Near grazing light f also has a ridge 1 / cos theta high along theta_i = -theta
    /// (cos theta_i / cos^2 theta_d), which lobe-sized panels miss: at least 32 x 16 panels. For
    /// the defaults a_f then agrees with rules twice as fine to 3e-4 at |theta| = 1.569 and to 2e-8
    /// below 1.5 (16 x 8: 1.3e-3, 3e-6). An even count per half puts panel edges at phi = 0 and
    /// pi, the kinks of N_g(|phi| - phi_g) and of cos(phi / 2) on the circle.
    fn table_features(params: &FiberParams) -> TableFeatures {
        let s = &params.sadeghi;
        let beta = s.beta_r.to_radians();
        let gamma = s.gamma_tt.min(s.gamma_g).to_radians();
        TableFeatures {
            min_theta_i_panels: 32,
            min_phi_panels: 16,
            even_phi_panels: true,
            ..TableFeatures::new(gamma / 4.0, beta * beta)
        }
    }

    /// Half of Marschner's: its Gaussians are in theta_h = (theta_i + theta_o) / 2, so half the
    /// width and shift.
    fn set_grid_roughness(params: &mut FiberParams, beta: f64) {
        params.sadeghi.alpha_r = -params.alpha;
        params.sadeghi.beta_r = 0.5 * r_width(beta).to_degrees();
    }

    fn describe(params: &FiberParams) -> String {
        let s = &params.sadeghi;
        format!(
            "alpha_R {}, beta_R {}, gamma_TT {} deg; I {}/{}/{}, I_g {}",
            s.alpha_r, s.beta_r, s.gamma_tt, s.i_r, s.i_tt, s.i_trt, s.i_g
        )
    }
}

impl SamplerKind {
    /// The Sadeghi model's flawed sampler (a name kept for the renderer).
    #[allow(non_upper_case_globals)]
    pub const BoxMuller: SamplerKind = SamplerKind::Flawed(ModelKind::Sadeghi);
}

/// x = pi - |phi| up to sign: wrap(phi - pi), TT's offset from its peak, in [-pi, pi].
fn tt_offset(dphi: f64) -> f64 {
    wrap_angle(dphi - PI)
}

/// Marschner 2003 section 4.3's TRT caustic azimuth of a smooth fiber at normal incidence
/// (eta' = eta): |4 gamma_t - 2 gamma_i| at h_c = sqrt((4 - eta^2) / 3); 0 once the caustics
/// merge (eta >= 2).
fn caustic_azimuth(eta: f64) -> f64 {
    if eta >= 2.0 {
        return 0.0;
    }
    let h = ((4.0 - eta * eta) / 3.0).sqrt();
    (4.0 * (h / eta).asin() - 2.0 * h.asin()).abs()
}

/// A_R, A_TT, A_TRT of a smooth fiber at theta = 0, averaged over h in [-1, 1]:
/// (1/2) int A_p(sin gamma) cos gamma d gamma (analytic in gamma, so Gauss-Legendre converges fast).
fn mean_attenuation(eta: f64, sigma_a: Rgb) -> [Rgb; 3] {
    let mut out = [Rgb::ZERO; 3];
    for (g, w) in composite(-FRAC_PI_2, FRAC_PI_2, 16, 8) {
        let h = g.sin();
        let cos_gamma_t = (1.0 - (h / eta).powi(2)).sqrt();
        let a = ap(1.0, 0.0, eta, h, sigma_a, cos_gamma_t);
        for p in 0..3 {
            out[p] += a[p] * (0.5 * w * g.cos());
        }
    }
    out
}

/// ISHair's unnormalized Gaussian g(w^2, x) = exp(-x^2 / (2 w^2)).
fn gauss(width: f64, x: f64) -> f64 {
    (-0.5 * (x / width).powi(2)).exp()
}

/// The normal density of standard deviation `width` on the whole line (Box-Muller's).
fn normal(width: f64, x: f64) -> f64 {
    gauss(width, x) / (width * TAU.sqrt())
}

/// int_a^b g(w^2, x) dx = w sqrt(pi/2) (erf(b / (w sqrt 2)) - erf(a / (w sqrt 2))), for a <= b, with
/// erfc on the tails so that nothing cancels.
fn gauss_mass(a: f64, b: f64, width: f64) -> f64 {
    let (a, b) = (a / (width * SQRT_2), b / (width * SQRT_2));
    let d = if a >= 0.0 {
        erfc(a) - erfc(b)
    } else if b <= 0.0 {
        erfc(-b) - erfc(-a)
    } else {
        erf(b) - erf(a)
    };
    (width * FRAC_PI_2.sqrt() * d).max(0.0)
}

/// The integral over [c - pi/2, c + pi/2] (c in [-pi, pi]) of a function on the circle, given its
/// integral `mass(lo, hi)` over subintervals of [-pi, pi].
fn window_mass(c: f64, mass: impl Fn(f64, f64) -> f64) -> f64 {
    [-TAU, 0.0, TAU]
        .into_iter()
        .map(|turn| {
            let (lo, hi) = ((c - FRAC_PI_2 - turn).max(-PI), (c + FRAC_PI_2 - turn).min(PI));
            if hi > lo { mass(lo, hi) } else { 0.0 }
        })
        .sum()
}

/// atan(a) - atan(b) for a >= b, without the cancellation of two angles near +-pi/2:
/// atan((a - b) / (1 + a b)) where a b > -1.
fn atan_diff(a: f64, b: f64) -> f64 {
    let ab = a * b;
    if ab > -1.0 { ((a - b) / (1.0 + ab)).atan() } else { a.atan() - b.atan() }
}

/// A Cauchy density of center c and width w cut to [lo, hi] and renormalized (ISHair section
/// 3.2): w / (((x - c)^2 + w^2) (atan(y_hi) - atan(y_lo))), y = (x - c) / w.
#[derive(Clone, Copy, Debug)]
struct Cauchy {
    center: f64,
    width: f64,
    lo: f64,
    hi: f64,
    y_lo: f64,
    /// atan(y_hi) - atan(y_lo): ISHair's A - B, C_TT, C_g - D_g.
    mass: f64,
}

impl Cauchy {
    fn new(center: f64, width: f64, lo: f64, hi: f64) -> Cauchy {
        let (y_lo, y_hi) = ((lo - center) / width, (hi - center) / width);
        Cauchy { center, width, lo, hi, y_lo, mass: atan_diff(y_hi, y_lo) }
    }

    fn pdf(&self, x: f64) -> f64 {
        let y = (x - self.center) / self.width;
        1.0 / (self.width * (1.0 + y * y) * self.mass)
    }

    #[cfg(test)]
    fn cdf(&self, x: f64) -> f64 {
        (atan_diff((x - self.center) / self.width, self.y_lo) / self.mass).clamp(0.0, 1.0)
    }

    /// The inverse CDF: y = tan(atan(y_lo) + u mass), by the tangent addition formula so that a
    /// y_lo far out in the tail keeps its precision.
    fn sample(&self, u: f64) -> f64 {
        let t = (u * self.mass).tan();
        let y = (self.y_lo + t) / (1.0 - self.y_lo * t);
        let x = self.center + self.width * y;
        if x.is_nan() { self.lo } else { x.clamp(self.lo, self.hi) }
    }
}

/// cos(phi / 2) / 4 over [-pi, pi] by inverse CDF: CDF (sin(phi / 2) + 1) / 2 (supplement 3.2).
fn half_cos_sample(u: f64) -> f64 {
    2.0 * (2.0 * u - 1.0).clamp(-1.0, 1.0).asin()
}

/// The Sadeghi fiber at one hit: what depends on wo.
pub struct SadeghiHit<'a> {
    fiber: &'a Sadeghi,
    theta_o: f64,
    sin_o: f64,
    cos_o: f64,
    phi_o: f64,
    /// ISHair's longitudinal Cauchys of R, TT, TRT over the valid theta_h range.
    cauchy: [Cauchy; 3],
}

impl FiberModel for Sadeghi {
    type Hit<'a> = SadeghiHit<'a>;

    fn at(&self, wo: DVec3, _h: f64) -> SadeghiHit<'_> {
        let (sin_o, cos_o) = sin_cos_theta(wo);
        let theta_o = sin_o.atan2(cos_o);
        // theta_i in [-pi/2, pi/2] is theta_h in [theta_o / 2 - pi/4, theta_o / 2 + pi/4].
        let (lo, hi) = (0.5 * theta_o - FRAC_PI_4, 0.5 * theta_o + FRAC_PI_4);
        SadeghiHit {
            fiber: self,
            theta_o,
            sin_o,
            cos_o,
            phi_o: phi(wo),
            cauchy: std::array::from_fn(|l| Cauchy::new(self.alpha[l], self.beta[l], lo, hi)),
        }
    }
}

/// What the model needs of a direction wi at a hit.
struct Angles {
    theta_h: f64,
    cos_i: f64,
    /// phi_i - phi_o in [-pi, pi].
    dphi: f64,
    /// cos theta_i / cos^2 theta_d: what turns the lobe sum into f |cos theta_i|.
    projection: f64,
}

impl SadeghiHit<'_> {
    fn angles(&self, wi: DVec3) -> Angles {
        let (sin_i, cos_i) = sin_cos_theta(wi);
        let cos2_d = 0.5 * (1.0 + self.cos_o * cos_i + self.sin_o * sin_i);
        Angles {
            theta_h: 0.5 * (sin_i.atan2(cos_i) + self.theta_o),
            cos_i,
            dphi: wrap_angle(phi(wi) - self.phi_o),
            projection: cos_i / cos2_d.max(1e-24),
        }
    }

    fn value(&self, a: &Angles) -> Rgb {
        let f = self.fiber;
        let m: [f64; 3] = std::array::from_fn(|l| gauss(f.beta[l], a.theta_h - f.alpha[l]));
        let n = f.n(a.dphi);
        (0..LOBES).map(|p| f.intensity[p] * (m[LONG[p]] * n[p])).sum::<Rgb>() * a.projection
    }

    /// The mixture density per unit solid angle that the sampler reports.
    fn density(&self, a: &Angles) -> f64 {
        let f = self.fiber;
        let (long, az): ([f64; 3], [f64; LOBES]) = match f.sampler {
            SadeghiSampler::Cauchy => (
                std::array::from_fn(|l| self.cauchy[l].pdf(a.theta_h)),
                [
                    0.25 * (0.5 * a.dphi).cos().max(0.0),
                    f.tt_cauchy.pdf(tt_offset(a.dphi)),
                    0.25 * (0.5 * a.dphi).cos().max(0.0),
                    0.5 * f.glint_cauchy.pdf(a.dphi.abs()),
                ],
            ),
            SadeghiSampler::BoxMuller => (
                std::array::from_fn(|l| normal(f.beta[l], a.theta_h - f.alpha[l])),
                [
                    0.25 * (0.5 * a.dphi).cos().max(0.0),
                    normal(f.gamma_tt, tt_offset(a.dphi)),
                    0.25 * (0.5 * a.dphi).cos().max(0.0),
                    0.5 * normal(f.gamma_g, a.dphi.abs() - f.phi_g),
                ],
            ),
        };
        let sum: f64 = (0..LOBES).map(|p| f.weights[p] * long[LONG[p]] * az[p]).sum();
        // p(theta_i) = p(theta_h) / 2, and d omega = cos theta_i d theta_i d phi.
        0.5 * sum / a.cos_i.max(1e-12)
    }

    /// f_s^G at `a` (see [`SpreadHit::eval_spread`]).
    fn spread_value(&self, a: &Angles, spread: Rgb) -> Rgb {
        let f = self.fiber;
        let n = f.n_half_circle(a.dphi);
        let mut out = Rgb::ZERO;
        for c in 0..3 {
            // spread is a variance of theta_i; theta_h = theta_i / 2 + const takes a quarter of it.
            let extra = 0.25 * spread.0[c].max(0.0);
            let m: [f64; 3] = std::array::from_fn(|l| {
                let widened = (f.beta[l] * f.beta[l] + extra).sqrt();
                f.beta[l] / widened * gauss(widened, a.theta_h - f.alpha[l])
            });
            out.0[c] = (0..LOBES).map(|p| f.intensity[p].0[c] * m[LONG[p]] * n[p]).sum();
        }
        out * a.projection
    }

    /// ISHair's draw of (theta_i, phi) for lobe p (ISHair sections 3.2.1, 3.2.2).
    fn draw_cauchy(&self, p: usize, u: [f64; 4]) -> (f64, f64) {
        let f = self.fiber;
        let theta_h = self.cauchy[LONG[p]].sample(u[1]);
        let dphi = match p {
            TT => PI + f.tt_cauchy.sample(u[2]),
            GLINT => f.glint_cauchy.sample(u[2]) * if u[3] < 0.5 { 1.0 } else { -1.0 },
            _ => half_cos_sample(u[2]),
        };
        ((2.0 * theta_h - self.theta_o).clamp(-FRAC_PI_2, FRAC_PI_2), dphi)
    }

    /// Hery and Ramamoorthi's draw as ISHair's Appendices A and B describe it.
    fn draw_box_muller(&self, p: usize, u: [f64; 4]) -> (f64, f64) {
        let f = self.fiber;
        let l = LONG[p];
        let r = (-2.0 * (1.0 - u[1]).ln()).sqrt();
        let (z1, z0) = (TAU * u[2]).sin_cos();
        let (z0, z1) = (r * z0, r * z1);
        let theta_h = (f.alpha[l] + f.beta[l] * z0).clamp(-FRAC_PI_2, FRAC_PI_2);
        let theta_i = 2.0 * theta_h - self.theta_o;
        // Flipped about the pole: with |theta_h| <= pi/2, one flip lands in [-pi/2, pi/2].
        let theta_i = if theta_i > FRAC_PI_2 {
            PI - theta_i
        } else if theta_i < -FRAC_PI_2 {
            -PI - theta_i
        } else {
            theta_i
        };
        let dphi = match p {
            TT => PI + f.gamma_tt * z1,
            GLINT => (f.phi_g + f.gamma_g * z1) * if u[3] < 0.5 { 1.0 } else { -1.0 },
            _ => half_cos_sample(u[3]),
        };
        (theta_i.clamp(-FRAC_PI_2, FRAC_PI_2), dphi)
    }
}

impl FiberHit for SadeghiHit<'_> {
    fn eval(&self, wi: DVec3) -> Rgb {
        self.value(&self.angles(wi))
    }

    fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
        let (p, _) = pick(&self.fiber.weights, u[0]);
        let (theta_i, dphi) = match self.fiber.sampler {
            SadeghiSampler::Cauchy => self.draw_cauchy(p, u),
            SadeghiSampler::BoxMuller => self.draw_box_muller(p, u),
        };
        let wi = direction(theta_i, self.phi_o + dphi);
        let (value, pdf) = self.eval_pdf(wi);
        (pdf > 0.0 && pdf.is_finite()).then_some(FiberSample { wi, value, pdf })
    }

    fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        let a = self.angles(wi);
        (self.value(&a), self.density(&a))
    }
}

impl SpreadHit for SadeghiHit<'_> {
    fn eval_spread(&self, wi: DVec3, spread: Rgb) -> Rgb {
        self.spread_value(&self.angles(wi), spread)
    }

    fn eval_both(&self, wi: DVec3, spread: Rgb) -> (Rgb, Rgb) {
        let a = self.angles(wi);
        (self.value(&a), self.spread_value(&a, spread))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gauss-Legendre integral of `f` over [a, b] (panels fine enough for the Cauchy peaks here).
    fn integral(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
        composite(a, b, 400, 8).iter().map(|&(x, w)| w * f(x)).sum()
    }

    /// Every inverse CDF against its CDF, and every CDF against the integral of its density: the
    /// longitudinal one in theta_i as corrected (erratum 3), the azimuthal ones (TT over
    /// [-pi, pi], glint |phi| over [0, pi], cos(phi / 2)).
    #[test]
    fn cdfs_invert_and_integrate_their_densities() {
        let us = [1e-9, 0.01, 0.2, 0.5, 0.77, 0.999, 1.0 - 1e-9];
        for theta_r in [0.0, 0.7, -1.2, FRAC_PI_2 - 1e-4, -FRAC_PI_2] {
            for (alpha, beta) in [(-0.13, 0.13), (0.2, 0.01), (-0.35, 0.5), (0.3, 1e-4)] {
                let (lo, hi) = (0.5 * theta_r - FRAC_PI_4, 0.5 * theta_r + FRAC_PI_4);
                let c = Cauchy::new(alpha, beta, lo, hi);
                // ISHair's density of theta_i (supplement 3.1 without its 1 / cos theta_i):
                // beta / (((theta_h - alpha)^2 + beta^2) 2 (A - B)), A and B of section 3.2.1.
                let (a_, b_) = (((hi - alpha) / beta).atan(), ((lo - alpha) / beta).atan());
                let density = |t: f64| {
                    let th = 0.5 * (t + theta_r);
                    beta / (((th - alpha).powi(2) + beta * beta) * 2.0 * (a_ - b_))
                };
                for &u in &us {
                    let th = c.sample(u);
                    assert!((c.cdf(th) - u).abs() < 1e-9, "theta_r {theta_r}, alpha {alpha}, beta {beta}, u {u}");
                    if u > 1e-6 && u < 1.0 - 1e-6 && beta > 1e-3 {
                        let theta_i = 2.0 * th - theta_r;
                        // Integrate in theta_h (d theta_i = 2 d theta_h) over panels that follow the peak.
                        let want = integral(lo, th, |x| 2.0 * density(2.0 * x - theta_r));
                        assert!((want - u).abs() < 1e-7, "CDF {u} vs integral {want} at theta_i {theta_i}");
                    }
                }
            }
        }
        for (center, width, lo, hi) in
            [(0.0, 0.5, -PI, PI), (0.0, 0.05, -PI, PI), (0.32, 0.26, 0.0, PI), (2.6, 0.1, 0.0, PI)]
        {
            let c = Cauchy::new(center, width, lo, hi);
            assert!((integral(lo, hi, |x| c.pdf(x)) - 1.0).abs() < 1e-9);
            for &u in &us {
                let x = c.sample(u);
                assert!((c.cdf(x) - u).abs() < 1e-9 && (integral(lo, x, |x| c.pdf(x)) - u).abs() < 1e-7, "{u}");
            }
        }
        for &u in &us {
            let x = half_cos_sample(u);
            let want = integral(-PI, x, |t| 0.25 * (0.5 * t).cos());
            assert!((want - u).abs() < 1e-9 && (((0.5 * x).sin() + 1.0) * 0.5 - u).abs() < 1e-12, "{u}");
        }
    }

    /// The half-circle means against brute-force integration of N_p over the window.
    #[test]
    fn half_circle_means_match_quadrature() {
        let params = FiberParams { model: super::super::ModelKind::Sadeghi, ..Default::default() };
        let fiber = Sadeghi::new(&params, SadeghiSampler::Cauchy).unwrap();
        for dphi in [0.0, 0.3, -1.4, 2.0, PI, -3.0] {
            let got = fiber.n_half_circle(dphi);
            // Split at the multiples of pi, where N_g (|phi|) and N_R (cos(phi / 2) past pi) have kinks.
            let (a, b) = (dphi - FRAC_PI_2, dphi + FRAC_PI_2);
            let mut ends = vec![a, b];
            ends.extend([-PI, 0.0, PI].into_iter().filter(|&k| k > a && k < b));
            ends.sort_by(f64::total_cmp);
            let want = (0..LOBES).map(|p| {
                ends.windows(2).map(|e| integral(e[0], e[1], |x| fiber.n(wrap_angle(x))[p])).sum::<f64>() / PI
            });
            for (p, w) in want.enumerate() {
                assert!((got[p] - w).abs() < 1e-9 * w.max(1e-3), "lobe {p} at {dphi}: {} vs {w}", got[p]);
            }
        }
    }
}
