//! The global forward-transmittance lookup: deep opacity maps of the hair, one per light
//! direction, giving at any point the fraction of light that reaches it directly (Zinke et al.
//! 2008's directFraction) and the mean number n of fibers in the way. It depends on the hair and
//! the light directions only, never on the camera: a camera move reuses it, a sun move rebuilds
//! the sun's map alone.
//!
//! A map looks along a light direction (orthographic, texels of a fixed size in the plane across
//! it). Each texel keeps the depth of the first fiber met there and of the last, and the
//! cumulative count of fibers crossed at knots behind the first (0.5, 0.71, 1, ..., 8, 16, 32, 64
//! fiber widths) and before the last (0.5, 1, 2 widths; Yuksel and Keyser 2008, "Deep opacity maps":
//! layers from each texel's first hit, so the outermost fibers, the ones a camera sees lit, are
//! resolved; here the innermost too, which a back light's camera sees; Kim and Neumann 2001
//! accumulate such counts in fixed slices). A fiber of radius r crossing a texel of side s along
//! a length l (projected across the light) adds 2 r l / s^2 to the expected count of a ray
//! through the texel: the density grid's count (Lemein 2020 section 5.2) at the scale of one texel.
//! Between knots the count is linear in depth, across texels bilinear.
//!
//! With fibers placed at random across a texel the count N along a ray is Poisson, so the lit
//! fraction is P(N = 0) = e^-n, and `dual`'s Poisson transmittance (given N >= 1) takes the same
//! n: the lookup gives the expectation of what a shadow ray and a grid march give, per point.
//!
//! - The sun: one map toward the centre of its disc, texels of `sun_texel` fiber widths.
//! - The environment: one map per vertex of an octahedral grid of directions (Engelhardt and
//!   Dachsbacher 2008's octahedron map, `env_grid` squares a side), texels of `env_texel` fiber
//!   widths; a direction reads the four maps around it, weighted bilinearly in the octahedral
//!   square, lit fractions and counts each.
//!
//! Meshes are not in the maps: `dual` traces its (cheap) shadow rays against them exactly.
//! Units: depths and texels in world units; n is dimensionless.

use crate::error::ensure;
use crate::lights::Lights;
use crate::progress::Progress;
use glam::{DVec2, DVec3};
use precompute::strands::Strands;
use rayon::prelude::*;
use serde::Deserialize;
use std::f64::consts::{FRAC_1_SQRT_2, SQRT_2};
use std::io::Write;

/// Resolutions of the lookup (scene file `dual.lookup`), chosen by measured error against
/// shadow rays and grid marches (docs/dual_scattering.md, "The forward-transmittance lookup").
#[derive(serde::Serialize, Deserialize, Debug, Clone, Copy, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct LookupSettings {
    /// Texel side of the sun's map, in fiber widths (twice the mean radius).
    pub sun_texel: f64,
    /// Texel side of each environment map, in fiber widths.
    pub env_texel: f64,
    /// Squares per side of the octahedral grid of environment directions: (n + 1)^2 vertices,
    /// (n - 1)^2 + 1 + 4 ceil((n - 1) / 2) distinct ones (the border folds onto itself).
    pub env_grid: u32,
}

impl Default for LookupSettings {
    fn default() -> Self {
        LookupSettings { sun_texel: 2.0, env_texel: 3.0, env_grid: 7 }
    }
}

impl LookupSettings {
    pub fn validate(&self) -> crate::error::Result<()> {
        for (name, v) in [("sun_texel", self.sun_texel), ("env_texel", self.env_texel)] {
            ensure!(
                v.is_finite() && (0.25..=1024.0).contains(&v),
                "dual.lookup.{name} must be in 0.25..=1024 fiber widths, got {v}"
            );
        }
        ensure!((2..=32).contains(&self.env_grid), "dual.lookup.env_grid must be in 2..=32, got {}", self.env_grid);
        Ok(())
    }
}

/// Knots of a texel's count, in fiber widths behind its first fiber, with S its last fiber's
/// depth there: `FRONT_KNOTS` from the first fiber (a ratio of sqrt 2 up to 8 widths, then 2),
/// where a front light's camera looks and where the outermost fibers decide what is lit;
/// `BACK_KNOTS` before the last, S - 0.5, S - 1, S - 2, where a back light's camera looks; and S
/// itself. Between knots the count is linear in depth. Knots at both ends keep both outer layers
/// resolved however much hair or empty space (a head's hollow) lies between.
const FRONT_KNOTS: [f64; 12] =
    [0.5, FRAC_1_SQRT_2, 1.0, SQRT_2, 2.0, 2.0 * SQRT_2, 4.0, 4.0 * SQRT_2, 8.0, 16.0, 32.0, 64.0];
const BACK_KNOTS: [f64; 3] = [0.5, 1.0, 2.0];
const FRONT: usize = FRONT_KNOTS.len();
const BACK: usize = BACK_KNOTS.len();
const KNOTS: usize = FRONT + BACK + 1;

/// The front knots at or beyond offset `o`: those from the first with a depth above `o`.
fn front_from(o: f64) -> usize {
    FRONT_KNOTS.iter().position(|&k| k > o).unwrap_or(FRONT)
}

/// The back knots beyond offset o, d = S - o before the last fiber: those with S - k > o, which
/// is k < d.
fn back_before(d: f64) -> usize {
    BACK_KNOTS.iter().position(|&k| k >= d).unwrap_or(BACK)
}

/// Texels per side of a tile: only tiles that hair touches are stored.
const TILE: usize = 4;

/// The most texels a map may span (before tiles drop the empty ones): a coarser texel is taken
/// beyond, so that a map of a sprawling groom stays within memory (16 bytes a texel kept, about
/// 64 while its map is built, on each thread: 256 MB here at most).
const MAX_TEXELS: f64 = 4e6;

/// The cumulative count on a log scale in a byte: q = round(24 log2(1 + n)), steps of 2.9% in
/// 1 + n (rounding keeps n within half of one), up to n = 1600; read back through a table.
fn quantize(n: f64) -> u8 {
    (24.0 * n.max(0.0).ln_1p() / std::f64::consts::LN_2).round().min(255.0) as u8
}

fn dequantize(q: u8) -> f64 {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|q| ((q as f64 / 24.0).exp2() - 1.0) as f32))[q as usize] as f64
}

/// The hair seen from one light direction.
#[derive(Debug, PartialEq)]
struct DepthMap {
    /// Unit direction toward the light.
    direction: DVec3,
    /// Axes across it (`any_orthonormal_pair`), and the corner of texel (0, 0) on them.
    across: [DVec3; 2],
    corner: DVec2,
    /// Texel side and fiber width, world units.
    texel: f64,
    fiber_width: f64,
    /// Texels per side.
    size: [usize; 2],
    /// Per tile (row by row), its slot among the stored tiles or `u32::MAX` for none.
    tiles: Vec<u32>,
    /// Per stored tile: the least first depth of its texels (world units).
    bases: Vec<f32>,
    /// Per stored texel (`TILE`^2 per tile, row by row in it): its first fiber's depth behind
    /// its tile's base in steps of `FIRST_STEP` fiber widths (`u16::MAX` where none), how far
    /// behind that its last fiber lies (`span_widths`) and the quantized cumulative count at each
    /// knot ([`FRONT`] ones, then [`BACK`] ones, then the last fiber).
    first: Vec<u16>,
    span: Vec<u8>,
    counts: Vec<[u8; KNOTS]>,
}

/// The step of a texel's first depth, in fiber widths.
const FIRST_STEP: f64 = 1.0 / 16.0;

/// A texel's span in a byte, rounded up on a log scale: 2^(q / 16) - 1 fiber widths, steps of
/// 4.4% in 1 + span, up to 63,000 widths.
fn span_byte(widths: f64) -> u8 {
    (16.0 * widths.max(0.0).ln_1p() / std::f64::consts::LN_2).ceil().min(255.0) as u8
}

fn span_widths(q: u8) -> f64 {
    (q as f64 / 16.0).exp2() - 1.0
}

/// What a segment leaves along its way in a map: its points, one a texel across the light, in
/// texel coordinates, with their depth (world units), the count they add and the fiber's radius
/// in texels.
struct Splat {
    x: f32,
    y: f32,
    depth: f32,
    count: f32,
    half: f32,
}

impl DepthMap {
    /// The frame of a map toward `direction`, its texel and fiber width: an empty map.
    fn frame(direction: DVec3, texel: f64, fiber_width: f64) -> DepthMap {
        let across = direction.any_orthonormal_pair();
        DepthMap {
            direction,
            across: [across.0, across.1],
            corner: DVec2::ZERO,
            texel,
            fiber_width,
            size: [0, 0],
            tiles: Vec::new(),
            bases: Vec::new(),
            first: Vec::new(),
            span: Vec::new(),
            counts: Vec::new(),
        }
    }

    /// Position across the light (world units) and depth along its travel.
    fn project(&self, p: DVec3) -> (DVec2, f64) {
        (DVec2::new(p.dot(self.across[0]), p.dot(self.across[1])), -p.dot(self.direction))
    }

    /// Calls `each` for every splat of every segment; `points` are the strands' points in
    /// texel coordinates and depth (`DepthMap::texel_space`).
    fn splats(&self, strands: &Strands, points: &[[f32; 3]], mut each: impl FnMut(Splat)) {
        let inverse = (1.0 / self.texel) as f32;
        for strand in 0..strands.strand_count() {
            let (start, end) = (strands.offsets[strand] as usize, strands.offsets[strand + 1] as usize);
            for i in start..end - 1 {
                let ([xa, ya, za], [xb, yb, zb]) = (points[i], points[i + 1]);
                let across = ((xb - xa) * (xb - xa) + (yb - ya) * (yb - ya)).sqrt();
                let steps = across.ceil().max(1.0);
                // The segment's radius: the mean of its ends' (`Strands::segments`).
                let r = 0.5 * (strands.radii[i] + strands.radii[i + 1]) * inverse;
                // Projected area 2 r l of the piece over the texel's area (both in texels): the
                // expected count.
                let count = 2.0 * r * across / steps;
                for k in 0..steps as usize {
                    let t = (k as f32 + 0.5) / steps;
                    let (x, y, depth) = (xa + (xb - xa) * t, ya + (yb - ya) * t, za + (zb - za) * t);
                    each(Splat { x, y, depth, count, half: r.min(0.5) });
                }
            }
        }
    }

    /// The strands' points in texel coordinates (x, y) and depth (world units).
    fn texel_space(&self, strands: &Strands) -> Vec<[f32; 3]> {
        strands
            .points
            .iter()
            .map(|p| {
                let (uv, depth) = self.project(p.as_dvec3());
                let x = (uv - self.corner) / self.texel;
                [x.x as f32, x.y as f32, depth as f32]
            })
            .collect()
    }

    /// The four texels around `uv` (world units across the light) with bilinear weights, as
    /// their stored slots (`None` outside the map or its stored tiles).
    fn around(&self, uv: DVec2) -> [(Option<usize>, f64); 4] {
        let x = (uv - self.corner) / self.texel - 0.5;
        let (i, j) = (x.x.floor(), x.y.floor());
        let (fx, fy) = (x.x - i, x.y - j);
        let at = |di: f64, dj: f64| {
            let (ii, jj) = (i + di, j + dj);
            (ii >= 0.0 && jj >= 0.0 && (ii as usize) < self.size[0] && (jj as usize) < self.size[1])
                .then(|| self.slot(ii as usize, jj as usize))
                .flatten()
        };
        [
            (at(0.0, 0.0), (1.0 - fx) * (1.0 - fy)),
            (at(1.0, 0.0), fx * (1.0 - fy)),
            (at(0.0, 1.0), (1.0 - fx) * fy),
            (at(1.0, 1.0), fx * fy),
        ]
    }

    /// The texels that a square of half side `s.half` (at most half a texel) centred on a splat
    /// overlaps, at most four, with the share of the square in each. The map's margin of a texel
    /// keeps them all inside it.
    fn footprint(&self, s: &Splat) -> [(usize, f32); 4] {
        // Per axis: the texel of the low edge, and the share of the square beyond its end.
        let axis = |c: f32| {
            let (lo, hi) = (c - s.half, c + s.half);
            let i = lo.floor();
            (i as usize, ((hi - (i + 1.0)) / (hi - lo)).clamp(0.0, 1.0))
        };
        let ((i, fx), (j, fy)) = (axis(s.x), axis(s.y));
        let t = j * self.size[0] + i;
        let w = self.size[0];
        [(t, (1.0 - fx) * (1.0 - fy)), (t + 1, fx * (1.0 - fy)), (t + w, (1.0 - fx) * fy), (t + w + 1, fx * fy)]
    }

    /// The stored slot of texel (x, y), if its tile is stored.
    fn slot(&self, x: usize, y: usize) -> Option<usize> {
        let tile = self.tiles[(y / TILE) * self.size[0].div_ceil(TILE) + x / TILE];
        (tile != u32::MAX).then(|| tile as usize * TILE * TILE + (y % TILE) * TILE + x % TILE)
    }

    /// Builds the map of `strands` toward `direction` (unit, toward the light) with texels of
    /// `texel` world units (coarser if the map would exceed [`MAX_TEXELS`]).
    fn build(strands: &Strands, direction: DVec3, texel: f64, fiber_width: f64) -> DepthMap {
        let mut map = DepthMap::frame(direction, texel, fiber_width);
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in &strands.points {
            let uv = map.project(p.as_dvec3()).0;
            (lo, hi) = (lo.min(uv), hi.max(uv));
        }
        if lo.x > hi.x {
            return map;
        }
        let extent = hi - lo;
        let texels = (extent.x / texel + 3.0) * (extent.y / texel + 3.0);
        if texels > MAX_TEXELS {
            map.texel *= (texels / MAX_TEXELS).sqrt();
        }
        map.corner = lo - map.texel;
        map.size = [(extent.x / map.texel) as usize + 3, (extent.y / map.texel) as usize + 3];
        // Pass 1: each texel's first and last fiber: the least and greatest depth of the splats
        // whose footprint (a square of the fiber's width) overlaps it.
        let texels = map.size[0] * map.size[1];
        let points = map.texel_space(strands);
        let mut first = vec![f32::INFINITY; texels];
        let mut last = vec![f32::NEG_INFINITY; texels];
        map.splats(strands, &points, |s| {
            for (t, w) in map.footprint(&s) {
                if w > 0.0 {
                    first[t] = first[t].min(s.depth);
                    last[t] = last[t].max(s.depth);
                }
            }
        });
        // The tiles hair touches, and the least first depth of each.
        let tiles_x = map.size[0].div_ceil(TILE);
        let mut tiles = vec![u32::MAX; tiles_x * map.size[1].div_ceil(TILE)];
        let mut stored = 0;
        for (t, z) in first.iter().enumerate() {
            let tile = &mut tiles[(t / map.size[0] / TILE) * tiles_x + (t % map.size[0]) / TILE];
            if z.is_finite() && *tile == u32::MAX {
                *tile = stored;
                stored += 1;
            }
        }
        map.tiles = tiles;
        let texels_stored = stored as usize * TILE * TILE;
        map.bases = vec![f32::INFINITY; stored as usize];
        for (t, &z) in first.iter().enumerate() {
            if let Some(slot) = map.slot(t % map.size[0], t / map.size[0]) {
                map.bases[slot / (TILE * TILE)] = map.bases[slot / (TILE * TILE)].min(z);
            }
        }
        // Each texel's first depth as stored, rounded down (its own fibers stay behind it), and
        // its span as stored, rounded up: what the knots are placed by, here as in `count_at`.
        (map.first, map.span) = (vec![u16::MAX; texels_stored], vec![0; texels_stored]);
        let mut spans = last;
        for (t, (z, span)) in first.iter_mut().zip(spans.iter_mut()).enumerate() {
            if let Some(slot) = map.slot(t % map.size[0], t / map.size[0])
                && z.is_finite()
            {
                let base = map.bases[slot / (TILE * TILE)];
                map.first[slot] = ((*z - base) as f64 / fiber_width / FIRST_STEP).floor().min(65534.0) as u16;
                *z = (base as f64 + map.first[slot] as f64 * FIRST_STEP * fiber_width) as f32;
                map.span[slot] = span_byte((*span - *z) as f64 / fiber_width);
                *span = span_widths(map.span[slot]) as f32;
            }
        }
        // Pass 2: each splat's count, shared by overlap, at the first front knot beyond it and at
        // the last back knot beyond it (the knots' cumulative counts are then sums from the front
        // and from the back), and in all at the last fiber.
        let mut knots = vec![[0f32; KNOTS]; texels];
        let per_width = (1.0 / fiber_width) as f32;
        map.splats(strands, &points, |s| {
            for (t, w) in map.footprint(&s) {
                if w > 0.0 {
                    let c = w * s.count;
                    let o = ((s.depth - first[t]) * per_width).max(0.0) as f64;
                    let k = &mut knots[t];
                    let front = front_from(o);
                    if front < FRONT {
                        k[front] += c;
                    }
                    let back = back_before(spans[t] as f64 - o);
                    if back > 0 {
                        k[FRONT + back - 1] += c;
                    }
                    k[KNOTS - 1] += c;
                }
            }
        });
        drop(spans);
        map.counts = vec![[0; KNOTS]; texels_stored];
        for (t, k) in knots.iter().enumerate() {
            if let Some(slot) = map.slot(t % map.size[0], t / map.size[0])
                && first[t].is_finite()
            {
                let counts = &mut map.counts[slot];
                let mut sum = 0.0;
                for i in 0..FRONT {
                    sum += k[i] as f64;
                    counts[i] = quantize(sum);
                }
                sum = 0.0;
                for i in (0..BACK).rev() {
                    sum += k[FRONT + i] as f64;
                    counts[FRONT + i] = quantize(sum);
                }
                counts[KNOTS - 1] = quantize(k[KNOTS - 1] as f64);
            }
        }
        map
    }

    /// The mean count of fibers between the light and depth `depth` at `uv`, of one texel's slot.
    fn count_at(&self, slot: usize, depth: f64) -> f64 {
        if self.first[slot] == u16::MAX {
            return 0.0;
        }
        let first = self.bases[slot / (TILE * TILE)] as f64 + self.first[slot] as f64 * FIRST_STEP * self.fiber_width;
        let o = (depth - first) / self.fiber_width;
        if o.is_nan() || o <= 0.0 {
            return 0.0;
        }
        let (counts, span) = (&self.counts[slot], span_widths(self.span[slot]));
        if o >= span {
            return dequantize(counts[KNOTS - 1]);
        }
        // The nearest knots on either side of o, among the front ones, the back ones, the first
        // fiber (0, no count) and the last (S, all of it); the count is monotone in depth, so
        // the tightest pair brackets it.
        let (mut lo, mut c_lo, mut hi, mut c_hi) = (0.0, 0.0, span, dequantize(counts[KNOTS - 1]));
        let front = front_from(o);
        if front > 0 {
            (lo, c_lo) = (FRONT_KNOTS[front - 1], dequantize(counts[front - 1]));
        }
        if front < FRONT && FRONT_KNOTS[front] < hi {
            (hi, c_hi) = (FRONT_KNOTS[front], dequantize(counts[front]));
        }
        let back = back_before(span - o);
        if back > 0 && span - BACK_KNOTS[back - 1] < hi {
            (hi, c_hi) = (span - BACK_KNOTS[back - 1], dequantize(counts[FRONT + back - 1]));
        }
        if back < BACK && span - BACK_KNOTS[back] > lo {
            (lo, c_lo) = (span - BACK_KNOTS[back], dequantize(counts[FRONT + back]));
        }
        if hi <= lo {
            return c_hi;
        }
        c_lo + (c_hi - c_lo) * ((o - lo) / (hi - lo)).clamp(0.0, 1.0)
    }

    /// The mean count of fibers between the light and a point `p` on the surface of a fiber of
    /// radius `radius` (world units; 0 off the hair): fibers whose axis lies more than a radius
    /// in front of it, so that its own fiber is not counted whichever side of it `p` is on, nor
    /// a fiber beside it.
    fn count(&self, p: DVec3, radius: f64) -> f64 {
        let (uv, depth) = self.project(p);
        let depth = depth - radius;
        let mut n = 0.0;
        for (slot, w) in self.around(uv) {
            if let Some(slot) = slot {
                n += w * self.count_at(slot, depth);
            }
        }
        n
    }

    fn bytes(&self) -> usize {
        4 * (self.tiles.len() + self.bases.len()) + 3 * self.first.len() + KNOTS * self.counts.len()
    }
}

/// The octahedral map of directions (Engelhardt and Dachsbacher 2008): a unit direction to a
/// point of the square [-1, 1]^2 and back; the lower hemisphere folds over the corners.
fn octahedral(d: DVec3) -> DVec2 {
    let p = DVec2::new(d.x, d.y) / (d.x.abs() + d.y.abs() + d.z.abs());
    if d.z >= 0.0 {
        p
    } else {
        (DVec2::ONE - DVec2::new(p.y.abs(), p.x.abs())) * DVec2::new(p.x.signum(), p.y.signum())
    }
}

fn from_octahedral(p: DVec2) -> DVec3 {
    let z = 1.0 - p.x.abs() - p.y.abs();
    let xy = if z >= 0.0 {
        p
    } else {
        (DVec2::ONE - DVec2::new(p.y.abs(), p.x.abs())) * DVec2::new(p.x.signum(), p.y.signum())
    };
    DVec3::new(xy.x, xy.y, z).normalize()
}

/// The environment's maps: one per distinct vertex of an octahedral grid.
#[derive(Debug, PartialEq)]
struct EnvMaps {
    grid: u32,
    /// Per grid vertex ((grid + 1)^2, row by row), the index of its map.
    vertex_map: Vec<u32>,
    maps: Vec<DepthMap>,
}

impl EnvMaps {
    /// The grid's vertex directions and, per vertex, the index among the distinct ones.
    fn directions(grid: u32) -> (Vec<DVec3>, Vec<u32>) {
        let n = grid as usize + 1;
        let mut distinct: Vec<DVec3> = Vec::new();
        let vertex_map = (0..n * n)
            .map(|v| {
                let p = DVec2::new((v % n) as f64, (v / n) as f64) * (2.0 / grid as f64) - 1.0;
                let d = from_octahedral(p);
                match distinct.iter().position(|e| e.dot(d) > 1.0 - 1e-9) {
                    Some(k) => k as u32,
                    None => {
                        distinct.push(d);
                        distinct.len() as u32 - 1
                    }
                }
            })
            .collect();
        (distinct, vertex_map)
    }

    /// The four maps around direction `d` with bilinear weights.
    fn around(&self, d: DVec3) -> [(usize, f64); 4] {
        let g = self.grid as f64;
        let x = (octahedral(d) + 1.0) * (0.5 * g);
        let (i, j) = (x.x.floor().clamp(0.0, g - 1.0), x.y.floor().clamp(0.0, g - 1.0));
        let (fx, fy) = ((x.x - i).clamp(0.0, 1.0), (x.y - j).clamp(0.0, 1.0));
        let n = self.grid as usize + 1;
        let v = |di: usize, dj: usize| self.vertex_map[(j as usize + dj) * n + i as usize + di] as usize;
        [(v(0, 0), (1.0 - fx) * (1.0 - fy)), (v(1, 0), fx * (1.0 - fy)), (v(0, 1), (1.0 - fx) * fy), (v(1, 1), fx * fy)]
    }
}

/// Lit fraction and fibers crossed from any point toward a scene's lights (module
/// documentation).
#[derive(Debug, PartialEq)]
pub struct ForwardLookup {
    /// The sun's map and the cosine beyond which a direction is in its disc.
    sun: Option<(DepthMap, f64)>,
    env: Option<EnvMaps>,
}

/// The fiber width of a hair: twice its mean radius.
pub fn fiber_width(strands: &Strands) -> f64 {
    2.0 * strands.radii.iter().map(|&r| r as f64).sum::<f64>() / strands.radii.len().max(1) as f64
}

impl ForwardLookup {
    /// The sun's part: its map toward `direction` (unit, toward it) and its disc's half angle.
    pub fn sun(strands: &Strands, direction: DVec3, half_angle: f64, settings: &LookupSettings) -> ForwardLookup {
        let w = fiber_width(strands);
        let map = DepthMap::build(strands, direction, settings.sun_texel * w, w);
        ForwardLookup { sun: Some((map, half_angle.cos().min(1.0 - 1e-12))), env: None }
    }

    /// The environment's part: its maps, built in parallel, reported to `progress`.
    pub fn environment(strands: &Strands, settings: &LookupSettings, progress: &dyn Progress) -> ForwardLookup {
        let w = fiber_width(strands);
        let (directions, vertex_map) = EnvMaps::directions(settings.env_grid);
        let task = progress.task("forward-transmittance maps of the sky", Some(directions.len() as u64));
        let maps = directions
            .par_iter()
            .map(|&d| {
                let map = DepthMap::build(strands, d, settings.env_texel * w, w);
                task.advance(1);
                map
            })
            .collect();
        drop(task);
        ForwardLookup { sun: None, env: Some(EnvMaps { grid: settings.env_grid, vertex_map, maps }) }
    }

    /// Both parts for a scene's lights, uncached (`Cache::lookup` keeps each part apart).
    pub fn build(
        strands: &Strands,
        lights: &Lights,
        settings: &LookupSettings,
        progress: &dyn Progress,
    ) -> ForwardLookup {
        let sun = lights.sun.map(|sun| ForwardLookup::sun(strands, sun.direction, sun.half_angle, settings));
        let env = lights.environment.as_ref().map(|_| ForwardLookup::environment(strands, settings, progress));
        ForwardLookup::join(sun, env)
    }

    /// One lookup of both parts (the sun's from `sun`, the environment's from `env`).
    pub fn join(sun: Option<ForwardLookup>, env: Option<ForwardLookup>) -> ForwardLookup {
        ForwardLookup { sun: sun.and_then(|s| s.sun), env: env.and_then(|e| e.env) }
    }

    /// (lit fraction, mean fibers crossed) from point `p` toward the unit direction `d` (world):
    /// the sun's map for directions in its disc, the environment's for any other; `None` for a
    /// direction no light shines from. `radius` is that of the fiber `p` is on (0 for a point on
    /// no fiber, like the skin).
    pub fn toward(&self, p: DVec3, radius: f64, d: DVec3) -> Option<(f64, f64)> {
        if let Some((map, cos_disc)) = &self.sun
            && d.dot(map.direction) >= *cos_disc
        {
            let n = map.count(p, radius);
            return Some(((-n).exp(), n));
        }
        let env = self.env.as_ref()?;
        let (mut lit, mut n) = (0.0, 0.0);
        for (k, w) in env.around(d) {
            if w > 0.0 {
                let nk = env.maps[k].count(p, radius);
                lit += w * (-nk).exp();
                n += w * nk;
            }
        }
        Some((lit, n))
    }

    /// Memory it takes, in bytes.
    pub fn bytes(&self) -> usize {
        self.sun.as_ref().map_or(0, |s| s.0.bytes())
            + self.env.as_ref().map_or(0, |e| e.maps.iter().map(DepthMap::bytes).sum())
    }

    /// The number of maps: the sun's and the environment's.
    pub fn maps(&self) -> usize {
        self.sun.is_some() as usize + self.env.as_ref().map_or(0, |e| e.maps.len())
    }

    /// Writes the lookup in its cache format, every number little-endian: "DHDEEPOM", the count
    /// of layers (u32); a byte 1 then the sun's disc cosine (f64) and its map, or a byte 0; a
    /// byte 1, the octahedral grid's squares per side (u32), its vertices' map indices ((n + 1)^2
    /// u32), the count of maps (u32) and the maps, or a byte 0. A map: its direction (3 f64),
    /// corner (2 f64), texel and fiber width (2 f64), size (2 u32), tile slots (u32 per tile of
    /// `TILE`^2 texels), the count of stored texels (u64), the stored tiles' base depths (f32),
    /// the texels' first depths (u16) and spans (u8, see `DepthMap`) and quantized cumulative
    /// counts (`KNOTS` bytes each).
    pub fn write(&self, w: &mut impl Write) -> std::io::Result<()> {
        w.write_all(MAGIC)?;
        w.write_all(&(KNOTS as u32).to_le_bytes())?;
        match &self.sun {
            Some((map, cos_disc)) => {
                w.write_all(&[1])?;
                w.write_all(&cos_disc.to_le_bytes())?;
                write_map(w, map)?;
            }
            None => w.write_all(&[0])?,
        }
        match &self.env {
            Some(env) => {
                w.write_all(&[1])?;
                w.write_all(&env.grid.to_le_bytes())?;
                w.write_all(&env.vertex_map.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
                w.write_all(&(env.maps.len() as u32).to_le_bytes())?;
                for map in &env.maps {
                    write_map(w, map)?;
                }
            }
            None => w.write_all(&[0])?,
        }
        Ok(())
    }

    /// Reads what [`ForwardLookup::write`] wrote; `None` if the bytes are not such a lookup
    /// (sizes are checked against the bytes before anything is allocated).
    pub fn read(bytes: &[u8]) -> Option<ForwardLookup> {
        let mut r = bytes.strip_prefix(MAGIC)?;
        if u32::from_le_bytes(take(&mut r)?) != KNOTS as u32 {
            return None;
        }
        let sun = match take::<1>(&mut r)?[0] {
            0 => None,
            1 => {
                let cos_disc = f64::from_le_bytes(take(&mut r)?);
                Some((read_map(&mut r)?, cos_disc))
            }
            _ => return None,
        };
        let env = match take::<1>(&mut r)?[0] {
            0 => None,
            1 => {
                let grid = u32::from_le_bytes(take(&mut r)?);
                LookupSettings { env_grid: grid, ..LookupSettings::default() }.validate().ok()?;
                let vertex_map = chunks(&mut r, (grid as usize + 1).pow(2), u32::from_le_bytes)?;
                let count = u32::from_le_bytes(take(&mut r)?) as usize;
                if vertex_map.iter().any(|&v| v as usize >= count) {
                    return None;
                }
                let mut maps = Vec::new();
                for _ in 0..count {
                    maps.push(read_map(&mut r)?);
                }
                Some(EnvMaps { grid, vertex_map, maps })
            }
            _ => return None,
        };
        r.is_empty().then_some(ForwardLookup { sun, env })
    }
}

const MAGIC: &[u8] = b"DHDEEPOM";

fn write_map(w: &mut impl Write, m: &DepthMap) -> std::io::Result<()> {
    let d = m.direction;
    for v in [d.x, d.y, d.z, m.corner.x, m.corner.y, m.texel, m.fiber_width] {
        w.write_all(&v.to_le_bytes())?;
    }
    w.write_all(&(m.size[0] as u32).to_le_bytes())?;
    w.write_all(&(m.size[1] as u32).to_le_bytes())?;
    w.write_all(&m.tiles.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
    w.write_all(&(m.first.len() as u64).to_le_bytes())?;
    w.write_all(&m.bases.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
    w.write_all(&m.first.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
    w.write_all(&m.span)?;
    w.write_all(m.counts.as_flattened())
}

fn read_map(r: &mut &[u8]) -> Option<DepthMap> {
    let mut f = || Some(f64::from_le_bytes(take(r)?));
    let (x, y, z, cx, cy, texel, fiber_width) = (f()?, f()?, f()?, f()?, f()?, f()?, f()?);
    let direction = DVec3::new(x, y, z);
    let finite = [cx, cy, texel, fiber_width].iter().all(|v| v.is_finite());
    if !finite || texel <= 0.0 || fiber_width <= 0.0 || (direction.length() - 1.0).abs() > 1e-9 {
        return None;
    }
    let mut map = DepthMap::frame(direction, texel, fiber_width);
    map.corner = DVec2::new(cx, cy);
    map.size = [u32::from_le_bytes(take(r)?) as usize, u32::from_le_bytes(take(r)?) as usize];
    let tiles = map.size[0].div_ceil(TILE).checked_mul(map.size[1].div_ceil(TILE))?;
    map.tiles = chunks(r, tiles, u32::from_le_bytes)?;
    let texels = usize::try_from(u64::from_le_bytes(take(r)?)).ok()?;
    if texels % (TILE * TILE) != 0 || map.tiles.iter().any(|&t| t != u32::MAX && t as usize >= texels / (TILE * TILE)) {
        return None;
    }
    map.bases = chunks(r, texels / (TILE * TILE), f32::from_le_bytes)?;
    map.first = chunks(r, texels, u16::from_le_bytes)?;
    map.span = chunks(r, texels, u8::from_le_bytes)?;
    let counts = chunks(r, texels.checked_mul(KNOTS)?, u8::from_le_bytes)?;
    map.counts = counts.chunks_exact(KNOTS).map(|c| c.try_into().expect("KNOTS counts")).collect();
    Some(map)
}

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
    use crate::progress::Silent;
    use glam::Vec3;

    /// One straight strand along x at height z, radius r, from x = -1 to 1 in `pieces` segments.
    fn strand(z: f32, r: f32, pieces: usize) -> (Vec<Vec3>, Vec<f32>) {
        let points: Vec<Vec3> =
            (0..=pieces).map(|k| Vec3::new(-1.0 + 2.0 * k as f32 / pieces as f32, 0.0, z)).collect();
        let radii = vec![r; points.len()];
        (points, radii)
    }

    /// `count` strands like [`strand`], `gap` apart in y from y = -0.5.
    fn sheet(z: f32, r: f32, gap: f32, count: usize) -> Vec<(Vec<Vec3>, Vec<f32>)> {
        (0..count)
            .map(|k| {
                let (mut p, radii) = strand(z, r, 50);
                p.iter_mut().for_each(|q| q.y = -0.5 + k as f32 * gap);
                (p, radii)
            })
            .collect()
    }

    fn strands(parts: &[(Vec<Vec3>, Vec<f32>)]) -> Strands {
        let mut s = Strands { points: Vec::new(), radii: Vec::new(), offsets: vec![0] };
        for (p, r) in parts {
            s.points.extend(p);
            s.radii.extend(r);
            s.offsets.push(s.points.len() as u32);
        }
        s
    }

    #[test]
    fn a_sheet_of_fibers_counts_its_coverage() {
        // A sheet of parallel fibers along x, spaced `gap` apart in y, at z = 0; light from +z.
        // A vertical ray through the sheet crosses on average 2 r / gap fibers (closed form);
        // points above the sheet see none, points below see the sheet, a fiber in the sheet
        // does not count itself.
        let (r, gap) = (0.001f32, 0.005f32);
        let s = strands(&sheet(0.0, r, gap, 201));
        let settings = LookupSettings { sun_texel: 20.0, ..LookupSettings::default() };
        let lookup = ForwardLookup::sun(&s, DVec3::Z, 0.0, &settings);
        let expect = 2.0 * r as f64 / gap as f64;
        for y in [-0.2, 0.0013, 0.1] {
            let (lit, n) = lookup.toward(DVec3::new(0.1, y, -0.05), 0.0, DVec3::Z).unwrap();
            // Within the byte's rounding (`quantize`) and 1% more.
            assert!((n - expect).abs() < 0.0146 * (1.0 + expect) + 0.01 * expect, "below at y {y}: n {n} vs {expect}");
            assert!((lit - (-n).exp()).abs() < 1e-12);
            let (lit, n) = lookup.toward(DVec3::new(0.1, y, 0.05), 0.0, DVec3::Z).unwrap();
            assert_eq!((lit, n), (1.0, 0.0), "above");
            // A point on the top of a fiber of the sheet, its own fiber not counted.
            let on = DVec3::new(0.1, -0.5 + 100.0 * gap as f64, r as f64 * 0.99);
            assert_eq!(lookup.toward(on, r as f64, DVec3::Z).unwrap().1, 0.0);
        }
        // Another direction is no light.
        assert_eq!(lookup.toward(DVec3::ZERO, 0.0, DVec3::X), None);
    }

    #[test]
    fn a_slab_and_a_hollow_count_the_fibers_above_a_point() {
        // Sheets like the test above (coverage c = 2 r / gap = 0.1 each), light from +z: 160
        // sheets a quarter of a fiber width apart (a slab 40 widths thick), then 300 widths of
        // nothing (a head's hollow), then 20 sheets more. At the knots (0.5, ..., 64 widths behind
        // the first sheet, 0.5, 1, 2 before the last, and beyond it) a point below k
        // sheets sees k c fibers (closed form), within one sheet's c and the byte's rounding;
        // between knots the count rises monotonically.
        let (r, gap) = (0.001f32, 0.02f32);
        let w = 2.0 * r as f64;
        let depths: Vec<f64> =
            (0..160).map(|k| k as f64 * 0.25 * w).chain((0..20).map(|k| (340.0 + k as f64 * 0.25) * w)).collect();
        let parts: Vec<_> = depths.iter().flat_map(|&d| sheet(-d as f32, r, gap, 51)).collect();
        let s = strands(&parts);
        let settings = LookupSettings { sun_texel: 40.0, ..LookupSettings::default() };
        let lookup = ForwardLookup::sun(&s, DVec3::Z, 0.0, &settings);
        let c = 2.0 * r as f64 / gap as f64;
        let n_at = |z: f64| lookup.toward(DVec3::new(0.1, 0.0013, -z * w), 0.0, DVec3::Z).unwrap().1;
        // The span as stored: rounded up (`span_byte`).
        let span = span_widths(span_byte(344.75));
        let knots = FRONT_KNOTS.into_iter().chain(BACK_KNOTS.map(|k| span - k)).chain([span + 1.0, 1000.0]);
        for z in knots {
            let (n, want) = (n_at(z), depths.iter().filter(|&&d| d < z * w).count() as f64 * c);
            assert!((n - want).abs() <= c + 0.0146 * (1.0 + want), "at depth {z} widths: n {n} vs {want}");
        }
        let mut before = 0.0;
        for k in 0..2000 {
            let n = n_at(k as f64 * 0.2);
            assert!(n >= before - 0.0146 * (1.0 + n), "at depth {} widths: {n} after {before}", k as f64 * 0.2);
            before = before.max(n);
        }
    }

    #[test]
    fn octahedral_grid_round_trips_and_interpolates() {
        for k in 0..200 {
            let d = precompute::conventions::uniform_sphere([(k as f64 + 0.5) / 200.0, (k as f64 * 0.618).fract()]);
            assert!((from_octahedral(octahedral(d)) - d).length() < 1e-12, "{d}");
        }
        // 25 vertices of 4 x 4 squares: the 9 inside are distinct; on the border the 4 corners
        // are one direction (-z) and each side's 3 others fold in pairs, 2 distinct a side.
        let (dirs, vertex_map) = EnvMaps::directions(4);
        assert_eq!(vertex_map.len(), 25);
        assert_eq!(dirs.len(), 9 + 1 + 4 * 2);
        let env = EnvMaps { grid: 4, vertex_map, maps: Vec::new() };
        for (k, &d) in dirs.iter().enumerate() {
            let w = env.around(d);
            let at: f64 = w.iter().filter(|(m, _)| *m == k).map(|x| x.1).sum();
            assert!((at - 1.0).abs() < 1e-9, "vertex {k} ({d}): {w:?}");
        }
    }

    #[test]
    fn cache_format_round_trips_and_rejects_damaged_bytes() {
        let (p, radii) = strand(0.0, 0.01, 8);
        let s = strands(&[(p, radii)]);
        let settings = LookupSettings { env_grid: 2, env_texel: 8.0, sun_texel: 8.0 };
        let lookup = ForwardLookup::join(
            Some(ForwardLookup::sun(&s, DVec3::new(0.0, 0.6, 0.8), 0.01, &settings)),
            Some(ForwardLookup::environment(&s, &settings, &Silent)),
        );
        let mut bytes = Vec::new();
        lookup.write(&mut bytes).unwrap();
        assert_eq!(ForwardLookup::read(&bytes), Some(lookup));
        for len in 0..bytes.len() {
            assert_eq!(ForwardLookup::read(&bytes[..len]), None, "truncated to {len}");
        }
    }

    #[test]
    fn quantized_counts_keep_n_within_their_step() {
        for n in [0.0, 1e-4, 0.5, 1.0, 7.3, 120.0, 1500.0] {
            let m = dequantize(quantize(n));
            assert!((m - n).abs() <= 0.0146 * (1.0 + n), "{n} -> {m}");
        }
        assert_eq!(quantize(1e9), 255);
    }
}
