//! Hair geometry as polyline strands: the data every later stage (BVH, density grid) reads.
//!
//! A strand is a polyline of control points with a fiber radius at each point; it renders as a
//! round fiber, the union of capsules around its segments (a sphere swept along the polyline, with
//! the radius of each segment the mean of its end radii). Units are the scene's; radii are half the
//! thickness stored in a .hair file.

mod curves;
mod generate;
mod hair_format;
mod pbrt_curves;
mod usd;

pub use generate::{Ball, Curly, GenerateError, Generator, MAX_STRAND_POINTS, MAX_TOTAL_POINTS, Scalp, Straight, Wavy};
pub use hair_format::{HairError, parse_hair, read_hair, write_hair};
pub use pbrt_curves::{PbrtError, parse_pbrt_curves, read_pbrt_curves};
pub use usd::{UsdError, parse_usd_curves, read_usd_curves};

use glam::Vec3;
use std::path::Path;

/// Hair files this crate reads, by name: Cem Yuksel's .hair (also gzipped, `.hair.gz`),
/// pbrt-v4 scenes (`.pbrt`, `.pbrt.gz`), whose curve shapes become strands, and USD stages
/// (`.usda`, `.usdc`, `.usd`, `.usdz`), whose BasisCurves prims do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairFormat {
    Hair,
    Pbrt,
    Usd,
}

impl HairFormat {
    /// The format of the file `path` names, if it is one of the hair formats.
    pub fn of(path: &Path) -> Option<HairFormat> {
        let full = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        let name = full.strip_suffix(".gz").unwrap_or(&full);
        if name.ends_with(".hair") {
            Some(HairFormat::Hair)
        } else if name.ends_with(".pbrt") {
            Some(HairFormat::Pbrt)
        } else if [".usda", ".usdc", ".usd", ".usdz"].iter().any(|e| full.ends_with(e)) {
            Some(HairFormat::Usd)
        } else {
            None
        }
    }
}

/// A hair file that cannot be read, in its format's terms.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error(transparent)]
    Hair(#[from] HairError),
    #[error(transparent)]
    Pbrt(#[from] PbrtError),
    #[error(transparent)]
    Usd(#[from] UsdError),
    #[error("{}: not a hair file this reader knows (.hair, .hair.gz, .pbrt, .pbrt.gz, .usda, .usdc, .usd or .usdz)", .0.display())]
    Unknown(std::path::PathBuf),
}

/// Reads strands from a .hair(.gz) file or the curves of a .pbrt(.gz) scene, by the file's name.
pub fn read_strands(path: &Path) -> Result<Strands, ReadError> {
    match HairFormat::of(path) {
        Some(HairFormat::Hair) => Ok(read_hair(path)?),
        Some(HairFormat::Pbrt) => Ok(read_pbrt_curves(path)?),
        Some(HairFormat::Usd) => Ok(read_usd_curves(path)?),
        None => Err(ReadError::Unknown(path.to_owned())),
    }
}

/// Strands in one flat layout: strand `s` owns points `offsets[s]..offsets[s + 1]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Strands {
    /// Control points of all strands, strand after strand.
    pub points: Vec<Vec3>,
    /// Fiber radius at each point (> 0).
    pub radii: Vec<f32>,
    /// Index of each strand's first point, plus a final entry equal to `points.len()`.
    pub offsets: Vec<u32>,
}

/// A segment of a strand: the capsule between two consecutive points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub a: Vec3,
    pub b: Vec3,
    pub radius: f32,
}

/// Geometry that cannot be rendered; the message says where and what.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum StrandError {
    #[error("strand offsets are inconsistent with {points} points and {radii} radii")]
    Layout { points: usize, radii: usize },
    #[error("strand {strand} has {points} point(s); a strand needs at least 2")]
    TooShort { strand: usize, points: usize },
    #[error("point {point} (strand {strand}) is not finite: {value:?}")]
    NonFinitePoint { strand: usize, point: usize, value: [f32; 3] },
    #[error("point {point} (strand {strand}) has radius {radius}; radii must be finite and > 0")]
    BadRadius { strand: usize, point: usize, radius: f32 },
    #[error("segment {point}-{next} of strand {strand} has zero length")]
    ZeroLengthSegment { strand: usize, point: usize, next: usize },
}

impl Strands {
    pub fn strand_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn segment_count(&self) -> usize {
        self.points.len() - self.strand_count()
    }

    /// Points of strand `s`.
    pub fn strand(&self, s: usize) -> &[Vec3] {
        &self.points[self.offsets[s] as usize..self.offsets[s + 1] as usize]
    }

    /// Every segment, strand by strand.
    pub fn segments(&self) -> impl Iterator<Item = Segment> + '_ {
        self.offsets.windows(2).flat_map(move |w| {
            (w[0] as usize..w[1] as usize - 1).map(move |i| Segment {
                a: self.points[i],
                b: self.points[i + 1],
                radius: 0.5 * (self.radii[i] + self.radii[i + 1]),
            })
        })
    }

    /// Total fiber length (sum of segment lengths), in f64.
    pub fn total_length(&self) -> f64 {
        self.segments().map(|s| (s.b - s.a).as_dvec3().length()).sum()
    }

    /// Axis-aligned bounds of the fibers, radii included: (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.points.iter().zip(&self.radii).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (&p, &r)| {
            (lo.min(p - Vec3::splat(r)), hi.max(p + Vec3::splat(r)))
        })
    }

    /// Checks the layout and every value: at least two points per strand, finite points, finite
    /// positive radii, no zero-length segment.
    pub fn validate(&self) -> Result<(), StrandError> {
        let (n, layout) =
            (self.points.len(), StrandError::Layout { points: self.points.len(), radii: self.radii.len() });
        if self.radii.len() != n
            || self.offsets.first() != Some(&0)
            || self.offsets.last().map(|&o| o as usize) != Some(n)
            || self.offsets.windows(2).any(|w| w[1] < w[0])
        {
            return Err(layout);
        }
        for (s, w) in self.offsets.windows(2).enumerate() {
            let (start, end) = (w[0] as usize, w[1] as usize);
            if end - start < 2 {
                return Err(StrandError::TooShort { strand: s, points: end - start });
            }
            for i in start..end {
                let p = self.points[i];
                if !p.is_finite() {
                    return Err(StrandError::NonFinitePoint { strand: s, point: i, value: p.to_array() });
                }
                let r = self.radii[i];
                if !(r.is_finite() && r > 0.0) {
                    return Err(StrandError::BadRadius { strand: s, point: i, radius: r });
                }
                if i > start && p == self.points[i - 1] {
                    return Err(StrandError::ZeroLengthSegment { strand: s, point: i - 1, next: i });
                }
            }
        }
        Ok(())
    }
}
