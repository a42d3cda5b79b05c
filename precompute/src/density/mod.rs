//! The voxelized hair-length density grid (Zinke et al. 2008's global forward-scattering estimate,
//! with a voxel grid as in Lemein's thesis section 5.2).
//!
//! Each voxel holds the hair length inside it per unit volume (1/length^2 in scene units). Segments
//! are clipped exactly against every voxel they cross, so the grid conserves length: the sum of
//! density times voxel volume is the total fiber length. Voxel (i, j, k) covers
//! [i s, (i + 1) s) x [j s, (j + 1) s) x [k s, (k + 1) s) for voxel size s, with its center at
//! ((i, j, k) + 1/2) s. Storage is sparse: 8^3 bricks (OpenVDB's leaf size) only where hair is.

use crate::strands::Strands;
use glam::DVec3;
use rustc_hash::FxHashMap;

mod vdb;
pub use vdb::{VdbError, parse_vdb, read_vdb, write_vdb};

/// Voxels along each edge of a brick.
pub const BRICK: i32 = 8;
const BRICK_VOXELS: usize = (BRICK * BRICK * BRICK) as usize;

/// A sparse grid of hair length per unit volume.
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    /// Edge length of a voxel, in scene units.
    pub voxel_size: f64,
    /// Width of a fiber (mean diameter), to turn length crossed into fibers crossed.
    pub fiber_width: f64,
    /// Bricks keyed by the index of their first voxel divided by `BRICK`.
    bricks: FxHashMap<[i32; 3], Box<[f32; BRICK_VOXELS]>>,
    /// World bounds of the stored bricks (where a ray march can find hair).
    bounds: Option<(DVec3, DVec3)>,
    /// The hair's orientation per brick (empty until [`DensityGrid::with_orientation`]): the
    /// length-weighted mean of t t^T over the segments whose midpoint is in the brick, for unit
    /// tangents t, as its six entries xx, yy, zz, xy, xz, yz (trace 1).
    orientation: FxHashMap<[i32; 3], [f64; 6]>,
}

fn brick_of(v: [i32; 3]) -> ([i32; 3], usize) {
    let b = v.map(|c| c.div_euclid(BRICK));
    let l = v.map(|c| c.rem_euclid(BRICK) as usize);
    (b, (l[2] * BRICK as usize + l[1]) * BRICK as usize + l[0])
}

/// Walks the voxels a segment from `a` to `b` passes through (Amanatides & Woo 1987), calling
/// `visit(voxel, t0, t1)` with the parametric interval (in [0, 1] along the segment) inside it.
/// Every point of the segment belongs to exactly one interval, so lengths are conserved; a segment
/// lying exactly on a voxel face is assigned to the voxel on the face's positive side.
pub fn traverse(a: DVec3, b: DVec3, voxel_size: f64, mut visit: impl FnMut([i32; 3], f64, f64)) {
    let d = b - a;
    let pa = a / voxel_size;
    let mut v = pa.floor().as_ivec3().to_array();
    let mut t_next = [0.0; 3];
    let mut t_step = [f64::INFINITY; 3];
    let mut step = [0; 3];
    for k in 0..3 {
        let dk = d[k] / voxel_size;
        if dk > 0.0 {
            step[k] = 1;
            t_step[k] = 1.0 / dk;
            t_next[k] = ((v[k] + 1) as f64 - pa[k]) / dk;
        } else if dk < 0.0 {
            step[k] = -1;
            t_step[k] = -1.0 / dk;
            t_next[k] = (v[k] as f64 - pa[k]) / dk;
        } else {
            t_next[k] = f64::INFINITY;
        }
    }
    let mut t = 0.0;
    while t < 1.0 {
        let k = if t_next[0] <= t_next[1] && t_next[0] <= t_next[2] {
            0
        } else if t_next[1] <= t_next[2] {
            1
        } else {
            2
        };
        let t_exit = t_next[k].min(1.0);
        if t_exit > t {
            visit(v, t, t_exit);
        }
        t = t_exit;
        v[k] += step[k];
        t_next[k] += t_step[k];
    }
}

impl DensityGrid {
    /// The default voxel size for a hair model: 8 mean fiber diameters, so a voxel averages over
    /// several neighbouring fibers (the forward-scattering count is a statistical estimate), kept
    /// between 1/512 and 1/16 of the longest edge of the hair's bounds to bound memory and keep
    /// some resolution.
    pub fn auto_voxel_size(strands: &Strands) -> f64 {
        let (lo, hi) = strands.bounds();
        let longest = (hi - lo).max_element() as f64;
        (16.0 * mean_radius(strands)).clamp(longest / 512.0, longest / 16.0)
    }

    /// Bytes [`DensityGrid::voxelize`] holds per brick at its peak: the brick's sums in f64 and
    /// its densities in f32, each boxed, with their hash entries.
    pub const VOXELIZE_BYTES_PER_BRICK: u64 = (BRICK_VOXELS * (8 + 4) + 2 * 48) as u64;

    /// The most bricks voxelizing `strands` can make: those of the hair's bounds (cheap, and
    /// what a grid of fine voxels over a large groom cannot exceed).
    pub fn bricks_bound(strands: &Strands, voxel_size: f64) -> u64 {
        let (lo, hi) = strands.bounds();
        let brick = voxel_size * BRICK as f64;
        (0..3)
            .map(|k| ((hi[k] as f64 / brick).floor() - (lo[k] as f64 / brick).floor() + 1.0).max(1.0))
            .product::<f64>()
            .min(u64::MAX as f64) as u64
    }

    /// The bricks voxelizing `strands` will make, counted by walking the segments brick by brick
    /// (a hash set of keys: about 1/300 of the grid's memory), or `limit + 1` once more than
    /// `limit` are found.
    pub fn bricks_touched(strands: &Strands, voxel_size: f64, limit: u64) -> u64 {
        let mut bricks = rustc_hash::FxHashSet::default();
        for s in strands.segments() {
            traverse(s.a.as_dvec3(), s.b.as_dvec3(), voxel_size * BRICK as f64, |b, _, _| {
                bricks.insert(b);
            });
            if bricks.len() as u64 > limit {
                return limit + 1;
            }
        }
        bricks.len() as u64
    }

    /// Voxelizes strands: exact length of every segment inside every voxel, over the voxel volume.
    pub fn voxelize(strands: &Strands, voxel_size: f64) -> DensityGrid {
        assert!(voxel_size > 0.0 && voxel_size.is_finite(), "voxel size must be finite and > 0");
        let mut sums: FxHashMap<[i32; 3], Box<[f64; BRICK_VOXELS]>> = FxHashMap::default();
        for s in strands.segments() {
            let (a, b) = (s.a.as_dvec3(), s.b.as_dvec3());
            let len = (b - a).length();
            traverse(a, b, voxel_size, |v, t0, t1| {
                let (brick, i) = brick_of(v);
                sums.entry(brick).or_insert_with(|| Box::new([0.0; BRICK_VOXELS]))[i] += (t1 - t0) * len;
            });
        }
        let volume = voxel_size.powi(3);
        let bricks = sums.into_iter().map(|(k, s)| (k, Box::new(s.map(|l| (l / volume) as f32)))).collect();
        DensityGrid::new(voxel_size, 2.0 * mean_radius(strands), bricks)
    }

    fn new(voxel_size: f64, fiber_width: f64, bricks: FxHashMap<[i32; 3], Box<[f32; BRICK_VOXELS]>>) -> DensityGrid {
        let s = voxel_size * BRICK as f64;
        let bounds = bricks.keys().fold(None, |acc: Option<(DVec3, DVec3)>, b| {
            let lo = DVec3::from_array(b.map(|c| c as f64)) * s;
            let hi = lo + DVec3::splat(s);
            Some(acc.map_or((lo, hi), |(l, h)| (l.min(lo), h.max(hi))))
        });
        DensityGrid { voxel_size, fiber_width, bricks, bounds, orientation: FxHashMap::default() }
    }

    /// A grid from explicit voxel densities (for readers of other formats).
    pub fn from_voxels(
        voxel_size: f64,
        fiber_width: f64,
        voxels: impl IntoIterator<Item = ([i32; 3], f32)>,
    ) -> DensityGrid {
        let mut bricks: FxHashMap<[i32; 3], Box<[f32; BRICK_VOXELS]>> = FxHashMap::default();
        for (v, d) in voxels {
            let (brick, i) = brick_of(v);
            bricks.entry(brick).or_insert_with(|| Box::new([0.0; BRICK_VOXELS]))[i] = d;
        }
        DensityGrid::new(voxel_size, fiber_width, bricks)
    }

    /// Every voxel with non-zero density, in no particular order.
    pub fn voxels(&self) -> impl Iterator<Item = ([i32; 3], f32)> + '_ {
        self.bricks.iter().flat_map(|(b, data)| {
            data.iter().enumerate().filter(|(_, d)| **d != 0.0).map(move |(i, &d)| {
                let l = [i as i32 % BRICK, (i as i32 / BRICK) % BRICK, i as i32 / (BRICK * BRICK)];
                ([b[0] * BRICK + l[0], b[1] * BRICK + l[1], b[2] * BRICK + l[2]], d)
            })
        })
    }

    /// Bricks: index of each brick's first voxel and its 8^3 densities, x fastest.
    pub fn bricks(&self) -> impl Iterator<Item = ([i32; 3], &[f32; BRICK_VOXELS])> + '_ {
        self.bricks.iter().map(|(b, d)| (b.map(|c| c * BRICK), &**d))
    }

    /// The grid with the orientation of `strands` (the hair it was voxelized from) per brick, for
    /// [`DensityGrid::fibers_crossed`]. Derived from the strands whenever a grid is loaded, not
    /// stored in its file: OpenVDB's density grid has no place for it.
    pub fn with_orientation(mut self, strands: &Strands) -> DensityGrid {
        let mut sums: FxHashMap<[i32; 3], [f64; 6]> = FxHashMap::default();
        for s in strands.segments() {
            let (a, b) = (s.a.as_dvec3(), s.b.as_dvec3());
            let (d, len) = (b - a, (b - a).length());
            if len <= 0.0 {
                continue;
            }
            // len t t^T = d d^T / len.
            let (key, _) = brick_of((0.5 * (a + b) / self.voxel_size).floor().as_ivec3().to_array());
            let m = [d.x * d.x, d.y * d.y, d.z * d.z, d.x * d.y, d.x * d.z, d.y * d.z].map(|v| v / len);
            let sum = sums.entry(key).or_default();
            (0..6).for_each(|k| sum[k] += m[k]);
        }
        self.orientation = sums
            .into_iter()
            .filter_map(|(k, m)| {
                let trace = m[0] + m[1] + m[2];
                (trace > 0.0).then(|| (k, m.map(|v| v / trace)))
            })
            .collect();
        self
    }

    /// The mean |sin| of the angle between the unit direction `d` and the hair of a brick, as
    /// sqrt(mean sin^2) = sqrt(1 - d^T M d) for the brick's orientation M: exact where the
    /// fibers are parallel, 4% above the mean (sqrt(2/3) against pi/4) where every orientation
    /// is as likely; 1 (fibers across the ray) where the orientation is not known.
    fn across(&self, brick: [i32; 3], d: DVec3) -> f64 {
        let Some(m) = self.orientation.get(&brick) else { return 1.0 };
        let along = m[0] * d.x * d.x
            + m[1] * d.y * d.y
            + m[2] * d.z * d.z
            + 2.0 * (m[3] * d.x * d.y + m[4] * d.x * d.z + m[5] * d.y * d.z);
        (1.0 - along).max(0.0).sqrt()
    }

    /// Density of one voxel (0 outside the stored bricks).
    pub fn voxel(&self, v: [i32; 3]) -> f32 {
        let (brick, i) = brick_of(v);
        self.bricks.get(&brick).map_or(0.0, |d| d[i])
    }

    /// Total hair length: sum of density times voxel volume.
    pub fn total_length(&self) -> f64 {
        self.voxels().map(|(_, d)| d as f64).sum::<f64>() * self.voxel_size.powi(3)
    }

    /// Trilinear interpolation between voxel centers.
    pub fn density(&self, p: DVec3) -> f64 {
        let q = p / self.voxel_size - DVec3::splat(0.5);
        let base = q.floor();
        let f = q - base;
        let b = base.as_ivec3();
        let mut sum = 0.0;
        for corner in 0..8 {
            let o = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let w: f64 = (0..3).map(|k| if o[k] == 1 { f[k] } else { 1.0 - f[k] }).product();
            if w > 0.0 {
                sum += w * self.voxel([b.x + o[0], b.y + o[1], b.z + o[2]]) as f64;
            }
        }
        sum
    }

    /// Number of fibers crossed along the ray from `origin` in unit direction `dir` over
    /// [0, t_max] (Zinke et al. 2008's n): the length density integrated along the ray (exactly,
    /// voxel by voxel) times the fiber width times the mean |sin| of the angle between the ray and
    /// the fibers (a fiber of width w at angle a to the ray presents a cross-section w |sin a| per
    /// unit length; `DensityGrid::across`), per brick. `t_max` may be infinite; the march
    /// stops past the bricks.
    pub fn fibers_crossed(&self, origin: DVec3, dir: DVec3, t_max: f64) -> f64 {
        self.march(origin, dir, t_max, true)
    }

    /// [`DensityGrid::fibers_crossed`] with every fiber taken as across the ray, whatever the
    /// orientation: the count of Zinke et al. 2008 and Lemein's thesis (section 5.2), 4/pi of
    /// the real count for fibers of random orientation.
    pub fn fibers_across(&self, origin: DVec3, dir: DVec3, t_max: f64) -> f64 {
        self.march(origin, dir, t_max, false)
    }

    fn march(&self, origin: DVec3, dir: DVec3, t_max: f64, oriented: bool) -> f64 {
        let Some((lo, hi)) = self.bounds else { return 0.0 };
        // Clip the ray to the bounds of the stored bricks (slab test).
        let (mut t0, mut t1) = (0.0f64, t_max);
        for k in 0..3 {
            if dir[k] == 0.0 {
                if origin[k] < lo[k] || origin[k] > hi[k] {
                    return 0.0;
                }
            } else {
                let (a, b) = ((lo[k] - origin[k]) / dir[k], (hi[k] - origin[k]) / dir[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        if t0 >= t1 {
            return 0.0;
        }
        let (a, b) = (origin + t0 * dir, origin + t1 * dir);
        let mut integral = 0.0;
        // Brick by brick, then voxel by voxel inside the stored bricks only: a march through a
        // groom crosses mostly empty space (the head, the air around it).
        traverse(a, b, self.voxel_size * BRICK as f64, |key, s0, s1| {
            let Some(data) = self.bricks.get(&key) else { return };
            let (p, q) = (a.lerp(b, s0), a.lerp(b, s1));
            let len = (t1 - t0) * (s1 - s0);
            let base = key.map(|c| c * BRICK);
            let across = if oriented { self.across(key, dir) } else { 1.0 };
            traverse(p, q, self.voxel_size, |v, u0, u1| {
                // Rounding can step the piece's ends into a neighbouring brick's voxel for a
                // length of order 1e-16 of the piece: that sliver counts in the nearest voxel here.
                let l = [0, 1, 2].map(|k| (v[k] - base[k]).clamp(0, BRICK - 1));
                integral += data[((l[2] * BRICK + l[1]) * BRICK + l[0]) as usize] as f64 * (u1 - u0) * len * across;
            });
        });
        integral * self.fiber_width
    }
}

fn mean_radius(strands: &Strands) -> f64 {
    strands.radii.iter().map(|&r| r as f64).sum::<f64>() / strands.radii.len().max(1) as f64
}
