//! Estimators of the radiance arriving along a camera ray.
//!
//! `path` traces full multiple scattering between fibers: next-event estimation toward every light
//! combined with fiber (BCSDF) sampling by multiple importance sampling (power heuristic; Veach
//! 1997), and Russian roulette with compensation so that it is unbiased. `single` is the same
//! estimator stopped after the first fiber vertex (max depth 1): direct lighting only.

use crate::fibers::{Fibers, Hit};
use crate::light::{LightSample, Lights};
use glam::{DVec3, Vec3};
use precompute::conventions::h_offset;
use precompute::fiber::FiberModel;
use precompute::spectrum::Rgb;
use rand::Rng;

/// An estimator of the radiance arriving along camera rays.
pub trait Integrator: Sync {
    fn radiance(&self, origin: Vec3, dir: DVec3, rng: &mut impl Rng) -> CameraSample;
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

/// Next-event estimation: one sample of each light, environment then sun, handed to `each`. Every
/// integrator draws its light samples here, so all of them use the same random numbers in the
/// same order (`dual` with d_f = d_b = 0 reproduces `single` exactly).
pub(crate) fn sample_lights(lights: &Lights, rng: &mut impl Rng, mut each: impl FnMut(&LightSample)) {
    if let Some(env) = &lights.environment
        && let Some(s) = env.sample(rng.random())
    {
        each(&s);
    }
    if let Some(sun) = &lights.sun {
        each(&sun.sample(rng.random()));
    }
}

/// A light sample's estimate f L / pdf for the (projected) scattering value `f` toward it,
/// MIS-weighted against a direction sampler whose density toward it `direction_pdf` gives (not
/// asked for a delta light, which no direction sampler can hit).
pub(crate) fn light_estimate(s: &LightSample, f: Rgb, direction_pdf: impl FnOnce() -> f64) -> Rgb {
    let w = if s.delta { 1.0 } else { power_heuristic(s.pdf, direction_pdf()) };
    f * s.radiance * (w / s.pdf)
}

/// Where new rays leave a hit: just inside the fiber, which the BVH then ignores (rays only enter
/// fibers from outside), so a ray leaving through its own fiber cannot hit it again however the
/// hit point was rounded.
pub(crate) fn spawn_point(hit: &Hit) -> Vec3 {
    hit.point - hit.normal * (0.01 * hit.radius)
}

pub struct PathTracer<'a> {
    pub fibers: &'a Fibers,
    pub fiber: &'a dyn FiberModel,
    pub lights: &'a Lights,
    /// Number of fiber vertices along a path: 1 is single scattering.
    pub max_depth: u32,
}

/// Radiance along a camera ray, and whether it hit hair.
pub struct CameraSample {
    pub radiance: Rgb,
    pub hit_hair: bool,
}

impl PathTracer<'_> {
    /// Radiance carried by a light sample toward a vertex, MIS-weighted against fiber sampling.
    fn light_contribution(&self, s: &LightSample, frame: &Frame, wo: DVec3, h: f64, from: Vec3) -> Rgb {
        let wi = frame.to_local(s.wi);
        let f = self.fiber.eval(wo, wi, h);
        if f.luminance() <= 0.0 || self.fibers.occluded(from, s.wi.as_vec3(), f32::INFINITY) {
            return Rgb::ZERO;
        }
        light_estimate(s, f, || self.fiber.pdf(wo, wi, h))
    }
}

/// Radiance of the lights seen along a direction drawn by fiber sampling with density
/// `fiber_pdf`, each MIS-weighted against its own light sampling.
pub(crate) fn seen_lights(lights: &Lights, d: DVec3, fiber_pdf: f64) -> Rgb {
    let mut l = Rgb::ZERO;
    if let Some(env) = &lights.environment {
        l += env.radiance(d) * power_heuristic(fiber_pdf, env.pdf(d));
    }
    if let Some(sun) = &lights.sun {
        l += sun.radiance(d) * power_heuristic(fiber_pdf, sun.pdf(d));
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
    CameraSample { radiance, hit_hair: false }
}

impl Integrator for PathTracer<'_> {
    fn radiance(&self, origin: Vec3, dir: DVec3, rng: &mut impl Rng) -> CameraSample {
        let Some(mut hit) = self.fibers.closest_hit(origin, dir.as_vec3(), f32::INFINITY) else {
            return background(self.lights, dir);
        };
        let (mut radiance, mut throughput, mut dir) = (Rgb::ZERO, Rgb::ONE, dir);
        for depth in 1..=self.max_depth {
            let frame = Frame::new(hit.tangent);
            let wo = frame.to_local(-dir);
            let h = h_offset(wo, frame.to_local(hit.normal.as_dvec3()));
            let from = spawn_point(&hit);

            sample_lights(self.lights, rng, |s| {
                radiance += throughput * self.light_contribution(s, &frame, wo, h, from)
            });

            // Continue by sampling the fiber.
            let Some(s) = self.fiber.sample(wo, h, rng.random()) else { break };
            throughput = throughput * s.weight();
            dir = frame.to_world(s.wi).normalize();
            match self.fibers.closest_hit(from, dir.as_vec3(), f32::INFINITY) {
                None => {
                    radiance += throughput * seen_lights(self.lights, dir, s.pdf);
                    break;
                }
                Some(next) => hit = next,
            }
            if depth == self.max_depth {
                break;
            }
            // Russian roulette from the third vertex on, compensated by 1 / (survival probability).
            if depth >= 3 {
                let survive = throughput.0.iter().copied().fold(0.0, f64::max).min(0.95);
                if rng.random::<f64>() >= survive {
                    break;
                }
                throughput = throughput / survive;
            }
        }
        CameraSample { radiance, hit_hair: true }
    }
}
