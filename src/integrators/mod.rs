//! The estimators of the radiance arriving along a camera ray, and what they share: the
//! [`Integrator`] interface, the local fiber frame at a hit, next-event estimation with multiple
//! importance sampling (power heuristic; Veach 1997), and the split of the radiance into the
//! terms of dual scattering. `path` and `single` are in [`path`], `dual` in [`dual`].

/// A closed set of choices that scene files and the command line name (in snake_case): each
/// choice with its name and a description, which the command line's help shows.
pub trait Choice: Copy + PartialEq + Send + Sync + 'static {
    /// Every choice: (choice, name, description).
    fn choices() -> Vec<(Self, &'static str, &'static str)>;

    /// The name scene files and the command line give this choice.
    fn name(self) -> &'static str {
        Self::choices().into_iter().find(|c| c.0 == self).map_or("", |c| c.1)
    }

    /// The choice called `name`, if any.
    fn named(name: &str) -> Option<Self> {
        Self::choices().into_iter().find(|c| c.1 == name).map(|c| c.0)
    }
}

/// Defines an enum of [`Choice`]s: each variant's name (its serde name too) beside it, and its
/// doc comment as its description, so that the three cannot disagree.
macro_rules! choices {
    ($(#[$meta:meta])* pub enum $name:ident { $($(#[doc = $doc:literal])* $variant:ident = $text:literal,)* }) => {
        $(#[$meta])*
        #[derive(serde::Serialize, serde::Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
        pub enum $name {
            $($(#[doc = $doc])* #[serde(rename = $text)] $variant,)*
        }

        impl $crate::integrators::Choice for $name {
            fn choices() -> Vec<(Self, &'static str, &'static str)> {
                vec![$(($name::$variant, $text, concat!($($doc),*)),)*]
            }
        }
    };
}

choices! {
    /// Which estimator renders the image.
    #[derive(PartialOrd, Ord)]
    pub enum IntegratorKind {
        /// Direct lighting only.
        Single = "single",
        /// Full multiple scattering between fibers (the reference).
        Path = "path",
        /// Dual-scattering approximation of multiple scattering (Zinke et al. 2008).
        Dual = "dual",
        /// `single` where the fiber's tables predict little multiple scattering (dark hair), else
        /// `dual`; the render says which and why.
        Auto = "auto",
    }
}

/// How an integrator draws directions at a fiber, combined with light sampling by MIS. Ordered
/// as [`Choice::choices`] lists them (the flawed samplers in the models' order), which is how
/// `converge` sorts its methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Sampling {
    /// d'Eon et al. 2013 fiber importance sampling (for dual, a mixture covering all its terms).
    Importance,
    /// Uniform sphere sampling (the baseline).
    Uniform,
    /// Light sampling alone (`dual` only).
    Light,
    /// The flawed sampler the model's source publishes ([`precompute::fiber::FlawedSampler`]),
    /// for that model's fibers only: biased, there to measure that.
    Flawed(ModelKind),
}

impl Choice for Sampling {
    fn choices() -> Vec<(Self, &'static str, &'static str)> {
        let mut all = vec![
            (
                Sampling::Importance,
                "importance",
                "d'Eon et al. 2013 fiber importance sampling (for dual, a mixture covering all its terms)",
            ),
            (Sampling::Uniform, "uniform", "Uniform sphere sampling (the baseline)"),
            (Sampling::Light, "light", "Light sampling alone (`dual` only)"),
        ];
        let flawed = ModelKind::ALL.iter().filter_map(|&m| m.flawed().map(|f| (Sampling::Flawed(m), f.name, f.help)));
        all.extend(flawed);
        all
    }
}

impl Sampling {
    /// An error unless `model` has this sampler: each flawed sampler is one model's.
    pub fn check_model(self, model: ModelKind) -> std::result::Result<(), String> {
        match self {
            Sampling::Flawed(owner) if owner != model => {
                Err(format!("`{}` is {}, not this fiber's", self.name(), owner.possessive()))
            }
            _ => Ok(()),
        }
    }

    /// The fiber sampler this sampling draws directions with.
    pub fn fiber_sampler(self) -> SamplerKind {
        match self {
            Sampling::Flawed(model) => SamplerKind::Flawed(model),
            Sampling::Importance | Sampling::Uniform | Sampling::Light => SamplerKind::Exact,
        }
    }
}

/// Scene files spell a sampling by its [`Choice::name`].
impl serde::Serialize for Sampling {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for Sampling {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Sampling, D::Error> {
        static NAMES: std::sync::LazyLock<Vec<&'static str>> =
            std::sync::LazyLock::new(|| Sampling::choices().into_iter().map(|c| c.1).collect());
        let name = String::deserialize(d)?;
        Sampling::named(&name).ok_or_else(|| serde::de::Error::unknown_variant(&name, NAMES.as_slice()))
    }
}

pub mod dual;
pub mod path;

use crate::geometry::meshes::MeshHit;
use crate::geometry::strands::Hit;
use crate::lights::{LightSample, Lights};
use crate::sampler::Sampler;
use glam::{DVec3, Vec3};
use precompute::conventions::h_offset;
use precompute::fiber::{ModelKind, SamplerKind};
use precompute::spectrum::Rgb;
use std::f64::consts::{FRAC_1_PI, TAU};

/// An estimator of the radiance arriving along camera rays.
pub trait Integrator: Sync {
    fn radiance(&self, origin: Vec3, dir: DVec3, sampler: &mut impl Sampler) -> CameraSample;
}

/// Local fiber frame at a hit: x along the tangent (conventions module).
pub(crate) struct Frame {
    u: DVec3,
    v: DVec3,
    w: DVec3,
}

impl Frame {
    pub(crate) fn new(tangent: Vec3) -> Frame {
        let u = tangent.as_dvec3().normalize();
        let (v, w) = u.any_orthonormal_pair();
        Frame { u, v, w }
    }

    pub(crate) fn to_local(&self, d: DVec3) -> DVec3 {
        DVec3::new(d.dot(self.u), d.dot(self.v), d.dot(self.w))
    }

    pub(crate) fn to_world(&self, d: DVec3) -> DVec3 {
        self.u * d.x + self.v * d.y + self.w * d.z
    }
}

pub(crate) fn power_heuristic(a: f64, b: f64) -> f64 {
    if a <= 0.0 { 0.0 } else { a * a / (a * a + b * b) }
}

/// Next-event estimation: one light sample ([`Lights::sample`]), handed to `each`. Every
/// integrator draws its light samples here, so all of them use the same random numbers in the
/// same order (`dual` with d_f = d_b = 0 reproduces `single` exactly).
pub(crate) fn sample_lights(lights: &Lights, sampler: &mut impl Sampler, mut each: impl FnMut(&LightSample)) {
    if let Some(s) = lights.sample(sampler) {
        each(&s);
    }
}

/// A light sample's weight L w / pdf, MIS-weighted against a direction sampler whose density
/// toward it `direction_pdf` gives (not asked for a delta light, which no direction sampler can
/// hit): the estimate of the light's contribution is the (projected) scattering value times it.
pub(crate) fn light_weight(s: &LightSample, direction_pdf: impl FnOnce() -> f64) -> Rgb {
    let w = if s.delta { 1.0 } else { power_heuristic(s.pdf, direction_pdf()) };
    s.radiance * (w / s.pdf)
}

/// The fiber frame at a hit seen along `dir` (unit, world), the direction toward the viewer in
/// it, and the offset h across the fiber ([`precompute::conventions`]): what every shading of a hit starts
/// from, and what the forward-transmittance lookup bins its entries by.
pub(crate) fn hit_frame(hit: &Hit, dir: DVec3) -> (Frame, DVec3, f64) {
    let frame = Frame::new(hit.tangent);
    let wo = frame.to_local(-dir);
    let h = h_offset(wo, frame.to_local(hit.normal.as_dvec3()));
    (frame, wo, h)
}

/// Where new rays leave a hit: just inside the fiber, which the BVH then ignores (rays only enter
/// fibers from outside), so a ray leaving through its own fiber cannot hit it again however the
/// hit point was rounded.
pub(crate) fn spawn_point(hit: &Hit) -> Vec3 {
    hit.point - hit.normal * (0.01 * hit.radius)
}

/// Radiance along a camera ray, whether it hit hair, and the radiance split into [`Term`]s.
pub struct CameraSample {
    pub radiance: Rgb,
    pub hit_hair: bool,
    pub terms: Terms,
}

/// The parts of a hair pixel's radiance that dual scattering models separately (Zinke et al.
/// 2008, section 4), so that each of `dual`'s terms can be compared with the light `path` finds
/// on the same kind of path. Events are classed at the fibers between the light and the camera
/// fiber, not at the camera fiber itself: an event is backward when light leaves into the half of
/// azimuths it came from (|phi| < pi/2, [`precompute::conventions`]), else forward. Together the terms are
/// the radiance of light scattered by hair; background seen directly is in none of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Term {
    /// Light scattered once, at the camera fiber (`path`: depth 1; `dual`: f_s when fully lit).
    Single,
    /// Light that reached the camera fiber through forward events only (`dual`: T_f d_f f_s^G).
    Forward,
    /// Light with exactly one backward event (`dual`: every local backscatter term, d_b f_back).
    Back,
    /// Light with two or more backward events (`dual` has no separate term for it: A_b's
    /// three-event part is counted in `Back`).
    MultiBack,
}

impl Term {
    pub const ALL: [Term; 4] = [Term::Single, Term::Forward, Term::Back, Term::MultiBack];

    pub fn name(self) -> &'static str {
        match self {
            Term::Single => "single",
            Term::Forward => "forward",
            Term::Back => "back",
            Term::MultiBack => "multiback",
        }
    }

    /// The term of light scattered at `vertex` fibers (1 = the camera fiber alone) with
    /// `backward` backward events among them.
    pub(crate) fn of_path(vertex: u32, backward: u32) -> Term {
        match (vertex, backward) {
            (1, _) => Term::Single,
            (_, 0) => Term::Forward,
            (_, 1) => Term::Back,
            _ => Term::MultiBack,
        }
    }
}

/// Radiance per [`Term`], indexed by `Term as usize`.
pub type Terms = [Rgb; 4];

/// Radiance of the lights seen along a direction drawn by fiber sampling with density
/// `fiber_pdf`, each MIS-weighted against its own light sampling.
pub(crate) fn seen_lights(lights: &Lights, d: DVec3, fiber_pdf: f64) -> Rgb {
    let (env_pdf, sun_pdf) = lights.pdfs(d);
    let mut l = Rgb::ZERO;
    if let Some(env) = &lights.environment {
        l += env.radiance(d) * power_heuristic(fiber_pdf, env_pdf);
    }
    if let Some(sun) = &lights.sun {
        l += sun.radiance(d) * power_heuristic(fiber_pdf, sun_pdf);
    }
    l
}

/// What a camera ray that misses the hair sees.
pub(crate) fn background(lights: &Lights, dir: DVec3) -> CameraSample {
    let mut radiance = Rgb::ZERO;
    if let Some(env) = &lights.environment {
        radiance += env.radiance(dir);
    }
    if let Some(sun) = &lights.sun {
        radiance += sun.radiance(dir);
    }
    CameraSample { radiance, hit_hair: false, terms: [Rgb::ZERO; 4] }
}

/// Light from a light sample scattered at a diffuse mesh hit (f = albedo / pi, two-sided),
/// MIS-weighted against cosine sampling; `reaching` gives the share of the light's radiance that
/// reaches the hit from the sample's direction (0 or 1 behind a shadow ray).
pub(crate) fn diffuse_light(s: &LightSample, hit: &MeshHit, reaching: impl FnOnce(DVec3) -> Rgb) -> Rgb {
    let cos = s.wi.dot(hit.normal.as_dvec3());
    if cos <= 0.0 {
        return Rgb::ZERO;
    }
    let reached = reaching(s.wi);
    if reached.0.iter().all(|&r| r == 0.0) {
        return Rgb::ZERO;
    }
    hit.albedo * reached * (cos * FRAC_1_PI) * light_weight(s, || cos * FRAC_1_PI)
}

/// A cosine-weighted direction about the unit normal `n` (Malley's method: a uniform point on the
/// disc, lifted to the hemisphere) and its solid-angle density cos / pi.
pub(crate) fn sample_cosine(n: DVec3, u: [f64; 2]) -> (DVec3, f64) {
    let (r, phi) = (u[0].sqrt(), TAU * u[1]);
    let z = (1.0 - u[0]).max(0.0).sqrt();
    let (a, b) = n.any_orthonormal_pair();
    let d = (a * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize();
    (d, z * FRAC_1_PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samplings_sort_as_they_are_listed_and_read_back_by_name() {
        let listed: Vec<Sampling> = Sampling::choices().into_iter().map(|c| c.0).collect();
        let mut sorted = listed.clone();
        sorted.sort();
        assert_eq!(sorted, listed);
        assert!(listed.len() > 3, "every model with a flawed sampler adds one: {listed:?}");
        for s in listed {
            let json = serde_json::to_string(&s).unwrap();
            assert_eq!(serde_json::from_str::<Sampling>(&json).unwrap(), s, "{json}");
        }
    }
}
