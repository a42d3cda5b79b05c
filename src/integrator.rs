//! Estimators of the radiance arriving along a camera ray.
//!
//! `path` traces full multiple scattering between fibers: next-event estimation toward one light
//! (`Lights::sample`) combined with fiber (BCSDF) sampling by multiple importance sampling (power heuristic; Veach
//! 1997), and Russian roulette with compensation so that it is unbiased. At a mesh (`meshes.rs`)
//! the same with a diffuse surface and cosine sampling. `single` is the same estimator stopped
//! after the first vertex (max depth 1): direct lighting only.

use crate::fibers::Hit;
use crate::light::{LightSample, Lights};
use crate::meshes::{self, MeshHit};
use crate::sampler::Sampler;
use crate::world::{Surface, World};
use glam::{DVec3, Vec3};
use precompute::conventions::h_offset;
use precompute::fiber::{FiberHit, FiberModel};
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
/// it, and the offset h across the fiber (design section 3): what every shading of a hit starts
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

pub struct PathTracer<'a, M> {
    pub world: World<'a>,
    pub fiber: &'a M,
    pub lights: &'a Lights,
    /// Number of scattering vertices (fiber or mesh) along a path: 1 is single scattering.
    pub max_depth: u32,
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
/// azimuths it came from (|phi| < pi/2, design section 3), else forward. Together the terms are
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
    fn of_path(vertex: u32, backward: u32) -> Term {
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

/// Whether scattering from `wi` (toward where the light comes from) into `wo` (toward where it
/// goes), both local, is a backward event: cos(phi_o - phi_i) > 0.
fn is_backward(wo: DVec3, wi: DVec3) -> bool {
    wo.y * wi.y + wo.z * wi.z > 0.0
}

impl<M: FiberModel> PathTracer<'_, M> {
    /// Radiance carried by a light sample toward a vertex where the fiber is `fiber`, MIS-weighted
    /// against fiber sampling, and whether it arrives by a backward event.
    fn light_contribution(
        &self,
        s: &LightSample,
        frame: &Frame,
        wo: DVec3,
        fiber: &M::Hit<'_>,
        from: Vec3,
    ) -> (Rgb, bool) {
        let wi = frame.to_local(s.wi);
        // A delta light needs no density for MIS: no direction sampler can reach it.
        let (f, pdf) = if s.delta { (fiber.eval(wi), 0.0) } else { fiber.eval_pdf(wi) };
        if f.luminance() <= 0.0 || self.world.occluded(from, s.wi.as_vec3(), f32::INFINITY) {
            return (Rgb::ZERO, false);
        }
        (f * light_weight(s, || pdf), is_backward(wo, wi))
    }
}

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

/// Where a path goes on from a vertex: the direction sampled there, its density, the weight
/// f cos / pdf, and the backward events so far counting this vertex's.
struct Onward {
    dir: DVec3,
    pdf: f64,
    weight: Rgb,
    backward: u32,
}

impl<M: FiberModel> Integrator for PathTracer<'_, M> {
    fn radiance(&self, origin: Vec3, dir: DVec3, sampler: &mut impl Sampler) -> CameraSample {
        let Some(mut surface) = self.world.closest_hit(origin, dir.as_vec3(), f32::INFINITY) else {
            return background(self.lights, dir);
        };
        // Terms split the light that hair scatters toward the camera: a mesh the camera sees
        // directly has none.
        let hit_hair = matches!(surface, Surface::Fiber(_));
        let (mut radiance, mut throughput, mut dir) = (Rgb::ZERO, Rgb::ONE, dir);
        let mut terms = [Rgb::ZERO; 4];
        // Backward events at the vertices after the camera fiber's, so far (a mesh vertex makes
        // none: terms class paths by their fiber events).
        let mut backward = 0;
        for depth in 1..=self.max_depth {
            let mut add = |l: Rgb, events: u32| {
                let l = throughput * l;
                radiance += l;
                if hit_hair {
                    terms[Term::of_path(depth, events) as usize] += l;
                }
            };
            let (from, onward) = match &surface {
                Surface::Fiber(hit) => {
                    let (frame, wo, h) = hit_frame(hit, dir);
                    let fiber = self.fiber.at(wo, h);
                    let from = spawn_point(hit);
                    // Backward events counting this vertex's, for light arriving from `wi`.
                    let events = |back: bool| backward + (depth > 1 && back) as u32;
                    sample_lights(self.lights, sampler, |s| {
                        let (l, back) = self.light_contribution(s, &frame, wo, &fiber, from);
                        add(l, events(back));
                    });
                    // Continue by sampling the fiber.
                    let onward = fiber.sample(sampler.get_4d()).map(|s| Onward {
                        dir: frame.to_world(s.wi).normalize(),
                        pdf: s.pdf,
                        weight: s.weight(),
                        backward: events(is_backward(wo, s.wi)),
                    });
                    (from, onward)
                }
                Surface::Mesh(hit) => {
                    let from = meshes::spawn_point(hit);
                    let unblocked =
                        |d: DVec3| Rgb::splat(!self.world.occluded(from, d.as_vec3(), f32::INFINITY) as u8 as f64);
                    sample_lights(self.lights, sampler, |s| add(diffuse_light(s, hit, unblocked), backward));
                    let (dir, pdf) = sample_cosine(hit.normal.as_dvec3(), sampler.get_2d());
                    (from, Some(Onward { dir, pdf, weight: hit.albedo, backward }))
                }
            };
            let Some(s) = onward else { break };
            throughput = throughput * s.weight;
            // Russian roulette before the ray from the second vertex on (a path that ends traces
            // no more rays), compensated by 1 / (survival probability). Started at the third
            // vertex and after the ray, it took 8-31% more time per sample for noise per sample
            // the same within measurement (README, "Speed of the path tracer").
            if depth >= 2 && depth < self.max_depth {
                let survive = throughput.0.iter().copied().fold(0.0, f64::max).min(0.95);
                if sampler.get_1d() >= survive {
                    break;
                }
                throughput = throughput / survive;
            }
            dir = s.dir;
            match self.world.closest_hit(from, dir.as_vec3(), f32::INFINITY) {
                None => {
                    let l = throughput * seen_lights(self.lights, dir, s.pdf);
                    radiance += l;
                    if hit_hair {
                        terms[Term::of_path(depth, s.backward) as usize] += l;
                    }
                    break;
                }
                Some(next) => surface = next,
            }
            backward = s.backward;
            if depth == self.max_depth {
                break;
            }
        }
        CameraSample { radiance, hit_hair, terms }
    }
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
    use precompute::conventions::direction;
    use std::f64::consts::PI;

    #[test]
    fn events_are_backward_within_a_quarter_turn_of_the_light() {
        // Light arriving from azimuth 0 (wi points toward it): leaving within pi/2 of it is
        // backward, beyond is forward, whatever the inclinations.
        for (theta_i, theta_o) in [(0.0, 0.0), (0.7, -0.3), (-1.2, 1.4)] {
            let wi = direction(theta_i, 0.0);
            for (phi, back) in [(0.0, true), (1.5, true), (-1.5, true), (1.65, false), (PI, false), (-2.0, false)] {
                assert_eq!(is_backward(direction(theta_o, phi), wi), back, "phi {phi}");
            }
        }
        assert_eq!(Term::of_path(1, 3), Term::Single);
        assert_eq!(Term::of_path(4, 0), Term::Forward);
        assert_eq!(Term::of_path(2, 1), Term::Back);
        assert_eq!(Term::of_path(5, 2), Term::MultiBack);
    }
}
