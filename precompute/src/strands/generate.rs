//! Seeded, deterministic test hair: swatches (straight, wavy, curly), a hair ball and a scalp cap.
//!
//! Each kind is described by a small struct that a scene file gives as JSON, e.g. `{"kind": "curly",
//! "turns": 3}`; every field has a default, so `{"kind": "curly"}` alone is a complete description.
//! The same description and seed always give the same strands (PCG64 from `rand_pcg`).
//!
//! Units are the scene's. The defaults make shapes about 1 unit across (swatches 1 unit wide and
//! long, a ball and a head 1 unit in diameter) with a fiber radius of 0.0025. Real hair has a radius
//! of about 0.04 mm, so on a 10 cm swatch it would be 0.0004; the defaults are about 6 times thicker
//! so that a few thousand strands (30k to 260k points) cover a shape and render fast. Z is up, as in
//! the real grooms: swatches hang from z = +length/2 toward -z.

use super::{StrandError, Strands};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, TAU};

/// At most this many points in all, so a typo in a scene file cannot ask for gigabytes.
pub const MAX_TOTAL_POINTS: u64 = 10_000_000;
/// At most this many points per strand: the most a .hair file can store (u16 segment counts).
pub const MAX_STRAND_POINTS: u32 = 65_536;

/// One generated hair shape; see each kind for its shape and parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Generator {
    Straight(Straight),
    Wavy(Wavy),
    Curly(Curly),
    Ball(Ball),
    Scalp(Scalp),
}

/// A generator parameter out of range, or parameters whose geometry cannot be rendered.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GenerateError {
    #[error("hair generator field `{field}` {problem} (got {value})")]
    Param { field: &'static str, problem: &'static str, value: f64 },
    // Not `#[from]`, which would make it the source too: the message says it, and `{:#}` would
    // print it twice.
    #[error("the hair generator's parameters give geometry that cannot be rendered: {0}")]
    Geometry(StrandError),
}

/// A flat swatch of parallel straight strands. Roots are uniform over a `width` (x) by `depth` (y)
/// rectangle centered on the z axis at z = +length/2; every strand runs straight down -z.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Straight {
    /// Number of strands (default 2000).
    pub strands: u32,
    /// Points per strand, evenly spaced (default 16).
    pub points: u32,
    /// Strand length (default 1).
    pub length: f64,
    /// Extent of the roots along x (default 1).
    pub width: f64,
    /// Extent of the roots along y (default 0.1); 0 puts all roots on one line.
    pub depth: f64,
    /// Fiber radius (default 0.0025).
    pub radius: f64,
    /// Seed of the random generator (default 1).
    pub seed: u64,
}

/// A swatch of wavy strands: as [`Straight`], but each strand waves in x as a sine of `amplitude`
/// and `wavelength` along its fall. Neighbours wave together, as in a combed swatch: the phases
/// differ by at most a quarter of a wave (uniform in [-pi/4, pi/4]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Wavy {
    /// Number of strands (default 2000).
    pub strands: u32,
    /// Points per strand, evenly spaced in z (default 64, about 13 per wave).
    pub points: u32,
    /// Vertical extent of each strand (default 1); the fiber itself is longer.
    pub length: f64,
    /// Extent of the roots along x (default 1).
    pub width: f64,
    /// Extent of the roots along y (default 0.1).
    pub depth: f64,
    /// Fiber radius (default 0.0025).
    pub radius: f64,
    /// Peak sideways offset of the wave (default 0.03; 0 makes straight strands).
    pub amplitude: f64,
    /// Vertical distance of one wave (default 0.2).
    pub wavelength: f64,
    /// Seed of the random generator (default 1).
    pub seed: u64,
}

/// A swatch of curly strands: each strand is a helix of radius `curl_radius` around a vertical axis,
/// making `turns` turns while it falls `length`, starting at a random angle. Its arc length is
/// sqrt((2 pi curl_radius turns)^2 + length^2). Axes are placed as the roots of [`Straight`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Curly {
    /// Number of strands (default 2000).
    pub strands: u32,
    /// Points per strand, evenly spaced along the helix (default 128, about 21 per turn).
    pub points: u32,
    /// Height of the helix, along its axis (default 1).
    pub length: f64,
    /// Extent of the axes along x (default 1).
    pub width: f64,
    /// Extent of the axes along y (default 0.1).
    pub depth: f64,
    /// Fiber radius (default 0.0025).
    pub radius: f64,
    /// Radius of the helix (default 0.04).
    pub curl_radius: f64,
    /// Number of turns over the strand (default 6).
    pub turns: f64,
    /// Seed of the random generator (default 1).
    pub seed: u64,
}

/// A hair ball: strands with roots uniform in the volume of a ball of `ball_radius` centered on the
/// origin, each a circular arc of `length` and `curvature` (radians per unit length) in a random
/// direction and plane. Every point lies within `ball_radius + length` of the center.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Ball {
    /// Number of strands (default 3000).
    pub strands: u32,
    /// Points per strand, evenly spaced along the arc (default 16).
    pub points: u32,
    /// Radius of the ball holding the roots (default 0.5).
    pub ball_radius: f64,
    /// Arc length of each strand (default 0.4).
    pub length: f64,
    /// Curvature of each strand in radians per unit length (default 4; 0 makes straight strands).
    pub curvature: f64,
    /// Fiber radius (default 0.0025).
    pub radius: f64,
    /// Seed of the random generator (default 1).
    pub seed: u64,
}

/// Hair on a head: roots uniform over the area of a spherical cap of `scalp_radius` centered on the
/// origin, within `cap_angle` (radians) of the +z pole. Each strand drapes under gravity: it follows
/// its meridian down over the head to the equator and then hangs straight down. So that strands do
/// not lie on top of each other, each one lies at its own height h, uniform in [0, layer], above the
/// scalp, which it climbs to from its root at a slope of 1 in 4. `length` is measured along the
/// drape; the climb changes the fiber's length by well under 1% at the defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scalp {
    /// Number of strands (default 5000).
    pub strands: u32,
    /// Points per strand, evenly spaced along the drape (default 32).
    pub points: u32,
    /// Radius of the scalp sphere (default 0.5).
    pub scalp_radius: f64,
    /// Polar angle of the cap's edge, in radians, in (0, pi/2] (default 1.2, about 69 degrees).
    pub cap_angle: f64,
    /// Strand length (default 1.2).
    pub length: f64,
    /// Thickness of the hair layer over the scalp (default 0.03).
    pub layer: f64,
    /// Fiber radius (default 0.0025).
    pub radius: f64,
    /// Seed of the random generator (default 1).
    pub seed: u64,
}

impl Default for Straight {
    fn default() -> Self {
        Straight { strands: 2000, points: 16, length: 1.0, width: 1.0, depth: 0.1, radius: 0.0025, seed: 1 }
    }
}

impl Default for Wavy {
    fn default() -> Self {
        Wavy {
            strands: 2000,
            points: 64,
            length: 1.0,
            width: 1.0,
            depth: 0.1,
            radius: 0.0025,
            amplitude: 0.03,
            wavelength: 0.2,
            seed: 1,
        }
    }
}

impl Default for Curly {
    fn default() -> Self {
        Curly {
            strands: 2000,
            points: 128,
            length: 1.0,
            width: 1.0,
            depth: 0.1,
            radius: 0.0025,
            curl_radius: 0.04,
            turns: 6.0,
            seed: 1,
        }
    }
}

impl Default for Ball {
    fn default() -> Self {
        Ball { strands: 3000, points: 16, ball_radius: 0.5, length: 0.4, curvature: 4.0, radius: 0.0025, seed: 1 }
    }
}

impl Default for Scalp {
    fn default() -> Self {
        Scalp {
            strands: 5000,
            points: 32,
            scalp_radius: 0.5,
            cap_angle: 1.2,
            length: 1.2,
            layer: 0.03,
            radius: 0.0025,
            seed: 1,
        }
    }
}

impl Generator {
    /// Checks the parameters and makes the strands; the same description always gives the same strands.
    pub fn generate(&self) -> Result<Strands, GenerateError> {
        let strands = match self {
            Generator::Straight(g) => g.generate()?,
            Generator::Wavy(g) => g.generate()?,
            Generator::Curly(g) => g.generate()?,
            Generator::Ball(g) => g.generate()?,
            Generator::Scalp(g) => g.generate()?,
        };
        // Valid parameters can still round to coincident f32 points (a length tiny next to the
        // coordinates) or overflow f32 (huge extents).
        strands.validate().map_err(GenerateError::Geometry)?;
        Ok(strands)
    }
}

impl Straight {
    fn generate(&self) -> Result<Strands, GenerateError> {
        let &Straight { strands, points, length, width, depth, radius, seed } = self;
        check_common(strands, points, length, radius)?;
        check_swatch(width, depth)?;
        Ok(build(strands, points, radius, seed, |rng| {
            let root = swatch_root(rng, width, depth, length);
            move |t| root - DVec3::Z * (length * t)
        }))
    }
}

impl Wavy {
    fn generate(&self) -> Result<Strands, GenerateError> {
        let &Wavy { strands, points, length, width, depth, radius, amplitude, wavelength, seed } = self;
        check_common(strands, points, length, radius)?;
        check_swatch(width, depth)?;
        check("amplitude", amplitude, amplitude >= 0.0, "must be finite and >= 0")?;
        check("wavelength", wavelength, wavelength > 0.0, "must be finite and > 0")?;
        Ok(build(strands, points, radius, seed, |rng| {
            let root = swatch_root(rng, width, depth, length);
            let phase = rng.random_range(-FRAC_PI_4..=FRAC_PI_4);
            move |t| {
                let fall = length * t;
                root + DVec3::new(amplitude * (TAU * fall / wavelength + phase).sin(), 0.0, -fall)
            }
        }))
    }
}

impl Curly {
    fn generate(&self) -> Result<Strands, GenerateError> {
        let &Curly { strands, points, length, width, depth, radius, curl_radius, turns, seed } = self;
        check_common(strands, points, length, radius)?;
        check_swatch(width, depth)?;
        check("curl_radius", curl_radius, curl_radius > 0.0, "must be finite and > 0")?;
        check("turns", turns, turns > 0.0, "must be finite and > 0")?;
        Ok(build(strands, points, radius, seed, |rng| {
            let axis = swatch_root(rng, width, depth, length);
            let phase = rng.random_range(0.0..TAU);
            move |t| {
                let angle = phase + TAU * turns * t;
                axis + DVec3::new(curl_radius * angle.cos(), curl_radius * angle.sin(), -length * t)
            }
        }))
    }
}

impl Ball {
    fn generate(&self) -> Result<Strands, GenerateError> {
        let &Ball { strands, points, ball_radius, length, curvature, radius, seed } = self;
        check_common(strands, points, length, radius)?;
        check("ball_radius", ball_radius, ball_radius > 0.0, "must be finite and > 0")?;
        check("curvature", curvature, curvature >= 0.0, "must be finite and >= 0")?;
        Ok(build(strands, points, radius, seed, |rng| {
            // Uniform in the ball: radius from the cube root of a uniform variate.
            let root = ball_radius * rng.random::<f64>().cbrt() * unit_vector(rng);
            let start = unit_vector(rng);
            let (a, b) = start.any_orthonormal_pair();
            let bend_angle = rng.random_range(0.0..TAU);
            let bend = a * bend_angle.cos() + b * bend_angle.sin();
            // The arc of curvature k starting along `start` and turning toward `bend`:
            // p(s) = root + (start sin(ks) + bend (1 - cos(ks))) / k.
            move |t| {
                let s = length * t;
                if curvature == 0.0 {
                    root + start * s
                } else {
                    let turn = curvature * s;
                    root + (start * turn.sin() + bend * (1.0 - turn.cos())) / curvature
                }
            }
        }))
    }
}

impl Scalp {
    fn generate(&self) -> Result<Strands, GenerateError> {
        let &Scalp { strands, points, scalp_radius, cap_angle, length, layer, radius, seed } = self;
        check_common(strands, points, length, radius)?;
        check("scalp_radius", scalp_radius, scalp_radius > 0.0, "must be finite and > 0")?;
        check("cap_angle", cap_angle, cap_angle > 0.0 && cap_angle <= FRAC_PI_2, "must be in (0, pi/2] radians")?;
        check("layer", layer, layer >= 0.0, "must be finite and >= 0")?;
        Ok(build(strands, points, radius, seed, |rng| {
            // Uniform over the cap's area: cos(polar angle) uniform in [cos(cap_angle), 1].
            let polar = rng.random_range(cap_angle.cos()..=1.0).acos();
            let azimuth = rng.random_range(0.0..TAU);
            let height = layer * rng.random::<f64>();
            let outward = DVec3::new(azimuth.cos(), azimuth.sin(), 0.0);
            // Distance along the drape at which the meridian reaches the equator and the strand hangs.
            let to_equator = (FRAC_PI_2 - polar) * (scalp_radius + height);
            move |t| {
                let s = length * t;
                let rho = scalp_radius + (s / 4.0).min(height);
                if s < to_equator {
                    let theta = polar + s / (scalp_radius + height);
                    rho * (outward * theta.sin() + DVec3::Z * theta.cos())
                } else {
                    rho * outward - DVec3::Z * (s - to_equator)
                }
            }
        }))
    }
}

/// Makes `strands` strands of `points` points and one fiber `radius`: for each strand, `curve`
/// draws its random parameters from the generator seeded with `seed` and returns its path as a
/// function of t in [0, 1] (root to tip), sampled at evenly spaced t.
fn build<C: Fn(f64) -> DVec3>(
    strands: u32,
    points: u32,
    radius: f64,
    seed: u64,
    mut curve: impl FnMut(&mut Pcg64) -> C,
) -> Strands {
    let mut rng = Pcg64::seed_from_u64(seed);
    let total = strands as usize * points as usize;
    let mut out = Strands {
        points: Vec::with_capacity(total),
        radii: vec![radius as f32; total],
        offsets: (0..=strands).map(|s| s * points).collect(),
    };
    for _ in 0..strands {
        let path = curve(&mut rng);
        let last = f64::from(points - 1);
        out.points.extend((0..points).map(|i| path(f64::from(i) / last).as_vec3()));
    }
    out
}

/// A root (or helix axis) of a swatch: uniform over the width x depth rectangle at z = length/2.
fn swatch_root(rng: &mut Pcg64, width: f64, depth: f64, length: f64) -> DVec3 {
    DVec3::new(width * (rng.random::<f64>() - 0.5), depth * (rng.random::<f64>() - 0.5), 0.5 * length)
}

/// A direction uniform on the unit sphere (z uniform in [-1, 1], Archimedes' hat-box theorem).
fn unit_vector(rng: &mut Pcg64) -> DVec3 {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let azimuth = rng.random_range(0.0..TAU);
    let r = (1.0 - z * z).sqrt();
    DVec3::new(r * azimuth.cos(), r * azimuth.sin(), z)
}

fn check(field: &'static str, value: f64, ok: bool, problem: &'static str) -> Result<(), GenerateError> {
    if value.is_finite() && ok { Ok(()) } else { Err(GenerateError::Param { field, problem, value }) }
}

/// The fields every kind has.
fn check_common(strands: u32, points: u32, length: f64, radius: f64) -> Result<(), GenerateError> {
    check("strands", strands.into(), strands >= 1, "must be at least 1")?;
    let points_ok = (2..=MAX_STRAND_POINTS).contains(&points);
    check("points", points.into(), points_ok, "must be between 2 and 65536 (points per strand)")?;
    let total = u64::from(strands) * u64::from(points);
    check("strands", total as f64, total <= MAX_TOTAL_POINTS, "times `points` must be at most 10,000,000")?;
    check("length", length, length > 0.0, "must be finite and > 0")?;
    check("radius", radius, radius > 0.0, "must be finite and > 0")
}

fn check_swatch(width: f64, depth: f64) -> Result<(), GenerateError> {
    check("width", width, width > 0.0, "must be finite and > 0")?;
    check("depth", depth, depth >= 0.0, "must be finite and >= 0")
}
