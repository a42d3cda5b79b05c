//! The global forward-transmittance lookup: for every fiber segment in view and light direction,
//! the fraction of the segment that sees the light directly (Zinke et al. 2008's directFraction)
//! and the number of fibers n in the way (the density grid's count, design section 4),
//! precomputed once per hair, camera and light setup so that a `dual` sample traces no shadow ray
//! and marches no grid. Zinke et al. 2008 (section 5) keep the same two quantities in
//! forward-scattering maps; here they are kept per segment, because a voxel-scale directFraction
//! (e^-n of a voxel lattice's n) was measured to darken the directly lit fibers by half: the
//! fibers a camera sees are the outermost of their voxel (README, "The forward-transmittance
//! lookup").
//!
//! Each entry is measured with the shadow rays and grid marches of `dual.shadows` "rays", from
//! points where camera rays hit the segment, placed as `dual` places its shading points (32 per
//! segment, spread along it and across it, on the parts the camera sees):
//!
//! - the sun: `sun_rays` rays over its disc per bin of the offset h across the fiber (4 bins);
//!   the lit fraction per bin and the mean n;
//! - the environment: one ray and one march per vertex of a map of directions in the segment's
//!   own fiber frame (design section 3: x along the tangent), `env_theta` x `env_phi` squares of
//!   inclination theta and azimuth phi; the lit bit and n per vertex.
//!   The map lives in the fiber frame because that is where visibility has its structure: a
//!   fiber's neighbours lie along it, so directions across the fiber (theta near 0, where f_s
//!   cos theta_i also peaks) are blocked far more often than directions along it; a world-space
//!   octahedral map of 8 x 8 squares measured twice the f_s-weighted visibility of the shadow rays.
//!   Interpolated bilinearly in (theta, phi) at render time.
//!
//! Units: n is dimensionless; directions are unit world vectors.

use crate::camera::Camera;
use crate::integrator::{Frame, hit_frame, spawn_point};
use crate::light::Lights;
use crate::world::World;
use anyhow::ensure;
use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};
use precompute::conventions::direction;
use precompute::density::DensityGrid;
use precompute::strands::{Segment, Strands};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde::Deserialize;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::io::Write;

/// Resolutions of the lookup (scene file `dual.lookup`), chosen by measured error against the
/// exact rays and marches (README, "The forward-transmittance lookup").
#[derive(serde::Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(default, deny_unknown_fields)]
pub struct LookupSettings {
    /// Shadow rays toward the sun per segment and bin of h across it.
    pub sun_rays: u32,
    /// Squares of the environment's map along the inclination theta (fiber frame).
    pub env_theta: u32,
    /// Squares of the environment's map around the azimuth phi (fiber frame).
    pub env_phi: u32,
}

impl Default for LookupSettings {
    fn default() -> Self {
        LookupSettings { sun_rays: 16, env_theta: 16, env_phi: 16 }
    }
}

impl LookupSettings {
    pub fn validate(&self) -> anyhow::Result<()> {
        ensure!((1..=4096).contains(&self.sun_rays), "dual.lookup.sun_rays must be in 1..=4096, got {}", self.sun_rays);
        for (name, v) in [("env_theta", self.env_theta), ("env_phi", self.env_phi)] {
            ensure!((2..=64).contains(&v), "dual.lookup.{name} must be in 2..=64, got {v}");
        }
        Ok(())
    }
}

/// A map of directions in a fiber frame: vertices at theta_j = -pi/2 + pi j / rows (j in 0..=rows)
/// and phi_i = 2 pi i / columns (i in 0..columns, periodic), stored row by row.
#[derive(Debug, Clone, Copy, PartialEq)]
struct AngleMap {
    rows: u32,
    columns: u32,
}

impl AngleMap {
    fn len(&self) -> usize {
        (self.rows as usize + 1) * self.columns as usize
    }

    /// Vertex k's direction (fiber frame).
    fn direction(&self, k: usize) -> DVec3 {
        let (j, i) = (k / self.columns as usize, k % self.columns as usize);
        direction(-FRAC_PI_2 + PI * j as f64 / self.rows as f64, TAU * i as f64 / self.columns as f64)
    }

    /// The four vertices around (theta, phi) with their bilinear weights.
    fn weights(&self, theta: f64, phi: f64) -> [(usize, f64); 4] {
        let rows = self.rows as f64;
        let y = ((theta + FRAC_PI_2) / PI * rows).clamp(0.0, rows);
        let j = (y.floor() as usize).min(self.rows as usize - 1);
        let fy = y - j as f64;
        let x = phi.rem_euclid(TAU) / TAU * self.columns as f64;
        let i = (x.floor() as usize).min(self.columns as usize - 1);
        let fx = (x - i as f64).clamp(0.0, 1.0);
        let c = self.columns as usize;
        let i1 = (i + 1) % c;
        [
            (j * c + i, (1.0 - fx) * (1.0 - fy)),
            (j * c + i1, fx * (1.0 - fy)),
            ((j + 1) * c + i, (1.0 - fx) * fy),
            ((j + 1) * c + i1, fx * fy),
        ]
    }
}

/// n on a log scale in a byte: q = round(32 log2(1 + n)), steps of 2.2% in 1 + n, up to n = 250
/// (beyond it no light passes: a_f^250 < 1e-11 for every a_f < 0.9, and the spread is saturated).
fn quantize(n: f64) -> u8 {
    (32.0 * (1.0 + n.max(0.0)).log2()).round().min(255.0) as u8
}

fn dequantize(q: f64) -> f64 {
    (q / 32.0).exp2() - 1.0
}

/// The count of a direction that a mesh blocks: n = 250, which `quantize` stores as its largest.
const OPAQUE: f64 = 250.0;

/// Entries toward the sun, per segment.
#[derive(Debug, PartialEq)]
struct SunLookup {
    direction: DVec3,
    /// Directions with a larger cosine to `direction` are the sun's (its disc).
    cos_disc: f64,
    /// Lit fraction per segment and h bin (`SUN_BINS`), mean n per segment.
    lit: Vec<f32>,
    count: Vec<f32>,
}

/// Entries toward the environment, per segment: a lit bit and a count per vertex of one map.
#[derive(Debug, PartialEq)]
struct EnvLookup {
    map: AngleMap,
    /// `words` 64-bit words of lit bits per segment, vertex k in bit k % 64 of word k / 64.
    words: usize,
    lit: Vec<u64>,
    /// `map.len()` quantized counts per segment.
    counts: Vec<u8>,
}

impl EnvLookup {
    fn new(settings: &LookupSettings) -> EnvLookup {
        let map = AngleMap { rows: settings.env_theta, columns: settings.env_phi };
        EnvLookup { map, words: map.len().div_ceil(64), lit: Vec::new(), counts: Vec::new() }
    }
}

/// Lit fraction and fibers crossed from each segment toward a scene's lights (module
/// documentation).
#[derive(Debug, PartialEq)]
pub struct ForwardLookup {
    /// Total segments of the hair.
    segments: usize,
    /// The segments with entries (those camera rays hit), ascending.
    seen: Vec<u32>,
    /// Each segment's row of entries, `u32::MAX` for none.
    rows: Vec<u32>,
    sun: Option<SunLookup>,
    env: Option<EnvLookup>,
}

/// The segments camera rays hit: k x k rays per pixel on a regular grid, spaced half a fiber
/// width apart at the hair's center (k in 4..=32), so that few segments in view are missed. A
/// sample's camera ray that hits one of those few anyway gets shadow rays from `dual`.
fn seen_segments(strands: &Strands, world: World, camera: &Camera) -> Vec<u32> {
    let (lo, hi) = strands.bounds();
    let distance = (0.5 * (lo + hi)).as_dvec3().distance(camera.position());
    let width = 2.0 * strands.radii.iter().map(|&r| r as f64).sum::<f64>() / strands.radii.len().max(1) as f64;
    let k = (2.0 * camera.pixel_width(distance) / width).ceil().clamp(4.0, 32.0) as usize;
    let hit: Vec<u32> = (0..camera.height * k)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..camera.width * k).filter_map(move |x| {
                let (o, d) = camera.ray((x as f64 + 0.5) / k as f64, (y as f64 + 0.5) / k as f64);
                world.closest_fiber(o, d.as_vec3()).map(|h| h.segment)
            })
        })
        .collect();
    let mut seen = vec![false; strands.segment_count()];
    hit.into_iter().for_each(|i| seen[i as usize] = true);
    (0..seen.len() as u32).filter(|&i| seen[i as usize]).collect()
}

/// A point on the half of segment `s` that faces `viewer`: at parameter t along the axis, at
/// offset `across` in [-1, 1] (camera rays hit uniformly in it), `radii` radii from the axis.
fn facing_point(s: &Segment, tangent: DVec3, viewer: DVec3, t: f64, across: f64, radii: f64) -> DVec3 {
    let axis = s.a.as_dvec3().lerp(s.b.as_dvec3(), t);
    let v = viewer - axis;
    let toward = (v - v.dot(tangent) * tangent).normalize_or_zero();
    let side = tangent.cross(toward);
    axis + (radii * s.radius as f64) * ((1.0 - across * across).max(0.0).sqrt() * toward + across * side)
}

/// Tries per shading point at finding a part of the segment the camera sees.
const VISIBLE_TRIES: usize = 16;

/// Shading points per segment that its entries are measured from.
const SHADING_POINTS: usize = 32;

/// Equal bins of the offset h in [-1, 1] across the fiber with a sun lit fraction of their own:
/// where across the fiber a point is decides which neighbours block the sun from it, and f_s at
/// that h weighs exactly that point (one lit fraction per segment measured 1.2-1.3% darker than
/// shadow rays under the front sun on brown and black hair, 0.2-0.8% with four bins, README).
/// The environment's map keeps one bin: four measured no closer to the rays under the HDRIs
/// (-1.5, -1.6, -1.0% on blond, brown, black against -1.6, -0.3, -1.5%) for 2.5 times the build.
const SUN_BINS: usize = 4;

/// The bin of the offset `h` among `SUN_BINS`.
fn sun_bin(h: f64) -> usize {
    (((h + 1.0) * 0.5 * SUN_BINS as f64).max(0.0) as usize).min(SUN_BINS - 1)
}

/// `SHADING_POINTS` points where camera rays hit segment `i` (`s`), placed as `dual` places its
/// shading points there (`spawn_point`), each with its offset h (`hit_frame`): stratified along
/// the segment, uniform across it, and drawn only from the parts the camera sees (a camera ray
/// toward the point must hit this segment first). Parts hidden behind other fibers are also more shadowed toward the lights:
/// measured from every part of the segment, the lit fraction came out 2-5% low under the
/// bundled HDRIs (README). Once a point's tries all fail, the segment is barely in view (seen
/// through a gap too narrow to find again, so camera rays seldom read its entries): its other
/// points are taken on the facing half without trying.
fn shading_points(
    world: World,
    s: &Segment,
    i: u32,
    tangent: DVec3,
    viewer: DVec3,
    rng: &mut Pcg64Mcg,
) -> Vec<(DVec3, f64)> {
    let mut tries = VISIBLE_TRIES;
    (0..SHADING_POINTS)
        .map(|k| {
            let mut draw =
                || ((k as f64 + rng.random::<f64>()) / SHADING_POINTS as f64, 2.0 * rng.random::<f64>() - 1.0);
            for _ in 0..tries {
                let (t, across) = draw();
                let d = (facing_point(s, tangent, viewer, t, across, 0.98) - viewer).normalize();
                if let Some(hit) = world.closest_fiber(viewer.as_vec3(), d.as_vec3())
                    && hit.segment == i
                {
                    return (spawn_point(&hit).as_dvec3(), hit_frame(&hit, d).2);
                }
            }
            tries = 0;
            // `facing_point`'s offset across is -h of `hit_frame` (its side is t x v).
            let (t, across) = draw();
            (facing_point(s, tangent, viewer, t, across, 0.99), -across)
        })
        .collect()
}

impl ForwardLookup {
    /// Changes whenever `build` measures differently, so that caches of an older build are not
    /// reused (part of the cache key).
    pub const VERSION: u32 = 3;

    /// Precomputes the lookup for the lights of a scene; `progress` shows a bar. Deterministic:
    /// each segment draws from its own random stream.
    pub fn build(
        strands: &Strands,
        world: World,
        camera: &Camera,
        grid: &DensityGrid,
        lights: &Lights,
        settings: &LookupSettings,
        progress: bool,
    ) -> ForwardLookup {
        let seen = seen_segments(strands, world, camera);
        // Only the segments in view, picked from the strands in one pass (`seen` is ascending).
        let mut wanted = seen.iter().copied().peekable();
        let segments: Vec<_> = strands
            .segments()
            .enumerate()
            .filter(|&(i, _)| wanted.next_if_eq(&(i as u32)).is_some())
            .map(|(_, s)| s)
            .collect();
        let viewer = camera.position();
        let env = lights.environment.as_ref().map(|_| EnvLookup::new(settings));
        let bar = if progress { ProgressBar::new(segments.len() as u64) } else { ProgressBar::hidden() };
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} forward-transmittance lookup [{bar:40}] {pos}/{len} segments, ETA {eta}",
            )
            .expect("static progress template")
            .progress_chars("=> "),
        );
        let escapes = |p: DVec3, d: DVec3| !world.occluded(p.as_vec3(), d.as_vec3(), f32::INFINITY);
        // A mesh in the way (the head) is opaque: it counts as the most fibers a count holds,
        // through which no light passes (`quantize`).
        let march = |p: DVec3, d: DVec3| match world.meshes.occluded(p.as_vec3(), d.as_vec3(), f32::INFINITY) {
            true => OPAQUE,
            false => grid.fibers_crossed(p, d, f64::INFINITY),
        };
        // Per segment: the sun's lit fraction per h bin and n, the environment's lit words and
        // counts.
        type Row = ((Vec<f32>, f32), Vec<u64>, Vec<u8>);
        let rows: Vec<Row> = segments
            .par_iter()
            .enumerate()
            .map(|(row, s)| {
                let i = seen[row] as usize;
                let mut rng = Pcg64Mcg::seed_from_u64(0x5eed_0000 ^ i as u64);
                let tangent = world.fibers.tangent_of(s).as_dvec3();
                let points = shading_points(world, s, i as u32, tangent, viewer, &mut rng);
                // Sample k takes a point by a stride coprime to their count, to spread them.
                let point = |k: usize| points[(k * 7919) % SHADING_POINTS].0;
                let sun = lights.sun.as_ref().map_or((Vec::new(), 0.0), |sun| {
                    let mut count = 0.0;
                    let lit = (0..SUN_BINS)
                        .map(|bin| {
                            // A bin without points (hidden from the camera) takes them all.
                            let mut own: Vec<DVec3> =
                                points.iter().filter(|p| sun_bin(p.1) == bin).map(|p| p.0).collect();
                            if own.is_empty() {
                                own = points.iter().map(|p| p.0).collect();
                            }
                            let k = settings.sun_rays as usize;
                            let mut lit = 0.0;
                            for r in 0..k {
                                let p = own[(r * 7919) % own.len()];
                                let d = sun.sample(rng.random()).wi;
                                lit += escapes(p, d) as u8 as f64;
                                count += march(p, d);
                            }
                            (lit / k as f64) as f32
                        })
                        .collect();
                    (lit, (count / (settings.sun_rays as usize * SUN_BINS) as f64) as f32)
                });
                let (mut words, mut counts) = (Vec::new(), Vec::new());
                if let Some(env) = &env {
                    let frame = Frame::new(world.fibers.tangent_of(s));
                    words = vec![0u64; env.words];
                    counts = (0..env.map.len())
                        .map(|k| {
                            let (p, d) = (point(k), frame.to_world(env.map.direction(k)));
                            if escapes(p, d) {
                                words[k / 64] |= 1 << (k % 64);
                            }
                            quantize(march(p, d))
                        })
                        .collect();
                }
                bar.inc(1);
                (sun, words, counts)
            })
            .collect();
        bar.finish_and_clear();
        let sun = lights.sun.as_ref().map(|sun| SunLookup {
            direction: sun.direction,
            cos_disc: sun.half_angle.cos().min(1.0 - 1e-12),
            lit: rows.iter().flat_map(|r| r.0.0.iter().copied()).collect(),
            count: rows.iter().map(|r| r.0.1).collect(),
        });
        let env = env.map(|e| EnvLookup {
            lit: rows.iter().flat_map(|r| r.1.iter().copied()).collect(),
            counts: rows.iter().flat_map(|r| r.2.iter().copied()).collect(),
            ..e
        });
        ForwardLookup::new(strands.segment_count(), seen, sun, env)
    }

    fn new(segments: usize, seen: Vec<u32>, sun: Option<SunLookup>, env: Option<EnvLookup>) -> ForwardLookup {
        let mut rows = vec![u32::MAX; segments];
        for (row, &i) in seen.iter().enumerate() {
            rows[i as usize] = row as u32;
        }
        ForwardLookup { segments, seen, rows, sun, env }
    }

    /// (lit fraction, fibers crossed) from segment `segment`, at offset `h` across it, toward the
    /// unit direction `d` (world), which has inclination `theta` and azimuth `phi` in the hit's
    /// fiber frame: the sun's entry for directions in its disc, the environment's for any other;
    /// `None` where there is no entry (a segment no camera ray hit while the lookup was built, or
    /// a direction no light shines from).
    pub fn toward(&self, segment: u32, h: f64, d: DVec3, theta: f64, phi: f64) -> Option<(f64, f64)> {
        let i = *self.rows.get(segment as usize)?;
        if i == u32::MAX {
            return None;
        }
        let i = i as usize;
        if let Some(sun) = &self.sun
            && d.dot(sun.direction) >= sun.cos_disc
        {
            return Some((sun.lit[i * SUN_BINS + sun_bin(h)] as f64, sun.count[i] as f64));
        }
        let env = self.env.as_ref()?;
        let (words, counts) = (&env.lit[i * env.words..], &env.counts[i * env.map.len()..]);
        let (mut lit, mut q) = (0.0, 0.0);
        for (k, w) in env.map.weights(theta, phi) {
            lit += w * ((words[k / 64] >> (k % 64)) & 1) as f64;
            // Interpolated on the stored log scale: a convex T(n) of a linear blend of counts
            // would darken the light that passes between a thin and a thick direction.
            q += w * counts[k] as f64;
        }
        let n = dequantize(q);
        Some((lit, n))
    }

    /// Memory it takes, in bytes.
    pub fn bytes(&self) -> usize {
        4 * (self.rows.len() + self.seen.len())
            + self.sun.as_ref().map_or(0, |s| 4 * (s.lit.len() + s.count.len()))
            + self.env.as_ref().map_or(0, |e| 8 * e.lit.len() + e.counts.len())
    }

    /// Segments with entries, and all segments.
    pub fn coverage(&self) -> (usize, usize) {
        (self.seen.len(), self.segments)
    }

    /// Writes the lookup in its cache format, every number little-endian: "DHFWDLUT", the segment
    /// count (u64), the count of segments with entries (u64) and their indices (u32, ascending);
    /// then, for the segments with entries in that order: a byte 1, the sun's direction and disc
    /// cosine (4 x f64), its lit fractions (f32 per segment and h bin, `SUN_BINS` bins) and
    /// counts (f32 per segment), or a byte 0; a byte 1, the lit map's theta and
    /// phi squares (2 x u32), then the lit words (u64) and quantized counts (u8) of every
    /// segment, or a byte 0.
    pub fn write(&self, w: &mut impl Write) -> std::io::Result<()> {
        w.write_all(MAGIC)?;
        w.write_all(&(self.segments as u64).to_le_bytes())?;
        w.write_all(&(self.seen.len() as u64).to_le_bytes())?;
        w.write_all(&self.seen.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
        match &self.sun {
            Some(s) => {
                w.write_all(&[1])?;
                for v in [s.direction.x, s.direction.y, s.direction.z, s.cos_disc] {
                    w.write_all(&v.to_le_bytes())?;
                }
                let floats = s.lit.iter().chain(&s.count);
                w.write_all(&floats.flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
            }
            None => w.write_all(&[0])?,
        }
        match &self.env {
            Some(e) => {
                w.write_all(&[1])?;
                w.write_all(&e.map.rows.to_le_bytes())?;
                w.write_all(&e.map.columns.to_le_bytes())?;
                w.write_all(&e.lit.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
                w.write_all(&e.counts)?;
            }
            None => w.write_all(&[0])?,
        }
        Ok(())
    }

    /// Reads what [`ForwardLookup::write`] wrote for `segments` segments; `None` if the bytes are
    /// not such a lookup (sizes are checked against the bytes before anything is allocated).
    pub fn read(bytes: &[u8], segments: usize) -> Option<ForwardLookup> {
        let mut r = bytes.strip_prefix(MAGIC)?;
        if u64::from_le_bytes(take(&mut r)?) != segments as u64 {
            return None;
        }
        let count = usize::try_from(u64::from_le_bytes(take(&mut r)?)).ok()?;
        let seen = chunks(&mut r, count, u32::from_le_bytes)?;
        if seen.windows(2).any(|w| w[0] >= w[1]) || seen.last().is_some_and(|&i| i as usize >= segments) {
            return None;
        }
        let segments_total = segments;
        let segments = seen.len();
        let sun = match take::<1>(&mut r)?[0] {
            0 => None,
            1 => {
                let mut f = || Some(f64::from_le_bytes(take(&mut r)?));
                let (x, y, z, cos_disc) = (f()?, f()?, f()?, f()?);
                let lit = chunks(&mut r, segments.checked_mul(SUN_BINS)?, f32::from_le_bytes)?;
                let count = chunks(&mut r, segments, f32::from_le_bytes)?;
                Some(SunLookup { direction: DVec3::new(x, y, z), cos_disc, lit, count })
            }
            _ => return None,
        };
        let env = match take::<1>(&mut r)?[0] {
            0 => None,
            1 => {
                let env_theta = u32::from_le_bytes(take(&mut r)?);
                let env_phi = u32::from_le_bytes(take(&mut r)?);
                let settings = LookupSettings { env_theta, env_phi, ..LookupSettings::default() };
                settings.validate().ok()?;
                let env = EnvLookup::new(&settings);
                let lit = chunks(&mut r, segments.checked_mul(env.words)?, u64::from_le_bytes)?;
                let counts = chunks(&mut r, segments.checked_mul(env.map.len())?, u8::from_le_bytes)?;
                Some(EnvLookup { lit, counts, ..env })
            }
            _ => return None,
        };
        r.is_empty().then(|| ForwardLookup::new(segments_total, seen, sun, env))
    }
}

const MAGIC: &[u8] = b"DHFWDLUT";

fn take<const N: usize>(r: &mut &[u8]) -> Option<[u8; N]> {
    let (head, rest) = r.split_first_chunk::<N>()?;
    *r = rest;
    Some(*head)
}

/// `count` numbers of N bytes each, if there are that many bytes.
fn chunks<T, const N: usize>(r: &mut &[u8], count: usize, from: fn([u8; N]) -> T) -> Option<Vec<T>> {
    let len = count.checked_mul(N)?;
    let bytes = r.get(..len)?;
    *r = &r[len..];
    Some(bytes.chunks_exact(N).map(|b| from(b.try_into().expect("N bytes"))).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use precompute::conventions::{phi, theta};

    #[test]
    fn angle_map_interpolates_its_vertices_and_weights_sum_to_one() {
        let map = AngleMap { rows: 6, columns: 8 };
        for k in 0..map.len() {
            let d = map.direction(k);
            let w = map.weights(theta(d), phi(d));
            assert!((w.iter().map(|x| x.1).sum::<f64>() - 1.0).abs() < 1e-12);
            // The vertex itself, or one of the same direction (a pole), gets all the weight.
            let at: DVec3 = w.iter().map(|&(v, wv)| map.direction(v) * wv).sum();
            assert!((at - d).length() < 1e-9, "vertex {k}: {d} vs {at}");
        }
        // Across phi = 2 pi the last column blends into the first.
        let w = map.weights(0.1, TAU - 0.01);
        let first: f64 = w.iter().filter(|(k, _)| k % 8 == 0).map(|(_, x)| x).sum();
        assert!(first > 0.98, "{w:?}");
    }

    #[test]
    fn cache_format_round_trips_and_rejects_damaged_bytes() {
        let settings = LookupSettings { env_theta: 2, env_phi: 3, ..LookupSettings::default() };
        let env = EnvLookup::new(&settings);
        let env = EnvLookup {
            lit: (0..2 * env.words as u64).map(|k| k * 0x9e37_79b9_7f4a_7c15).collect(),
            counts: (0..2 * env.map.len()).map(|k| k as u8).collect(),
            ..env
        };
        let lit = (0..2 * SUN_BINS).map(|k| k as f32 / 8.0).collect();
        let sun = SunLookup { direction: DVec3::Z, cos_disc: 0.99, lit, count: vec![3.0, 0.0] };
        let lookup = ForwardLookup::new(5, vec![1, 4], Some(sun), Some(env));
        let mut bytes = Vec::new();
        lookup.write(&mut bytes).unwrap();
        assert_eq!(ForwardLookup::read(&bytes, 5), Some(lookup));
        // Every truncation, another hair's segment count, and indices out of order or range.
        for len in 0..bytes.len() {
            assert_eq!(ForwardLookup::read(&bytes[..len], 5), None, "truncated to {len}");
        }
        assert_eq!(ForwardLookup::read(&bytes, 6), None);
        let mut swapped = bytes.clone();
        swapped[24..28].copy_from_slice(&9u32.to_le_bytes());
        assert_eq!(ForwardLookup::read(&swapped, 5), None);
        // A header claiming more entries than there are bytes allocates nothing.
        let mut huge = bytes.clone();
        huge[16..24].copy_from_slice(&u64::MAX.to_le_bytes());
        assert_eq!(ForwardLookup::read(&huge, 5), None);
    }

    #[test]
    fn quantized_counts_keep_n_within_their_step() {
        for n in [0.0, 1e-3, 0.5, 1.0, 7.3, 120.0, 249.0] {
            let m = dequantize(quantize(n) as f64);
            assert!((m - n).abs() <= 0.012 * (1.0 + n), "{n} -> {m}");
        }
        assert_eq!(quantize(1e9), 255);
    }
}
