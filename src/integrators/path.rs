//! `path` traces full multiple scattering between fibers: next-event estimation toward one light
//! (`Lights::sample`) combined with fiber (BCSDF) sampling by multiple importance sampling (power
//! heuristic; Veach 1997), and Russian roulette with compensation so that it is unbiased. At a
//! mesh the same with a diffuse surface and cosine sampling. `single` is the same estimator
//! stopped after the first vertex (max depth 1): direct lighting only.

use crate::geometry::meshes;
use crate::geometry::world::{Surface, World};
use crate::integrators::{
    CameraSample, Frame, Integrator, Term, background, diffuse_light, hit_frame, light_weight, sample_cosine,
    sample_lights, seen_lights, spawn_point,
};
use crate::lights::{LightSample, Lights};
use crate::sampler::Sampler;
use glam::{DVec3, Vec3};
use precompute::fiber::{FiberHit, FiberModel};
use precompute::spectrum::Rgb;

pub struct PathTracer<'a, M> {
    pub world: World<'a>,
    pub fiber: &'a M,
    pub lights: &'a Lights,
    /// Number of scattering vertices (fiber or mesh) along a path: 1 is single scattering.
    pub max_depth: u32,
}

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
            // the same within measurement (docs/performance.md, "What makes `path` fast").
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
