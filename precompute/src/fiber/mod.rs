//! Single-fiber scattering models (BCSDFs) and their direction samplers.
//!
//! Every model implements [`FiberModel`]; callers (the lobe image, the tables, the integrators)
//! never ask which model they hold. Directions are unit vectors in the local fiber frame of
//! [`crate::conventions`]. `wo` is the fixed direction the model is normalized for (pbrt's
//! omega_o: toward the camera in a path tracer, toward the light in the precomputed tables) and
//! `wi` the direction integrated or sampled over.

mod attenuation;
mod azimuthal;
mod chiang;
mod deon2014;
mod longitudinal;
mod marschner;
mod params;
mod sadeghi;

pub use attenuation::{P_MAX, fresnel_dielectric};
pub use azimuthal::scale_from_beta_n;
pub use chiang::{Chiang, ChiangHit};
pub use deon2014::{Deon2014, Deon2014Hit};
pub use longitudinal::{Longitudinal, mp, variance_from_beta_m};
pub use marschner::{Marschner, MarschnerHit, MarschnerParams, MarschnerPdf};
pub use params::{Absorption, FiberParams, ModelKind, ParamError};
pub use sadeghi::{Sadeghi, SadeghiHit, SadeghiParams, SadeghiSampler};

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
/// section 4; thesis eq. 3.19; design section 4).
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
}

/// Which of a model's samplers to draw with: its exact one, or the flawed one its source
/// publishes (kept to measure the flaw). A model without the named flawed sampler uses its exact
/// one; scene validation rejects such a pairing before it gets here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    /// The sampler whose reported density is the density it draws with.
    Exact,
    /// Marschner: the thesis's sampler with its stated density (seed 003 section 4.3).
    Thesis,
    /// Sadeghi: Hery and Ramamoorthi 2011's Box-Muller sampler as seed 000 describes it.
    BoxMuller,
    /// d'Eon 2014: the seed's iterative sampler as printed (Appendix A), with the model's density.
    Iterative,
}

/// The fiber model a [`FiberParams`] names: what commands and integrators hold, so that none of
/// them asks which model it is.
pub enum Fiber {
    Chiang(Chiang),
    Marschner(Marschner),
    Sadeghi(Sadeghi),
    Deon2014(Deon2014),
}

/// A [`Fiber`] at one hit.
pub enum FiberAt<'a> {
    Chiang(ChiangHit<'a>),
    Marschner(MarschnerHit<'a>),
    Sadeghi(SadeghiHit<'a>),
    Deon2014(Deon2014Hit<'a>),
}

/// Calls `$f` on whichever hit a [`FiberAt`] holds.
macro_rules! each_hit {
    ($hit:expr, $h:ident => $f:expr) => {
        match $hit {
            FiberAt::Chiang($h) => $f,
            FiberAt::Marschner($h) => $f,
            FiberAt::Sadeghi($h) => $f,
            FiberAt::Deon2014($h) => $f,
        }
    };
}

impl Fiber {
    /// The model of `params` drawing with `sampler`.
    pub fn new(params: &FiberParams, sampler: SamplerKind) -> Result<Fiber, ParamError> {
        Ok(match params.model {
            ModelKind::Chiang => Fiber::Chiang(Chiang::new(params)?),
            ModelKind::Marschner => {
                let pdf = if sampler == SamplerKind::Thesis { MarschnerPdf::Thesis } else { MarschnerPdf::Exact };
                Fiber::Marschner(Marschner::new(params, pdf)?)
            }
            ModelKind::Sadeghi => {
                let s =
                    if sampler == SamplerKind::BoxMuller { SadeghiSampler::BoxMuller } else { SadeghiSampler::Cauchy };
                Fiber::Sadeghi(Sadeghi::new(params, s)?)
            }
            ModelKind::Deon2014 => Fiber::Deon2014(Deon2014::with_sampler(params, sampler == SamplerKind::Iterative)?),
        })
    }

    /// Whether the model is far-field: f does not depend on the hit's offset h (every model but
    /// Chiang's), so one hit serves every h.
    pub fn far_field(&self) -> bool {
        !matches!(self, Fiber::Chiang(_))
    }

    /// The model of `params` with its exact sampler.
    pub fn exact(params: &FiberParams) -> Result<Fiber, ParamError> {
        Fiber::new(params, SamplerKind::Exact)
    }
}

impl FiberModel for Fiber {
    type Hit<'a> = FiberAt<'a>;

    fn at(&self, wo: DVec3, h: f64) -> FiberAt<'_> {
        match self {
            Fiber::Chiang(m) => FiberAt::Chiang(m.at(wo, h)),
            Fiber::Marschner(m) => FiberAt::Marschner(m.at(wo, h)),
            Fiber::Sadeghi(m) => FiberAt::Sadeghi(m.at(wo, h)),
            Fiber::Deon2014(m) => FiberAt::Deon2014(m.at(wo, h)),
        }
    }
}

impl FiberHit for FiberAt<'_> {
    fn eval(&self, wi: DVec3) -> Rgb {
        each_hit!(self, h => h.eval(wi))
    }

    fn sample(&self, u: [f64; 4]) -> Option<FiberSample> {
        each_hit!(self, h => h.sample(u))
    }

    fn eval_pdf(&self, wi: DVec3) -> (Rgb, f64) {
        each_hit!(self, h => h.eval_pdf(wi))
    }
}

impl SpreadHit for FiberAt<'_> {
    fn eval_spread(&self, wi: DVec3, spread: Rgb) -> Rgb {
        each_hit!(self, h => h.eval_spread(wi, spread))
    }

    fn eval_both(&self, wi: DVec3, spread: Rgb) -> (Rgb, Rgb) {
        each_hit!(self, h => h.eval_both(wi, spread))
    }
}
