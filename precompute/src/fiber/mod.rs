//! Single-fiber scattering models (BCSDFs) and their direction samplers.
//!
//! Every model implements [`FiberModel`]; callers (the lobe image, the tables, the integrators)
//! never ask which model they hold. Directions are unit vectors in the local fiber frame of
//! [`crate::conventions`]. `wo` is the fixed direction the model is normalized for (pbrt's
//! omega_o: toward the camera in a path tracer, toward the light in the precomputed tables) and
//! `wi` the direction integrated or sampled over.

mod attenuation;
mod azimuthal;
mod longitudinal;
mod model;
mod params;

pub use attenuation::{P_MAX, fresnel_dielectric};
pub use azimuthal::scale_from_beta_n;
pub use longitudinal::{Longitudinal, mp, variance_from_beta_m};
pub use model::{FlawedSampler, Model, TableFeatures, r_width};
pub use params::{Absorption, FiberParams, ParamError};

// The fiber models: each `Variant => module::Type` is the model `Type` in `fiber/module.rs`,
// which implements [`Model`]. This list makes [`ModelKind`], [`Fiber`] and [`FiberAt`]; adding a
// model is its file and its line here.
model::models! {
    Chiang => chiang::Chiang,
    Marschner => marschner::Marschner,
    Sadeghi => sadeghi::Sadeghi,
    Deon2014 => deon2014::Deon2014,
}

use crate::conventions::SPHERE;
use crate::spectrum::Rgb;
use glam::DVec3;

/// A direction drawn by a sampler, with what an estimator needs.
#[derive(Clone, Copy, Debug)]
pub struct FiberSample {
    pub wi: DVec3,
    /// The projected BCSDF `f(wo, wi) |cos theta_i|` at `wi`.
    pub value: Rgb,
    /// Density of `wi` per unit solid angle.
    pub pdf: f64,
}

impl FiberSample {
    /// The Monte Carlo weight `f |cos theta_i| / pdf`.
    pub fn weight(&self) -> Rgb {
        self.value / self.pdf
    }
}

/// A single-fiber scattering model together with a sampler for it.
///
/// Everything is asked of the model at one hit ([`FiberModel::at`]): the fixed direction `wo` and
/// the offset `h` across the fiber decide Fresnel, absorption and refraction, so a model computes
/// them once there and every direction evaluated or sampled at that hit reuses them (a `dual`
/// hit asks about two to a few dozen directions, a precomputed table thousands).
pub trait FiberModel: Send + Sync {
    /// The model at one hit.
    type Hit<'a>: FiberHit
    where
        Self: 'a;

    /// The model at the hit with fixed direction `wo` (local) and offset `h`.
    fn at(&self, wo: DVec3, h: f64) -> Self::Hit<'_>;

    /// The h-average sum_k w_k f(wo, wi; h_k) over the rule `(h_k, w_k)` (what the tables and
    /// lobe images integrate: Zinke et al. 2008's f averaged over the fiber's width) at each
    /// direction of `wis`, into `out`. A model whose lobes share work across offsets overrides it
    /// with the same sum, added in the same order.
    fn eval_h_average(&self, wo: DVec3, rule: &[(f64, f64)], wis: &[DVec3], out: &mut [Rgb]) {
        let hits: Vec<_> = rule.iter().map(|&(h, w)| (self.at(wo, h), w)).collect();
        for (wi, o) in wis.iter().zip(out) {
            *o = hits.iter().map(|(hit, w)| hit.eval(*wi) * *w).sum();
        }
    }
}

/// A fiber model at one hit (fixed `wo` and `h`: [`FiberModel::at`]).
pub trait FiberHit: Send + Sync {
    /// The projected BCSDF `f(wo, wi) |cos theta_i|` (pbrt's f times |cos theta_i|), per unit solid
    /// angle of `wi`. Returning the projected value keeps it finite at theta_i = +-pi/2, and it is
    /// what every estimator multiplies by.
    fn eval(&self, wi: DVec3) -> Rgb;

    /// Draws `wi` from four uniform numbers in [0, 1); `None` if no direction can be drawn.
    /// Renderers stratify `(u[1], u[2])` as one pair and `(u[0], u[3])` as another: a sampler draws
    /// its main two-dimensional choice (the longitudinal cone, a point on the sphere) from the
    /// first pair.
    fn sample(&self, u: [f64; 4]) -> Option<FiberSample>;

    /// `(eval, pdf)` at once, as a light sample needs both: the density per unit solid angle
    /// with which [`FiberHit::sample`] draws `wi`, beside the value.
    fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64);

    /// Density per unit solid angle with which [`FiberHit::sample`] draws `wi`.
    fn pdf(&self, wi: DVec3) -> f64 {
        self.eval_pdf(wi).1
    }
}

/// What dual scattering needs of a fiber model beyond single scattering: its response f_s^G to
/// light that reaches the fiber after passing forward through other fibers (Zinke et al. 2008
/// section 4; Lemein 2020 eq. 3.19).
///
/// That light arrives spread about the direction `wi` it entered the hair from: longitudinally by
/// an extra variance `spread` of the inclination (radians^2, per channel), azimuthally uniformly
/// over the half circle of directions within pi/2 of `wi`'s azimuth (Zinke's s_f = 1/pi). So f_s^G
/// widens every longitudinal lobe by `spread` and replaces each N_p by its average over that
/// half circle. Like [`FiberHit::eval`] it is the projected value per unit solid angle of `wi`
/// and integrates over `wi` to the same albedo.
pub trait SpreadHit: FiberHit {
    fn eval_spread(&self, wi: DVec3, spread: Rgb) -> Rgb;

    /// `(eval, eval_spread)` at once: a model can share the work of one direction between them.
    fn eval_both(&self, wi: DVec3, spread: Rgb) -> (Rgb, Rgb) {
        (self.eval(wi), self.eval_spread(wi, spread))
    }
}

/// Any fiber model, sampled uniformly over the sphere: the baseline for comparisons.
pub struct UniformSampled<M>(pub M);

/// [`UniformSampled`] at one hit.
pub struct UniformHit<H>(H);

impl<M: FiberModel> FiberModel for UniformSampled<M> {
    type Hit<'a>
        = UniformHit<M::Hit<'a>>
    where
        Self: 'a;

    fn at(&self, wo: DVec3, h: f64) -> Self::Hit<'_> {
        UniformHit(self.0.at(wo, h))
    }
}

impl<H: FiberHit> FiberHit for UniformHit<H> {
    fn eval(&self, wi: DVec3) -> Rgb {
        self.0.eval(wi)
    }

    fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
        let wi = crate::conventions::uniform_sphere([u[1], u[2]]);
        Some(FiberSample { wi, value: self.0.eval(wi), pdf: 1.0 / SPHERE })
    }

    fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        (self.0.eval(wi), 1.0 / SPHERE)
    }

    fn pdf(&self, _wi: DVec3) -> f64 {
        1.0 / SPHERE
    }
}

/// Which of a model's samplers to draw with: its exact one, or the flawed one its source
/// publishes ([`Model::FLAWED`], kept to measure the flaw). A model drawing with another model's
/// flawed sampler uses its exact one; scene validation rejects such a pairing before it gets here.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SamplerKind {
    /// The sampler whose reported density is the density it draws with.
    Exact,
    /// The flawed sampler of the model named.
    Flawed(ModelKind),
}

impl SamplerKind {
    /// The flawed sampler the CLI and scene files spell `name` ("thesis", "box_muller", ...), of
    /// whichever model has it; `None` if no model has a flawed sampler of that name.
    pub fn flawed(name: &str) -> Option<SamplerKind> {
        ModelKind::with_flawed_sampler(name).map(SamplerKind::Flawed)
    }
}

impl ModelKind {
    /// The name of the model's flawed sampler as the CLI and scene files spell it, if it has one.
    pub const fn flawed_sampler(self) -> Option<&'static str> {
        match self.flawed() {
            Some(f) => Some(f.name),
            None => None,
        }
    }

    /// The model whose flawed sampler the CLI and scene files spell `name`.
    pub fn with_flawed_sampler(name: &str) -> Option<ModelKind> {
        ModelKind::ALL.iter().copied().find(|m| m.flawed_sampler() == Some(name))
    }

    /// The model named in messages with how scene files name it: `the Marschner model's
    /// (fiber.model "marschner")`.
    pub fn possessive(self) -> String {
        format!("the {} model's (fiber.model \"{}\")", self.title(), self.name())
    }

    /// Every model with its one-line help, for `--model`: `chiang (...), marschner (...) or
    /// deon2014 (...)`.
    pub fn help_all() -> String {
        let each: Vec<String> = ModelKind::ALL.iter().map(|m| format!("{} ({})", m.name(), m.help())).collect();
        match each.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        }
    }
}

impl Fiber {
    /// The model of `params` with its exact sampler.
    pub fn exact(params: &FiberParams) -> Result<Fiber, ParamError> {
        Fiber::new(params, SamplerKind::Exact)
    }
}

impl Default for ModelKind {
    /// The first model listed: Chiang et al. 2016's.
    fn default() -> Self {
        ModelKind::ALL[0]
    }
}

impl std::str::FromStr for ModelKind {
    type Err = String;

    fn from_str(s: &str) -> Result<ModelKind, String> {
        ModelKind::ALL.iter().copied().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = ModelKind::ALL.iter().map(|m| m.name()).collect();
            format!("`{s}`: no such fiber model ({})", names.join(", "))
        })
    }
}
