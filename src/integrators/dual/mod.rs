//! `dual`: the dual-scattering integrator (Zinke et al. 2008, ray-shooting variant, with the
//! thesis's voxel density grid: Lemein 2020 chapters 3.3 and 5.2).
//!
//! A camera ray stops at the first fiber it hits, as in `single`. There the fiber-to-fiber bounces
//! of `path` are replaced by a shading function F(wo, wi) of the direction wi toward the light:
//!
//! ```text
//! fully lit (a shadow ray through the real strands escapes):
//!     F = f_s + d_b f_back                                                  (F_direct)
//! in shadow (n = fibers crossed toward the light, from the density grid):
//!     T_f = T(a_f(theta), n),  sigma_f^2 = n' beta_f(theta)^2
//!     F = d_f^k T_f (f_s^G + pi d_b f_back^G)                               (F_scatter)
//! ```
//!
//! with theta the light's inclination (the tables' argument, never theta_d). [`DualModel`] says
//! what T, n', k and A_b (in f_back) are: Zinke's literal T = a_f^n, n' = n, k = 2 and his A_b,
//! or the measured default (`two_stream`): T the mean of a_f^N over a Poisson count N of mean n
//! given N >= 1, n' = E[N | N >= 1], k = 1, and A_b = a_f R with R the Kubelka-Munk reflectance of
//! the hair behind the fiber. Every F here is, like
//! [`precompute::fiber::FiberHit::eval`], the projected value f |cos theta_i| per unit solid
//! angle of wi. The pieces:
//!
//! - f_s is the fiber model and f_s^G its forward-spread response
//!   ([`SpreadHit::eval_spread`]) with every lobe widened by 4 sigma_f^2: the tables' widths
//!   are of theta_h = (theta + theta_i) / 2, so a variance of the inclination is 4 times theirs.
//! - f_back = A_b M(theta_i; 2 Delta_b(theta) - theta_o, 4 sigma_b(theta)^2) s_b(phi), with M the
//!   normalized longitudinal lobe of d'Eon et al. 2011 (a Gaussian of theta_h, centred on Delta_b
//!   with standard deviation sigma_b, is that Gaussian of theta_i with twice the width) and
//!   s_b = 1/pi over the backward half |phi| < pi/2 (thesis eq. 3.26). Zinke's constant
//!   2 / (pi cos^2 theta_d) belongs to Marschner's theta_h-normalized Gaussians; with normalized
//!   lobes f_back carries exactly A_b, as A_b's definition asks (thesis eqs. 3.22-3.25).
//! - f_back^G widens M by 4 sigma_f^2 and replaces s_b by its convolution with the half circle
//!   the forward-scattered light arrives from: (pi - |phi|) / pi^2, which also integrates to 1.
//!
//! d_f = d_b = 0 leaves F = f_s when lit and 0 in shadow: single scattering, sample for sample
//! (with shadow rays, in a scene without meshes).
//!
//! A mesh (the head) hides the lights behind it and sends back its own diffuse light: a
//! direction from F's sampler that meets a mesh gathers one estimate of the mesh's radiance
//! (what `path` finds at its second vertex there), with F as for a light. Light samples never
//! draw a mesh, so under `light` sampling one direction a hit is drawn from the fiber's sampler
//! for that light alone.
//!
//! `dual.shadows` "rays" decides lit or in shadow with that shadow ray and marches the grid for
//! n; "lookup" ([`crate::integrators::dual::transmittance`]) reads the lit fraction L = e^-n toward the light and n
//! from deep opacity maps instead, and F = L F_direct + (1 - L) F_scatter, its straight-line n
//! turned into the count along the light's deflected way ([`forward_cosine`]).
//!
//! The environment integral of F is estimated with one light sample per light and one sample of
//! F's own sampler, combined by the power heuristic (Veach 1997). F's sampler is `uniform` over
//! the sphere, or `importance`: the fiber's d'Eon 2013 sampler (which follows f_s) mixed with a
//! small defensive share of the uniform sphere, so that every part of F (the broad backscatter
//! and forward-spread terms too) stays reachable and no estimator is biased. `light` uses light
//! sampling alone (unbiased too: the environment's sampler covers every direction it lights).
//! Mixtures that also drew from the backscatter lobe and from f_s^G's own sampler were measured
//! (brown curls under the courtyard HDRI, 48x48, 3 seeds): each extra component raised the MSE at
//! 4 to 32 spp, by up to 17%, because light sampling already covers those broad terms well.

pub mod cache;
pub mod inputs;
pub mod options;
pub mod transmittance;

use crate::geometry::meshes::{self, MeshHit};
use crate::geometry::strands::Hit;
use crate::geometry::world::{Surface, World};
use crate::integrators::dual::transmittance::ForwardLookup;
use crate::integrators::{
    CameraSample, Frame, Integrator, Sampling, Term, Terms, background, diffuse_light, hit_frame, light_weight,
    sample_cosine, sample_lights, seen_lights, spawn_point,
};
use crate::lights::{LightSample, Lights};
use crate::sampler::Sampler;
use glam::{DVec3, Vec3};
use precompute::conventions::{SPHERE, direction, phi, pick, sin_cos_theta, theta, uniform_sphere, wrap_angle};
use precompute::density::DensityGrid;
use precompute::fiber::{FiberHit, FiberModel, Longitudinal, SpreadHit};
use precompute::spectrum::Rgb;
use precompute::tables::{Quantity, Tables};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f64::consts::{FRAC_1_PI, FRAC_PI_2, PI};

/// Floor on the backscatter lobe's variance (radians^2): sigma_b is 0 only where a_b = 0, and
/// there A_b = 0 too.
const MIN_VARIANCE: f64 = 1e-4;

/// Share of the uniform sphere in the `importance` sampler, times max(d_f, d_b): 0 without
/// multiple scattering, so that `importance` is then exactly `single`'s fiber sampler.
const DEFENSIVE: f64 = 0.02;

/// How `dual` turns the fibers between a shading point and the light into a forward
/// transmittance T_f.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transmittance {
    /// a_f^n of the density grid's mean count n (Zinke et al. 2008 eq. 6 with the thesis's grid).
    Grid,
    /// The mean of a_f^N over a Poisson-distributed count N of mean n, given N >= 1 (the shadow
    /// ray found a fiber): (e^(-n (1 - a_f)) - e^(-n)) / (1 - e^(-n)).
    Poisson,
    /// a_f^N of the real count N of fibers the shadow ray crosses (Zinke's ray shooting, sec. 4.2).
    Fibers,
}

choices! {
    /// The dual-scattering model: Zinke et al. 2008 read literally, the measured default, and the
    /// other variants of the ablation (docs/dual_scattering.md). The first four each change one
    /// thing from the one before; the last three each change one thing in `poisson`.
    pub enum DualModel {
        /// Zinke et al. 2008's pseudo-code read literally, as Lemein 2020 and Unity HDRP do:
        /// T_f = d_f a_f^n of the grid's mean count, and d_f again in F_scatter.
        Zinke2008 = "zinke2008",
        /// d_f applied once, in T_f (Unreal Engine's and alShaders' reading).
        DfOnce = "df_once",
        /// d_f once, with n the real count of fibers the shadow ray crosses (Zinke's ray
        /// shooting).
        Fibers = "fibers",
        /// d_f once, with the mean of a_f^N over a Poisson count of the grid's mean n.
        Poisson = "poisson",
        /// `poisson` with a_f replaced by the per-fiber transmittance of a pile of plates with
        /// inter-reflections (Stokes 1862).
        PoissonStokes = "poisson_stokes",
        /// `poisson` with A_b replaced by the reflectance of a Kubelka-Munk half-space.
        KubelkaMunk = "kubelka_munk",
        /// `poisson` with A_b = a_f R: the light the half-space of fibers behind the shaded fiber
        /// sends back (its Kubelka-Munk reflectance R), passed on toward the viewer by the shaded
        /// fiber's own forward scattering (the default).
        TwoStream = "two_stream",
    }
}

impl DualModel {
    /// Whether d_f enters F_scatter a second time.
    pub fn d_f_twice(self) -> bool {
        self == DualModel::Zinke2008
    }

    /// Whether the density grid's count takes the hair's orientation
    /// ([`DensityGrid::fibers_crossed`]); Zinke's formulas read literally keep the thesis's count
    /// of fibers across the ray ([`DensityGrid::fibers_across`]), for reproduction.
    pub fn oriented_count(self) -> bool {
        !matches!(self, DualModel::Zinke2008 | DualModel::DfOnce)
    }

    /// The density grid's mean count of fibers from `from` along `d` (unit) within `t_max`.
    pub fn grid_count(self, grid: &DensityGrid, from: DVec3, d: DVec3, t_max: f64) -> f64 {
        if self.oriented_count() { grid.fibers_crossed(from, d, t_max) } else { grid.fibers_across(from, d, t_max) }
    }

    /// How the fibers toward the light are counted and turned into T_f.
    pub fn transmittance_kind(self) -> Transmittance {
        match self {
            DualModel::Zinke2008 | DualModel::DfOnce => Transmittance::Grid,
            DualModel::Fibers => Transmittance::Fibers,
            _ => Transmittance::Poisson,
        }
    }

    /// The transmittance per fiber crossed: a_f, or for `poisson_stokes` the factor by which a
    /// deep pile's transmittance falls per fiber. Stokes 1862: one fiber's transfer matrix has
    /// trace 2 cosh K with cosh K = (1 + a_f^2 - a_b^2) / (2 a_f) and determinant 1, so the factor
    /// is e^-K.
    pub fn per_fiber(self, a_f: f64, a_b: f64) -> f64 {
        if self != DualModel::PoissonStokes || a_f <= 0.0 || a_b <= 0.0 {
            return a_f;
        }
        let c = (1.0 + a_f * a_f - a_b * a_b) / (2.0 * a_f);
        1.0 / (c + (c * c - 1.0).max(0.0).sqrt())
    }

    /// T_f / d_f through `n` fibers (a real count or a mean, per `transmittance`), per channel of
    /// a_f and a_b, and the count n' the spread sigma_f^2 = n' beta_f^2 uses: n, or for a Poisson
    /// count given N >= 1 its conditional mean n / (1 - e^(-n)).
    ///
    /// `cosine` is the mean cosine g of the angle by which a fiber deflects the light it scatters
    /// forward (1 for a count that already runs along the light's way, like the density grid's,
    /// see [`crate::integrators::dual::transmittance`]): after the first fiber, which the light meets on the straight
    /// line, its way toward the point crosses 1 / g fibers for each fiber on the line, so each
    /// later fiber transmits b = a^(1/g) (Poisson count only):
    /// T = a E[b^(N - 1) | N >= 1] = (a / b) e^-n (e^(n b) - 1) / (1 - e^-n), which is the
    /// straight-line mean for g = 1 and a n e^-n / (1 - e^-n) (one fiber passes light) as b -> 0.
    pub fn transmittance(self, a_f: Rgb, a_b: Rgb, n: f64, cosine: Rgb) -> (Rgb, f64) {
        let a = a_f.zip(a_b, |f, b| self.per_fiber(f, b));
        match self.transmittance_kind() {
            Transmittance::Grid | Transmittance::Fibers => (a.map(|a| a.powf(n)), n),
            Transmittance::Poisson if n > 0.0 => {
                let (none, some) = ((-n).exp(), -(-n).exp_m1());
                let t = a.zip(cosine, |a, g| {
                    let b = a.powf(1.0 / g.clamp(MIN_COSINE, 1.0));
                    // In expm1 form for small n b (exact as n -> 0, where one fiber transmits a),
                    // else as written (no overflow for large n).
                    let passed = if n * b < 1.0 { none * (n * b).exp_m1() } else { (-n * (1.0 - b)).exp() - none };
                    if b > 0.0 { a / b * passed } else { a * n * none }
                });
                (t / some, n / some)
            }
            Transmittance::Poisson => (a, 1.0),
        }
    }

    /// The local backscattering albedo A_b for a_f, a_b (one channel), given the tables' own
    /// A_b (Zinke et al. 2008 eq. 14 with its three-event term).
    ///
    /// Half-space (`kubelka_munk`, `two_stream`): light entering a half-space of fibers with
    /// forward (a_f) and backward (a_b) fractions per fiber crossed, fibers placed at random so
    /// that light also travels through gaps, obeys dI/dn = -(1 - a_f) I + a_b J,
    /// -dJ/dn = -(1 - a_f) J + a_b I (n = fibers crossed; Kubelka and Munk 1931). Its reflectance
    /// is R = a_b / (s + sqrt(s^2 - a_b^2)) with s = 1 - a_f; its series a_b / 2s + a_b^3 / 8s^3 +
    /// ... has the one- and three-event structure of Zinke's a_b a_f^2 / (1 - a_f^2) + ...;
    /// sigma_a = 0 (a_f + a_b = 1) gives R = 1. Most of that light leaves through the gaps and
    /// reaches the camera on rays that hit other fibers; what the shaded fiber sends toward the
    /// viewer is the part it passes on forward, a_f R (`two_stream`). Zinke's one-event term has
    /// the same a_f, but its light must also cross every fiber on the way in.
    pub fn backscatter_albedo(self, a_f: f64, a_b: f64, table: f64) -> f64 {
        let passed_on = match self {
            DualModel::KubelkaMunk => 1.0,
            DualModel::TwoStream => a_f,
            _ => return table,
        };
        if a_b <= 0.0 {
            return 0.0;
        }
        let s = (1.0 - a_f).max(0.0);
        passed_on * (a_b / (s + (s * s - a_b * a_b).max(0.0).sqrt())).min(1.0)
    }
}

/// The least mean cosine of forward deflection taken (light deflected by more than 84 degrees
/// on average would hardly progress through hair at all).
pub const MIN_COSINE: f64 = 0.1;

/// The mean cosine g of the angle between the way light travels before and after a fiber
/// scatters it forward (|phi| >= pi/2 from the light's azimuth, [`precompute::conventions`]), per channel,
/// weighted by the energy scattered, over the offsets h and the inclinations of the fibers a ray
/// crosses ([`crossing_mean`]'s cos^2 theta). By reciprocity, the fiber's sampler at "wo" = the
/// direction toward the light draws the directions the light leaves in, with weights
/// f |cos theta| / pdf that are the energy scattered there. Deterministic (stratified, a fixed
/// random stream); sampling error about 0.1%.
pub fn forward_cosine(fiber: &impl FiberModel) -> Rgb {
    let (thetas, offsets, draws) = (48, 16, 32);
    let mut rng = Pcg64Mcg::seed_from_u64(0x6f72_7761_7264);
    let (mut sum, mut weight) = (Rgb::ZERO, Rgb::ZERO);
    for i in 0..thetas {
        let theta = -FRAC_PI_2 + PI * (i as f64 + 0.5) / thetas as f64;
        let light = direction(theta, 0.0);
        for j in 0..offsets {
            let hit = fiber.at(light, -1.0 + 2.0 * (j as f64 + 0.5) / offsets as f64);
            for k in 0..draws {
                let u = [(k as f64 + rng.random::<f64>()) / draws as f64, rng.random(), rng.random(), rng.random()];
                let Some(s) = hit.sample(u) else { continue };
                if phi(s.wi).abs() < FRAC_PI_2 {
                    continue;
                }
                let w = s.weight() * theta.cos().powi(2);
                sum += w * (-light.dot(s.wi));
                weight += w;
            }
        }
    }
    sum.zip(weight, |s, w| if w > 0.0 { (s / w).clamp(MIN_COSINE, 1.0) } else { 1.0 })
}

/// Below this predicted share of multiple scattering in the image, `auto` renders `single`.
pub const AUTO_SINGLE_BELOW: f64 = 0.15;

/// The tables' row averaged over light inclinations weighted by cos^2 theta: over the fibers a
/// straight ray crosses in hair of every orientation (directions uniform over the sphere relative
/// to the fiber, times the fiber's projected width cos theta).
pub fn crossing_mean(tables: &Tables) -> [Rgb; 9] {
    let n = 256;
    let mut sum = [Rgb::ZERO; 9];
    let mut weight = 0.0;
    for k in 0..n {
        let theta = -FRAC_PI_2 + PI * (k as f64 + 0.5) / n as f64;
        let w = theta.cos().powi(2);
        for (s, v) in sum.iter_mut().zip(tables.at(theta)) {
            *s += v * w;
        }
        weight += w;
    }
    sum.map(|s| s * (1.0 / weight))
}

/// The share of a hair image's light that multiple scattering carries, as the fiber's tables
/// predict it: the fiber's scattering albedo a_f + a_b (luminance) over the fibers crossed
/// ([`crossing_mean`]). Deep in hair each fiber passes on that fraction of what reaches it, so
/// the orders beyond the first carry about that share of the light (of the geometric series
/// 1 + w + w^2 + ... = 1 / (1 - w), the terms after the first are the share w).
pub fn predicted_multiple_share(tables: &Tables) -> f64 {
    let row = crossing_mean(tables);
    (row[Quantity::AF as usize] + row[Quantity::AB as usize]).luminance()
}

/// The `dual` integrator: the scene, the fiber, its tables and the hair's density grid.
pub struct DualScattering<'a, M> {
    pub world: World<'a>,
    /// The fiber model; its hits give f_s^G too ([`SpreadHit`]).
    pub fiber: &'a M,
    pub lights: &'a Lights,
    pub tables: &'a Tables,
    pub grid: &'a DensityGrid,
    /// Forward scattering density factor d_f in [0, 1] (Zinke et al. 2008; thesis eq. 3.17).
    pub d_f: f64,
    /// Backscattering density factor d_b in [0, 1] (thesis eq. 3.21).
    pub d_b: f64,
    pub model: DualModel,
    pub sampling: Sampling,
    pub shadows: Shadows<'a>,
    /// Light samples (each with a sample of F's sampler) per camera hit, stratified together.
    pub light_samples: u32,
    /// The tables over the fibers a ray crosses ([`crossing_mean`]): what light passing through
    /// hair onto a mesh meets.
    pub crossing: [Rgb; 9],
    /// The mean cosine of forward deflection (see [`DualModel::transmittance`]): the fiber's
    /// ([`forward_cosine`]). The lookup's counts and the density grid's (with the hair's
    /// orientation) both count the fibers on the straight line to the light.
    pub deflection: Rgb,
}

/// How `dual` finds the fibers between a shading point and a light (`dual.shadows`).
#[derive(Clone, Copy)]
pub enum Shadows<'a> {
    /// A shadow ray through the real strands decides lit or not, and in shadow the density grid
    /// is marched for n: crisp hair-on-hair shadows.
    Rays,
    /// Deep opacity maps give the lit fraction toward the light and n: soft shadows at a few
    /// fiber widths; a shadow ray against the meshes alone.
    Lookup(&'a ForwardLookup),
}

/// F toward one light direction, split into its terms (see [`Term`]).
#[derive(Clone, Copy, Default)]
struct Split {
    /// f_s when fully lit.
    single: Rgb,
    /// T_f d_f f_s^G in shadow.
    forward: Rgb,
    /// d_b f_back when lit, T_f d_f pi d_b f_back^G in shadow.
    back: Rgb,
}

impl Split {
    fn total(&self) -> Rgb {
        self.single + self.forward + self.back
    }

    fn scaled(&self, k: f64) -> Split {
        Split { single: self.single * k, forward: self.forward * k, back: self.back * k }
    }

    fn plus(&self, o: &Split) -> Split {
        Split { single: self.single + o.single, forward: self.forward + o.forward, back: self.back + o.back }
    }

    fn add_to(&self, terms: &mut Terms, weight: Rgb) {
        terms[Term::Single as usize] += self.single * weight;
        terms[Term::Forward as usize] += self.forward * weight;
        terms[Term::Back as usize] += self.back * weight;
    }
}

/// A light direction (local) with what every part of F needs of it: its inclination's sine and
/// cosine, |phi_i - phi_o| and the tables' row at its inclination.
struct Incoming {
    wi: DVec3,
    sin_i: f64,
    cos_i: f64,
    dphi: f64,
    row: [Rgb; 9],
    /// The backscatter lobe of each channel at this inclination (when d_b > 0).
    back: [BackLobe; 3],
}

/// The local backscatter lobe f_back of one channel at a light inclination, without its width:
/// its albedo A_b and the sine and cosine of the inclination theta_o - 2 Delta_b whose mirror
/// it is centred on (every term that reads it, lit or in shadow, shares this work).
#[derive(Clone, Copy, Default)]
struct BackLobe {
    albedo: f64,
    sin_c: f64,
    cos_c: f64,
    /// sigma_b^2, a variance of theta_h.
    variance: f64,
}

/// F at one fiber hit, with its sampler.
struct Shading<'a, M: FiberModel + 'a> {
    dual: &'a DualScattering<'a, M>,
    /// The fiber model at this hit (wo and h fixed), for every direction asked about here.
    fiber: M::Hit<'a>,
    frame: Frame,
    /// The inclination and azimuth of the direction toward the camera (local).
    theta_o: f64,
    phi_o: f64,
    /// Origin of shadow rays, grid marches and lookups.
    from: Vec3,
    /// The fiber's radius there, for the lookup (world units).
    radius: f64,
    /// Share of the uniform sphere in the `importance` sampler.
    uniform: f64,
}

impl<'a, M: FiberModel> Shading<'a, M>
where
    M::Hit<'a>: SpreadHit,
{
    fn new(dual: &'a DualScattering<'a, M>, hit: &Hit, dir: DVec3) -> Shading<'a, M> {
        let (frame, wo, h) = hit_frame(hit, dir);
        let uniform = DEFENSIVE * dual.d_f.max(dual.d_b);
        let (theta_o, phi_o) = (theta(wo), phi(wo));
        let fiber = dual.fiber.at(wo, h);
        Shading { dual, fiber, frame, theta_o, phi_o, from: spawn_point(hit), radius: hit.radius as f64, uniform }
    }

    /// F(wo, wi) toward the light direction `wi` (local) = `d` (world), split into its terms,
    /// for light from as far as `reach` (world units): infinity for the lights, a mesh's distance
    /// for the light it sends back. The caller has found no mesh in the way before `reach`.
    fn f(&self, wi: DVec3, d: DVec3, reach: f32) -> Split {
        let dual = self.dual;
        let (sin_i, cos_i) = sin_cos_theta(wi);
        let (theta_i, phi_i) = (sin_i.asin(), phi(wi));
        let dphi = wrap_angle(phi_i - self.phi_o).abs();
        // The lit fraction toward the light (Zinke et al. 2008's directFraction) weighs F_direct
        // against F_scatter of the mean count n. Without an entry, rays.
        let entry = match dual.shadows {
            // The maps hold the hair toward lights at infinity; a mesh's light comes by rays.
            Shadows::Lookup(lookup) if reach == f32::INFINITY => lookup.toward(self.from.as_dvec3(), self.radius, d),
            _ => None,
        };
        // Fully lit from the forward half (no backscatter there): F_direct is f_s alone, and the
        // tables are not read.
        if entry.is_some_and(|(lit, _)| lit >= 1.0) && (dual.d_b == 0.0 || dphi >= FRAC_PI_2) {
            return Split { single: self.fiber.eval(wi), ..Split::default() };
        }
        let row = dual.tables.at(theta_i);
        let back = if dual.d_b > 0.0 { self.back_lobes(&row) } else { [BackLobe::default(); 3] };
        let inc = Incoming { wi, sin_i, cos_i, dphi, row, back };
        let Some((lit, n)) = entry else { return self.f_rays(&inc, d, reach) };
        if lit >= 1.0 {
            return self.direct(&inc, self.fiber.eval(wi));
        }
        if lit <= 0.0 {
            return self.scatter(&inc, n, |spread| self.fiber.eval_spread(wi, spread));
        }
        // Partly lit: f_s and f_s^G share the work of the direction.
        let mut f_s = None;
        let scatter = self.scatter(&inc, n, |spread| {
            let (direct, spread) = self.fiber.eval_both(wi, spread);
            f_s = Some(direct);
            spread
        });
        let f_s = f_s.unwrap_or_else(|| self.fiber.eval(wi));
        self.direct(&inc, f_s).scaled(lit).plus(&scatter.scaled(1.0 - lit))
    }

    /// F with a shadow ray to `reach`: fully lit when no fiber is in the way (a shadow ray
    /// through the real strands, or for `fibers` the real count of fibers crossed, Zinke's ray
    /// shooting, being 0), else in shadow with the count the density grid's march gives.
    fn f_rays(&self, inc: &Incoming, d: DVec3, reach: f32) -> Split {
        let dual = self.dual;
        let fibers = dual.world.fibers;
        let count = (dual.model.transmittance_kind() == Transmittance::Fibers)
            .then(|| fibers.crossings(self.from, d.as_vec3(), reach) as f64);
        let lit = match count {
            Some(n) => n == 0.0,
            None => !fibers.occluded(self.from, d.as_vec3(), reach),
        };
        if lit {
            self.direct(inc, self.fiber.eval(inc.wi))
        } else {
            let n = count.unwrap_or_else(|| dual.model.grid_count(dual.grid, self.from.as_dvec3(), d, reach as f64));
            self.scatter(inc, n, |spread| self.fiber.eval_spread(inc.wi, spread))
        }
    }

    /// F_direct = f_s + d_b f_back: F where the light arrives unobstructed (directFraction = 1,
    /// T_f = 1), given f_s.
    fn direct(&self, inc: &Incoming, f_s: Rgb) -> Split {
        let dual = self.dual;
        let mut split = Split { single: f_s, ..Split::default() };
        if dual.d_b > 0.0 && inc.dphi < FRAC_PI_2 {
            split.back = self.backscatter(inc, Rgb::ZERO) * (dual.d_b * FRAC_1_PI);
        }
        split
    }

    /// F_scatter = d_f^k T_f (f_s^G + pi d_b f_back^G): F where `n` fibers (a mean count) are in
    /// the way (directFraction = 0), with T_f and sigma_f^2 = n' beta_f^2 as the model says
    /// (thesis eqs. 3.18 and 3.20 for `zinke2008`: T_f = a_f^n, n' = n, k = 2). `f_spread` gives
    /// f_s^G for a spread (not called when d_f = 0).
    fn scatter(&self, inc: &Incoming, n: f64, f_spread: impl FnOnce(Rgb) -> Rgb) -> Split {
        let dual = self.dual;
        if dual.d_f == 0.0 {
            return Split::default();
        }
        let (model, row) = (dual.model, &inc.row);
        let a_f = row[Quantity::AF as usize];
        let (t_f, mean_n) = model.transmittance(a_f, row[Quantity::AB as usize], n, dual.deflection);
        let var_f = Rgb(row[Quantity::BetaF as usize].0.map(|b| mean_n * b * b));
        let scale = t_f * if model.d_f_twice() { dual.d_f * dual.d_f } else { dual.d_f };
        let mut split = Split { forward: scale * f_spread(var_f * 4.0), ..Split::default() };
        if dual.d_b > 0.0 {
            let azimuth = (PI - inc.dphi) * FRAC_1_PI * FRAC_1_PI;
            split.back = scale * self.backscatter(inc, var_f) * (PI * dual.d_b * azimuth);
        }
        split
    }

    /// Each channel's [`BackLobe`] from the tables' row at the light's inclination.
    fn back_lobes(&self, row: &[Rgb; 9]) -> [BackLobe; 3] {
        std::array::from_fn(|c| {
            let q = |q: Quantity| row[q as usize].0[c];
            let albedo = self.dual.model.backscatter_albedo(q(Quantity::AF), q(Quantity::AB), q(Quantity::ABack));
            let (sin_c, cos_c) = (self.theta_o - 2.0 * q(Quantity::DeltaB)).sin_cos();
            BackLobe { albedo, sin_c, cos_c, variance: q(Quantity::SigmaB).powi(2) }
        })
    }

    /// A_b(theta) M(theta_i; 2 Delta_b - theta_o, 4 (sigma_b^2 + extra)) per channel: f_back
    /// without its azimuthal factor. `extra` is a theta_h variance, like sigma_b^2.
    fn backscatter(&self, inc: &Incoming, extra: Rgb) -> Rgb {
        Rgb(std::array::from_fn(|c| {
            let b = &inc.back[c];
            if b.albedo <= 0.0 {
                return 0.0;
            }
            let lobe = Longitudinal::new((4.0 * (b.variance + extra.0[c])).max(MIN_VARIANCE));
            b.albedo * lobe.eval(inc.cos_i, inc.sin_i, b.cos_c, b.sin_c)
        }))
    }

    /// A direction (local) from F's sampler and its density; `None` for `light` sampling, which
    /// draws nothing.
    fn sample(&self, sampler: &mut impl Sampler) -> Option<(DVec3, f64)> {
        let importance = match self.dual.sampling {
            Sampling::Light => return None,
            Sampling::Uniform => false,
            Sampling::Importance | Sampling::Flawed(_) => true,
        };
        let u = sampler.get_4d();
        // (u[1], u[2]) is the stratified pair of `Sampler::get_4d`.
        if !importance {
            return Some((uniform_sphere([u[1], u[2]]), 1.0 / SPHERE));
        }
        let (k, u0) = pick(&[1.0 - self.uniform, self.uniform], u[0]);
        if k == 0 {
            // The fiber sampler's own density saves evaluating it again.
            let s = self.fiber.sample([u0, u[1], u[2], u[3]])?;
            Some((s.wi, self.mixture_pdf(s.pdf)))
        } else {
            let wi = uniform_sphere([u[1], u[2]]);
            Some((wi, self.pdf(wi)))
        }
    }

    /// Density per unit solid angle of [`Shading::sample`] at `wi` (local).
    fn pdf(&self, wi: DVec3) -> f64 {
        match self.dual.sampling {
            Sampling::Light => 0.0,
            Sampling::Uniform => 1.0 / SPHERE,
            Sampling::Importance | Sampling::Flawed(_) => self.mixture_pdf(self.fiber.pdf(wi)),
        }
    }

    /// The `importance` mixture's density from the fiber sampler's.
    fn mixture_pdf(&self, fiber_pdf: f64) -> f64 {
        if self.uniform > 0.0 { (1.0 - self.uniform) * fiber_pdf + self.uniform / SPHERE } else { fiber_pdf }
    }

    /// Radiance from a light sample, MIS-weighted against F's sampler, added to `radiance` and
    /// its terms.
    fn light(&self, s: &LightSample, radiance: &mut Rgb, terms: &mut Terms) {
        // A mesh in the way (the head) is opaque: no light of this direction reaches the fiber
        // (the maps and the density grid hold the hair alone).
        if self.dual.world.meshes.occluded(self.from, s.wi.as_vec3(), f32::INFINITY) {
            return;
        }
        let wi = self.frame.to_local(s.wi);
        let split = self.f(wi, s.wi, f32::INFINITY);
        let f = split.total();
        if f.luminance() <= 0.0 {
            return;
        }
        let weight = light_weight(s, || self.pdf(wi));
        *radiance += f * weight;
        split.add_to(terms, weight);
    }
}

impl<M> DualScattering<'_, M> {
    /// The share of a light's radiance from direction `d` (unit, world) that reaches the mesh
    /// point `from` through the hair: what passes between the fibers, plus what the fibers in the
    /// way pass on forward (d_f T_f of the mean count, with a_f over the fibers a ray crosses:
    /// the skin's diffuse response does not see where within the forward spread it arrives).
    /// A mesh in the way blocks it.
    fn through_hair(&self, from: Vec3, d: DVec3) -> Rgb {
        if self.world.meshes.occluded(from, d.as_vec3(), f32::INFINITY) {
            return Rgb::ZERO;
        }
        let (lit, n) = match self.shadows {
            Shadows::Lookup(lookup) => lookup.toward(from.as_dvec3(), 0.0, d).unwrap_or((1.0, 0.0)),
            Shadows::Rays => match self.world.fibers.occluded(from, d.as_vec3(), f32::INFINITY) {
                false => (1.0, 0.0),
                true => (0.0, self.model.grid_count(self.grid, from.as_dvec3(), d, f64::INFINITY)),
            },
        };
        if lit >= 1.0 || self.d_f == 0.0 {
            return Rgb::splat(lit);
        }
        let row = &self.crossing;
        let t_f =
            self.model.transmittance(row[Quantity::AF as usize], row[Quantity::AB as usize], n, self.deflection).0;
        Rgb::splat(lit) + t_f * ((1.0 - lit) * self.d_f)
    }

    /// One estimate of the radiance a diffuse mesh point sends out (the same every way): the
    /// lights' direct light, arriving through the hair as [`DualScattering::through_hair`] says,
    /// from one sample of each light and one cosine sample, MIS-weighted. The light that hair
    /// scatters back onto it is not modeled (docs/usage.md, "Meshes").
    fn mesh_radiance(&self, hit: &MeshHit, sampler: &mut impl Sampler) -> Rgb {
        let from = meshes::spawn_point(hit);
        let mut radiance = Rgb::ZERO;
        sample_lights(self.lights, sampler, |s| radiance += diffuse_light(s, hit, |d| self.through_hair(from, d)));
        let (d, pdf) = sample_cosine(hit.normal.as_dvec3(), sampler.get_2d());
        radiance + hit.albedo * self.through_hair(from, d) * seen_lights(self.lights, d, pdf)
    }

    /// A mesh the camera sees (the head): [`DualScattering::mesh_radiance`] from as many
    /// estimates as a fiber hit takes light samples.
    fn mesh(&self, hit: &MeshHit, sampler: &mut impl Sampler) -> CameraSample {
        let mut radiance = Rgb::ZERO;
        let k = self.light_samples;
        sampler.split(k, &mut |sampler| radiance += self.mesh_radiance(hit, sampler));
        CameraSample { radiance: radiance * (1.0 / k as f64), hit_hair: false, terms: [Rgb::ZERO; 4] }
    }
}

impl<M: FiberModel> DualScattering<'_, M>
where
    for<'h> M::Hit<'h>: SpreadHit,
{
    /// F toward the direction `wi` (local) drawn with density `pdf` by a sampler other than the
    /// lights', and the weight of the radiance arriving that way: a mesh's light when a mesh is
    /// that way (one estimate of it, through the hair between; light sampling never draws it, so
    /// this sample takes it whole), else with `lights` the lights seen that way, MIS-weighted
    /// against light sampling. `None` where no light arrives.
    fn gather(
        &self,
        shading: &Shading<'_, M>,
        wi: DVec3,
        pdf: f64,
        lights: bool,
        sampler: &mut impl Sampler,
    ) -> Option<(Split, Rgb)> {
        if pdf <= 0.0 {
            return None;
        }
        let d = shading.frame.to_world(wi).normalize();
        let (weight, reach) = match self.world.meshes.closest_hit(shading.from, d.as_vec3(), f32::INFINITY) {
            // Short of the mesh, so that its own surface does not shadow it.
            Some(mesh) => (self.mesh_radiance(&mesh, sampler) / pdf, mesh.t * (1.0 - 1e-4)),
            None if lights => (seen_lights(self.lights, d, pdf) / pdf, f32::INFINITY),
            None => return None,
        };
        // No light that way (a sun-only scene, mostly): F would be multiplied by 0.
        weight.0.iter().any(|&w| w != 0.0).then(|| (shading.f(wi, d, reach), weight))
    }
}

impl<M: FiberModel> Integrator for DualScattering<'_, M>
where
    for<'h> M::Hit<'h>: SpreadHit,
{
    fn radiance(&self, origin: Vec3, dir: DVec3, sampler: &mut impl Sampler) -> CameraSample {
        let hit = match self.world.closest_hit(origin, dir.as_vec3(), f32::INFINITY) {
            None => return background(self.lights, dir),
            Some(Surface::Mesh(hit)) => return self.mesh(&hit, sampler),
            Some(Surface::Fiber(hit)) => hit,
        };
        let shading = Shading::new(self, &hit, dir);
        let (mut radiance, mut terms) = (Rgb::ZERO, [Rgb::ZERO; 4]);
        // `light_samples` sub-samples share the camera ray and the per-hit state. With one, the
        // same random numbers in the same order as `single`: d_f = d_b = 0 reproduces it.
        let k = self.light_samples;
        let mut first = true;
        sampler.split(k, &mut |sampler| {
            sample_lights(self.lights, sampler, |s| shading.light(s, &mut radiance, &mut terms));
            // F's own sampler makes the last request, so every strategy draws the same light
            // directions (renders with the same seed then differ only through the strategy).
            let gathered = match shading.sample(sampler) {
                Some((wi, pdf)) => self.gather(&shading, wi, pdf, true, sampler),
                // Light samples alone: with meshes, one direction from the fiber's own sampler for
                // the light the meshes send back, which light samples never draw (the lights'
                // directions a mesh hides they count as dark, rightly). One per hit, in the first
                // sub-sample and counted k times: it is a small share of the light and costs
                // two more shadow rays when it finds a mesh.
                None if first && !self.world.meshes.is_empty() => shading
                    .fiber
                    .sample(sampler.get_4d())
                    .and_then(|s| self.gather(&shading, s.wi, s.pdf / k as f64, false, sampler)),
                None => None,
            };
            if let Some((split, weight)) = gathered {
                radiance += split.total() * weight;
                split.add_to(&mut terms, weight);
            }
            first = false;
        });
        let share = 1.0 / k as f64;
        terms.iter_mut().for_each(|t| *t = *t * share);
        CameraSample { radiance: radiance * share, hit_hair: true, terms }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// P(N = k) for a Poisson count of mean n.
    fn poisson(n: f64, k: u32) -> f64 {
        (1..=k).fold((-n).exp(), |p, j| p * n / j as f64)
    }

    #[test]
    fn poisson_transmittance_is_the_mean_over_counts() {
        // Against the sum over counts k >= 1 of P(k) a^k / P(N >= 1), and the conditional mean
        // count; one fiber in the way (n -> 0) transmits a.
        for n in [0.05f64, 0.7, 3.0, 12.0, 40.0] {
            for a in [0.0f64, 0.04, 0.35, 0.72, 1.0] {
                let direct = (1..400).map(|k| poisson(n, k) * a.powi(k as i32)).sum::<f64>() / (1.0 - (-n).exp());
                let t = DualModel::Poisson.transmittance(Rgb::splat(a), Rgb::splat(0.1), n, Rgb::ONE).0.0[0];
                assert!((t - direct).abs() < 1e-12 * direct.max(1e-300) + 1e-15, "n {n}, a {a}: {t} vs {direct}");
            }
            let mean = (1..400).map(|k| k as f64 * poisson(n, k)).sum::<f64>() / (1.0 - (-n).exp());
            let mean_count = DualModel::Poisson.transmittance(Rgb::splat(0.5), Rgb::splat(0.1), n, Rgb::ONE).1;
            assert!((mean_count - mean).abs() < 1e-10 * mean);
        }
        let t =
            |model: DualModel, a: f64, n: f64| model.transmittance(Rgb::splat(a), Rgb::splat(0.1), n, Rgb::ONE).0.0[0];
        assert!((t(DualModel::Poisson, 0.6, 1e-9) - 0.6).abs() < 1e-8);
        assert!((t(DualModel::Poisson, 0.6, 0.0) - 0.6).abs() < 1e-15);
        let deep = t(DualModel::Poisson, 0.9, 1000.0);
        assert!((deep / (-100.0f64).exp() - 1.0).abs() < 1e-9, "{deep}");
        assert_eq!(t(DualModel::Zinke2008, 0.5, 3.0), 0.125);
    }

    #[test]
    fn deflected_transmittance_is_the_mean_over_counts() {
        // T = a E[b^(N-1) | N >= 1], b = a^(1/g), against the sum over counts; g = 1 is the
        // straight-line mean, and one fiber in the way (n -> 0) transmits a whatever g.
        for n in [0.05f64, 0.7, 3.0, 12.0, 40.0] {
            for (a, g) in [(0.04f64, 0.5f64), (0.35, 0.8), (0.72, 0.9), (0.9, 0.3), (0.0, 0.7)] {
                let b = a.powf(1.0 / g);
                let direct =
                    (1..400).map(|k| poisson(n, k) * a * b.powi(k as i32 - 1)).sum::<f64>() / (1.0 - (-n).exp());
                let t = DualModel::Poisson.transmittance(Rgb::splat(a), Rgb::splat(0.1), n, Rgb::splat(g)).0.0[0];
                assert!(
                    (t - direct).abs() < 1e-12 * direct.max(1e-300) + 1e-15,
                    "n {n}, a {a}, g {g}: {t} vs {direct}"
                );
            }
        }
        let t = DualModel::Poisson.transmittance(Rgb::splat(0.6), Rgb::splat(0.1), 1e-9, Rgb::splat(0.4)).0.0[0];
        assert!((t - 0.6).abs() < 1e-8);
    }

    #[test]
    fn forward_cosine_agrees_with_uniform_sampling() {
        // The same mean by another estimator: directions uniform over the sphere weighted by the
        // fiber's value f |cos theta| (not its sampler), on a smooth and a rough fiber.
        use precompute::fiber::{Chiang, FiberHit, FiberModel, FiberParams};
        for params in [r#"{"beta_m": 0.3, "beta_n": 0.3}"#, r#"{"beta_m": 0.6, "beta_n": 0.7}"#] {
            let params: FiberParams = serde_json::from_str(params).unwrap();
            let fiber = Chiang::new(&params).unwrap();
            let g = super::forward_cosine(&fiber);
            let mut rng = Pcg64Mcg::seed_from_u64(5);
            let (mut sum, mut weight) = (Rgb::ZERO, Rgb::ZERO);
            for i in 0..48 {
                let theta = -FRAC_PI_2 + PI * (i as f64 + 0.5) / 48.0;
                let light = direction(theta, 0.0);
                for j in 0..16 {
                    let hit = fiber.at(light, -1.0 + 2.0 * (j as f64 + 0.5) / 16.0);
                    for _ in 0..2000 {
                        let wi = uniform_sphere(rng.random());
                        if phi(wi).abs() >= FRAC_PI_2 {
                            let w = hit.eval(wi) * theta.cos().powi(2);
                            sum += w * (-light.dot(wi));
                            weight += w;
                        }
                    }
                }
            }
            for c in 0..3 {
                let want = sum.0[c] / weight.0[c];
                assert!((g.0[c] - want).abs() < 0.01, "{params:?} channel {c}: {} vs {want}", g.0[c]);
                assert!(g.0[c] > 0.3 && g.0[c] < 1.0, "{}", g.0[c]);
            }
            println!("{params:?}: g {:?}", g.0);
        }
    }

    #[test]
    fn stokes_pile_decays_by_its_per_fiber_factor() {
        // Stokes' recursion for identical plates: adding one of transmittance t and reflectance r
        // to a pile (T, R) gives T' = T t / (1 - R r), R' = R + T^2 r / (1 - R r). Deep in the pile
        // T falls by the model's per-fiber factor.
        for (t, r) in [(0.72, 0.074), (0.35, 0.044), (0.9, 0.09), (0.5, 0.45)] {
            let (mut tn, mut rn) = (t, r);
            let mut ratio = 0.0;
            for _ in 0..400 {
                let next = tn * t / (1.0 - rn * r);
                rn += tn * tn * r / (1.0 - rn * r);
                ratio = next / tn;
                tn = next;
            }
            let factor = DualModel::PoissonStokes.per_fiber(t, r);
            assert!((factor - ratio).abs() < 1e-9, "t {t}, r {r}: {factor} vs {ratio}");
            assert!(factor >= t, "inter-reflections only add light");
        }
    }

    #[test]
    fn kubelka_munk_reflectance() {
        // Its series in a_b (one and three backward events) and the white limit.
        let m = DualModel::KubelkaMunk;
        for (a_f, a_b) in [(0.72, 0.001), (0.35, 0.002), (0.04, 0.0005)] {
            let s: f64 = 1.0 - a_f;
            let series = a_b / (2.0 * s) + a_b.powi(3) / (8.0 * s.powi(3));
            assert!((m.backscatter_albedo(a_f, a_b, 9.0) - series).abs() < 1e-9, "{a_f} {a_b}");
        }
        assert!((m.backscatter_albedo(0.8, 0.2, 9.0) - 1.0).abs() < 1e-12);
        assert_eq!(m.backscatter_albedo(0.8, 0.0, 9.0), 0.0);
        assert_eq!(DualModel::Poisson.backscatter_albedo(0.8, 0.1, 9.0), 9.0);
        let (a_f, a_b) = (0.35, 0.044);
        assert_eq!(DualModel::TwoStream.backscatter_albedo(a_f, a_b, 9.0), a_f * m.backscatter_albedo(a_f, a_b, 9.0));
    }
}
