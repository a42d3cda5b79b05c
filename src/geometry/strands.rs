//! Ray queries against hair: a BVH (obvhs CwBvh) over strand segments, each a capsule.
//!
//! Fibers are the union of capsules around the strand segments (a sphere swept along each
//! polyline). A ray only ever hits a fiber from outside: a ray that starts on or inside a capsule
//! passes out of it. That matches the far-field fiber BCSDF, whose light enters and leaves at one
//! point, so rays leaving a scattering event need no origin offset and cannot self-intersect.
//! Consecutive capsules of a strand overlap at their joint (each end is a sphere): a ray inside
//! the fiber there "enters" the next capsule without crossing the fiber's surface, so an entry
//! point inside a neighbouring capsule of the same strand is no hit. Without that rule, light
//! leaving a lone straight fiber near a joint "hit" the next segment: 26% more light than Blender
//! Cycles on a front-lit fiber, which agrees with single scattering there (docs/cycles.md).
//!
//! CwBvh skips nodes closer than a hard-coded 1e-4 along the ray (notes/dependencies.md), which
//! would drop hits between hair-thin fibers in scene units. The BVH therefore works in "fiber
//! units": world coordinates divided by the mean fiber radius, so radii are O(1) and the cut-off is
//! 1e-4 radii. Callers see world units only.

use glam::{DVec3, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use precompute::strands::{Segment, Strands};
use std::time::Duration;

/// A capsule in fiber units.
#[derive(Clone, Copy, Debug)]
struct Capsule {
    a: DVec3,
    b: DVec3,
    r: f64,
}

/// A capsule as stored: world units in f32, 32 bytes, two to a cache line (the ray tests are
/// bound by fetching them); [`Fibers::capsule`] turns it into fiber units in f64.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Stored {
    a: Vec3,
    b: Vec3,
    r: f32,
}

const NONE: u32 = u32::MAX;

/// A ray-fiber hit, in world units.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub point: Vec3,
    /// Unit fiber tangent at the hit, root to tip.
    pub tangent: Vec3,
    /// Unit outward surface normal at the hit.
    pub normal: Vec3,
    /// Fiber radius at the hit.
    pub radius: f32,
    /// Index of the segment hit, in `Strands::segments` order.
    pub segment: u32,
}

/// Hair ready for ray queries.
pub struct Fibers {
    bvh: CwBvh,
    /// Capsules in BVH leaf order.
    capsules: Vec<Stored>,
    /// Slots of the previous and next capsules of the same strand (`NONE` at its ends), per slot.
    neighbours: Vec<[u32; 2]>,
    /// World units to fiber units.
    scale: f64,
}

/// Entry distance along a unit-direction ray into a capsule, if the ray enters it from outside at
/// `t > t_min`. Works in f64 and, as notes/dependencies.md advises for thin capsules, solves each
/// quadratic about the ray's closest approach instead of its origin, so no term of the size of the
/// distance squared cancels against the radius squared.
fn enter_capsule(o: DVec3, d: DVec3, c: &Capsule, t_min: f64) -> Option<f64> {
    let ba = c.b - c.a;
    let r2 = c.r * c.r;
    let oa = o - c.a;
    // Most candidates the BVH hands over miss: the distance between the ray's line and the axis's
    // line, |oa . (d x ba)| / |d x ba|, is then above r. Tested squared and multiplied out, without
    // the square root and the two divisions of the exact test below (which checks the same
    // distance), it rejects them for a third of the cost.
    let n = d.cross(ba);
    let (n2, m) = (n.length_squared(), oa.dot(n));
    if n2 > 1e-24 * ba.length_squared() && m * m > r2 * n2 {
        return None;
    }
    let len = ba.length();
    let u = ba / len;
    // Cylinder body: the ray projected on the normal plane of the axis. Both end spheres lie in
    // the infinite cylinder, so a ray that misses it misses the capsule; one that enters it between
    // the end planes enters the capsule there (it is convex); one that enters it beyond an end can
    // only enter the capsule through that end's sphere.
    let d_perp = d - d.dot(u) * u;
    let a2 = d_perp.length_squared();
    let ends: &[(DVec3, f64, f64)] = if a2 > 1e-24 {
        let o_perp = oa - oa.dot(u) * u;
        let t0 = -o_perp.dot(d_perp) / a2;
        let miss2 = (o_perp + t0 * d_perp).length_squared();
        if miss2 > r2 {
            return None;
        }
        let t = t0 - ((r2 - miss2) / a2).sqrt();
        let s = (oa + t * d).dot(u);
        if s < 0.0 {
            &[(c.a, f64::NEG_INFINITY, 0.0)]
        } else if s > len {
            &[(c.b, len, f64::INFINITY)]
        } else {
            return (t > t_min).then_some(t);
        }
    } else {
        &[(c.a, f64::NEG_INFINITY, 0.0), (c.b, len, f64::INFINITY)]
    };
    // End caps: spheres, counted only on the outer half beyond each end of the axis.
    let mut best = f64::INFINITY;
    for &(center, lo, hi) in ends {
        let oc = o - center;
        let t0 = -oc.dot(d);
        let miss2 = (oc + t0 * d).length_squared();
        if miss2 <= r2 {
            let t = t0 - (r2 - miss2).sqrt();
            let s = (o + t * d - c.a).dot(u);
            if t > t_min && t < best && s >= lo && s <= hi {
                best = t;
            }
        }
    }
    best.is_finite().then_some(best)
}

/// Whether `p` lies strictly inside the capsule (not on its surface).
fn inside_capsule(p: DVec3, c: &Capsule) -> bool {
    let ba = c.b - c.a;
    let s = ((p - c.a).dot(ba) / ba.length_squared()).clamp(0.0, 1.0);
    (p - (c.a + s * ba)).length_squared() < c.r * c.r * (1.0 - 1e-9)
}

/// Memory the BVH's build takes per segment at its peak, above the strands: 2,590 MB over 9.75M
/// segments measured on the film-scale groom (docs/usage.md, "Film-scale grooms"), mostly obvhs's own
/// working memory.
pub const BUILD_BYTES_PER_SEGMENT: u64 = 270;

impl Fibers {
    /// Builds the BVH; `strands` must be valid (see `Strands::validate`).
    pub fn new(strands: &Strands) -> Fibers {
        let count = strands.segment_count();
        let mean_r = strands.segments().map(|s| s.radius as f64).sum::<f64>() / count.max(1) as f64;
        let scale = if mean_r > 0.0 { 1.0 / mean_r } else { 1.0 };
        let aabbs: Vec<Aabb> = strands
            .segments()
            .map(|s| {
                let (a, b, r) = (s.a.as_dvec3() * scale, s.b.as_dvec3() * scale, s.radius as f64 * scale);
                // Pad by the radius plus a rounding margin so the f32 boxes surely contain the capsule.
                let pad = DVec3::splat(r * (1.0 + 1e-5) + a.abs().max(b.abs()).max_element() * 1e-6);
                Aabb::new(Vec3A::from((a.min(b) - pad).as_vec3()), Vec3A::from((a.max(b) + pad).as_vec3()))
            })
            .collect();
        let mut build_time = Duration::ZERO;
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&aabbs, BvhBuildParams::slow_build(), &mut build_time);
        // The build's own memory is its peak (docs/usage.md, "Film-scale grooms"): the segments are
        // gathered only after it, and the boxes let go.
        drop(aabbs);
        let segments: Vec<_> = strands.segments().collect();
        // The BVH's primitive indices are each slot's segment index (in `Strands::segments` order).
        let ids = &bvh.primitive_indices;
        let mut slots = vec![0; ids.len()];
        for (slot, &id) in ids.iter().enumerate() {
            slots[id as usize] = slot as u32;
        }
        // Consecutive segments share a point exactly where they belong to one strand.
        let joined = |i: usize| i + 1 < segments.len() && segments[i].b == segments[i + 1].a;
        let capsules = ids
            .iter()
            .map(|&i| {
                let s = segments[i as usize];
                Stored { a: s.a, b: s.b, r: s.radius }
            })
            .collect();
        let neighbours = ids
            .iter()
            .map(|&i| {
                let i = i as usize;
                [if i > 0 && joined(i - 1) { slots[i - 1] } else { NONE }, if joined(i) { slots[i + 1] } else { NONE }]
            })
            .collect();
        Fibers { bvh, capsules, neighbours, scale }
    }

    /// World units to the BVH's fiber units (1 / the mean fiber radius).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The original segment index of the capsule in leaf slot `slot`.
    fn id(&self, slot: usize) -> u32 {
        self.bvh.primitive_indices[slot]
    }

    /// Memory held, in bytes: the BVH's nodes and indices, the capsules and their neighbours.
    pub fn bytes(&self) -> usize {
        use std::mem::size_of_val;
        size_of_val(&self.bvh.nodes[..])
            + size_of_val(&self.bvh.primitive_indices[..])
            + size_of_val(&self.capsules[..])
            + size_of_val(&self.neighbours[..])
    }

    /// The capsule in leaf slot `slot`, in fiber units.
    fn capsule(&self, slot: usize) -> Capsule {
        let c = &self.capsules[slot];
        Capsule { a: c.a.as_dvec3() * self.scale, b: c.b.as_dvec3() * self.scale, r: c.r as f64 * self.scale }
    }

    /// The unit tangent a hit on segment `s` reports (computed as for the stored capsule).
    pub fn tangent_of(&self, s: &Segment) -> Vec3 {
        let (a, b) = (s.a.as_dvec3() * self.scale, s.b.as_dvec3() * self.scale);
        Self::tangent(&Capsule { a, b, r: s.radius as f64 * self.scale })
    }

    fn tangent(c: &Capsule) -> Vec3 {
        (c.b - c.a).normalize().as_vec3()
    }

    /// Where the ray enters capsule `slot` (fiber units) before `t_max`, if that entry is on the
    /// fiber's surface (the costlier test, so only for entries that are near enough to matter):
    /// an entry inside a neighbouring capsule of the same strand (at the joint, where they
    /// overlap) crosses no surface; only a ray that is already inside the fiber makes one.
    fn enter(&self, o: DVec3, d: DVec3, slot: usize, t_max: f32) -> Option<f64> {
        let t = enter_capsule(o, d, &self.capsule(slot), Self::T_MIN).filter(|&t| (t as f32) < t_max)?;
        let p = o + t * d;
        let interior = self.neighbours[slot].iter().any(|&n| n != NONE && inside_capsule(p, &self.capsule(n as usize)));
        (!interior).then_some(t)
    }

    /// Minimum hit distance in fiber units (1e-6 radii): only rejects hits at the ray origin.
    const T_MIN: f64 = 1e-6;

    fn to_bvh_ray(&self, origin: Vec3, dir: Vec3, t_max: f32) -> (Ray, DVec3, DVec3) {
        let (o, d) = (origin.as_dvec3() * self.scale, dir.as_dvec3().normalize());
        let ray = Ray::new(Vec3A::from(o.as_vec3()), Vec3A::from(d.as_vec3()), 0.0, (t_max as f64 * self.scale) as f32);
        (ray, o, d)
    }

    /// The closest fiber hit along the ray within `t_max` (world units), if any.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        let (ray, o, d) = self.to_bvh_ray(origin, dir, t_max);
        let mut hit = RayHit::none();
        let mut best = f64::INFINITY;
        self.bvh.ray_traverse(ray, &mut hit, |r, id| match self.enter(o, d, id, r.tmax) {
            Some(t) => {
                best = t;
                t as f32
            }
            None => f32::INFINITY,
        });
        if hit.primitive_id == obvhs::ray::INVALID_ID {
            return None;
        }
        let c = &self.capsule(hit.primitive_id as usize);
        let p = o + best * d;
        let u = (c.b - c.a).normalize();
        let s = (p - c.a).dot(u).clamp(0.0, (c.b - c.a).length());
        let normal = (p - (c.a + s * u)).normalize();
        Some(Hit {
            t: (best / self.scale) as f32,
            point: (p / self.scale).as_vec3(),
            tangent: Self::tangent(c),
            normal: normal.as_vec3(),
            radius: (c.r / self.scale) as f32,
            segment: self.id(hit.primitive_id as usize),
        })
    }

    /// Whether any fiber blocks the ray before `t_max` (world units).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let (ray, o, d) = self.to_bvh_ray(origin, dir, t_max);
        !self.bvh.ray_traverse_miss(ray, |r, id| self.enter(o, d, id, r.tmax).map_or(f32::INFINITY, |t| t as f32))
    }

    /// The number of fibers the ray crosses before `t_max` (world units): Zinke et al. 2008's
    /// ray-shooting count (section 4.2). A strand crossed at the joint of two segments enters
    /// both capsules at nearly the same distance; such a pair counts once.
    pub fn crossings(&self, origin: Vec3, dir: Vec3, t_max: f32) -> u32 {
        let (ray, o, d) = self.to_bvh_ray(origin, dir, t_max);
        let mut hits: Vec<(f64, u32)> = Vec::new();
        self.bvh.ray_traverse_anyhit(ray, |r, id| {
            if let Some(t) = self.enter(o, d, id, r.tmax) {
                hits.push((t, self.id(id)));
            }
        });
        if hits.len() < 2 {
            return hits.len() as u32;
        }
        hits.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Distances are in fiber units (mean radius 1): the same crossing lies within a diameter
        // or so, a strand's next crossing (a curl) much farther.
        let same = |a: &(f64, u32), b: &(f64, u32)| a.1.abs_diff(b.1) == 1 && b.0 - a.0 < 4.0;
        let mut count = 1;
        for k in 1..hits.len() {
            if !hits[..k].iter().rev().take_while(|p| hits[k].0 - p.0 < 4.0).any(|p| same(p, &hits[k])) {
                count += 1;
            }
        }
        count
    }
}
