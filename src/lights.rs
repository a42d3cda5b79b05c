//! Light sources: an environment (constant, or a lat-long map with importance sampling) and a sun.
//!
//! World frame: +Z is up. Lat-long maps follow Blender's Z-up convention, so HDRIs look the same
//! as there: texel column u = 1/2 - atan2(d.y, d.x) / 2pi (the center column looks toward +X),
//! row from the top at elevation +pi/2 to the bottom at -pi/2. `rotation` (degrees) turns the
//! lookup direction about +Z, as Blender's Mapping node does.
//!
//! Next-event estimation samples one light per shading point (`Lights::sample`): with a sun and an
//! environment, each is picked with a probability from their irradiance, so a
//! vertex costs one shadow ray instead of two.

use crate::error::{Context, Result, bail, invalid};
use crate::sampler::Sampler;
use glam::DVec3;
use precompute::conventions::{SPHERE, uniform_sphere};
use precompute::spectrum::Rgb;
use std::f64::consts::{PI, TAU};
use std::path::Path;

/// A direction toward a light, drawn by light sampling.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub wi: DVec3,
    /// Radiance arriving from `wi`; for a delta light, the irradiance it delivers.
    pub radiance: Rgb,
    /// Solid-angle density of `wi`; 1 for a delta light.
    pub pdf: f64,
    pub delta: bool,
}

/// A lat-long environment map with a luminance-and-area-proportional sampling distribution.
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Row by row from the top: what radiance lookups and light samples read, one record a
    /// texel, so that a light sample fetches one or two cache lines of a map of megabytes.
    texels: Vec<Texel>,
    /// Sum of the sampling weights; 0 when every weight is 0 (nothing to sample).
    total: f64,
    rotation: f64,
}

/// A texel: its radiance, its probability of being sampled, and its bin of the alias table.
#[derive(Clone, Copy)]
struct Texel {
    /// Radiance (times the map's strength), in f32 like the file's own values.
    radiance: [f32; 3],
    /// Its sampling weight over the sum of all weights, for the pdf.
    probability: f32,
    bin: AliasBin,
}

impl Texel {
    fn radiance(&self) -> Rgb {
        Rgb(self.radiance.map(f64::from))
    }
}

/// Walker's alias method, built in O(n) by Vose's algorithm (Vose 1991, "A linear algorithm for
/// generating random numbers with a given distribution"): bin i keeps outcome i with probability
/// `keep` and gives its `alias` otherwise, so a draw reads one bin where inverting a CDF searches
/// one (the environment's two binary searches were 14% of a `dual` render, perf).
#[derive(Clone, Copy)]
struct AliasBin {
    /// In f32: the probabilities it gives differ from the weights' by under 1e-7 relative.
    keep: f32,
    alias: u32,
}

/// The bins of an alias table for non-negative weights with a positive sum (at most 2^32 of
/// them).
fn alias_bins(weights: &[f64]) -> Vec<AliasBin> {
    let n = weights.len();
    let total: f64 = weights.iter().sum();
    // Each weight as a multiple of the mean: a bin holds exactly 1.
    let mut scaled: Vec<f64> = weights.iter().map(|w| w * n as f64 / total).collect();
    let mut bins = vec![AliasBin { keep: 1.0, alias: 0 }; n];
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        bins[s] = AliasBin { keep: scaled[s] as f32, alias: l as u32 };
        // The large outcome fills the rest of bin s.
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left holds 1 up to rounding: those bins keep their own outcome (keep = 1).
    bins
}

/// An outcome drawn from the alias table whose bin i is `bin(i)` (`n` bins) for `u` in [0, 1),
/// and `u` rescaled to [0, 1) within the part of the bin that chose it (a second uniform number
/// for free).
fn alias_sample(n: usize, bin: impl Fn(usize) -> AliasBin, u: f64) -> (usize, f64) {
    let x = u * n as f64;
    let i = (x as usize).min(n - 1);
    let (f, bin) = (x - i as f64, bin(i));
    let keep = bin.keep as f64;
    let (outcome, rest) = if f < keep { (i, f / keep) } else { (bin.alias as usize, (f - keep) / (1.0 - keep)) };
    (outcome, rest.clamp(0.0, 1.0 - f64::EPSILON))
}

/// Where the radiance of the sky comes from.
pub enum Environment {
    Constant(Rgb),
    Map(EnvMap),
}

/// A distant disc light. `half_angle` 0 makes it a delta (directional) light.
#[derive(Clone, Copy)]
pub struct Sun {
    /// Unit direction toward the sun.
    pub direction: DVec3,
    /// Irradiance on a surface facing the sun.
    pub irradiance: Rgb,
    pub half_angle: f64,
}

/// The least share of next-event samples either light gets when there are two. A light's share
/// of the image can exceed its share of the irradiance where the other is shadowed: `dual` under
/// a back sun, where the dim sky lights what the sun does not, was 2-2.6x less efficient with a
/// floor of 0.02 than with 1/4, while `path` gained 1.2-1.4x from 0.1
/// (docs/performance.md, "What makes `path` fast").
pub const MIN_SHARE: f64 = 0.1;

/// All lights of a scene.
pub struct Lights {
    pub environment: Option<Environment>,
    pub sun: Option<Sun>,
    /// Probability that [`Lights::sample`] samples the environment rather than the sun.
    env_share: f64,
}

impl Lights {
    /// With both lights, next-event estimation picks the environment with a probability
    /// proportional to its irradiance estimate against the sun's (as pbrt-v4's power light
    /// sampler does), never below [`MIN_SHARE`] for either.
    pub fn new(environment: Option<Environment>, sun: Option<Sun>) -> Lights {
        let env_share = match (&environment, &sun) {
            (Some(env), Some(sun)) => {
                let (e, s) = (env.irradiance(), sun.irradiance.luminance());
                if e + s > 0.0 { (e / (e + s)).clamp(MIN_SHARE, 1.0 - MIN_SHARE) } else { 0.5 }
            }
            (Some(_), None) => 1.0,
            _ => 0.0,
        };
        Lights { environment, sun, env_share }
    }

    /// One light sample for next-event estimation; its pdf includes the probability of picking
    /// that light. A random number picks the light only when there are two.
    pub fn sample(&self, sampler: &mut impl Sampler) -> Option<LightSample> {
        let pick_env = match (&self.environment, &self.sun) {
            (Some(_), Some(_)) => sampler.get_1d() < self.env_share,
            (env, _) => env.is_some(),
        };
        let (s, p) = match (pick_env, &self.environment, &self.sun) {
            (true, Some(env), _) => (env.sample(sampler.get_2d())?, self.env_share),
            (false, _, Some(sun)) => (sun.sample(sampler.get_2d()), 1.0 - self.env_share),
            _ => return None,
        };
        Some(LightSample { pdf: s.pdf * p, ..s })
    }

    /// Whether the environment is an image (rather than a constant color, or none).
    pub fn has_map(&self) -> bool {
        matches!(self.environment, Some(Environment::Map(_)))
    }

    /// Densities with which [`Lights::sample`] draws `d` from the environment and from the sun,
    /// for weighting directions that reach them by another sampler.
    pub fn pdfs(&self, d: DVec3) -> (f64, f64) {
        let env = self.environment.as_ref().map_or(0.0, |e| self.env_share * e.pdf(d));
        let sun = self.sun.as_ref().map_or(0.0, |s| (1.0 - self.env_share) * s.pdf(d));
        (env, sun)
    }
}

/// The most a compressed map can expand: deflate (EXR's ZIP and PXR24) makes at most 1032 bytes
/// of one, EXR's other compressions and Radiance's run-length encoding less. (Radiance's obsolete
/// encoding, for scanlines under 8 or over 32767 pixels, can do more, but only on a near-constant
/// map.)
const MAX_EXPANSION: u128 = 1032;

/// Refuses a map whose header says `width` x `height` pixels of `samples` bytes (uncompressed)
/// when a file of `file_len` bytes cannot hold them even at [`MAX_EXPANSION`]: such a header is
/// corrupt, and believing it would allocate gigabytes before the read fails.
fn check_size(path: &Path, width: usize, height: usize, samples: u128, file_len: usize) -> Result<()> {
    if samples > MAX_EXPANSION * file_len as u128 {
        bail!(
            "{}: the header says {width}x{height} pixels, more than a file of {file_len} bytes can hold: it is \
             corrupt or truncated",
            path.display()
        );
    }
    Ok(())
}

impl EnvMap {
    /// Loads a lat-long map from an .exr (first RGB(A) layer) or .hdr (Radiance) file.
    pub fn load(path: &Path, strength: f64, rotation_deg: f64) -> Result<EnvMap> {
        let bytes =
            std::fs::read(path).with_context(|| format!("{}: cannot read the environment map", path.display()))?;
        EnvMap::from_bytes(&bytes, path, strength, rotation_deg)
    }

    /// [`EnvMap::load`] for a file already in memory: `bytes` are its contents, `path` gives the
    /// format (by its extension) and is what errors name.
    pub fn from_bytes(bytes: &[u8], path: &Path, strength: f64, rotation_deg: f64) -> Result<EnvMap> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let (width, height, texels) = match ext.as_deref() {
            Some("exr") => {
                use exr::prelude::{ReadChannels, ReadLayers};
                // The exr crate's error already says its cause: as a context it would print twice.
                let exr_error = |e| invalid!("{}: cannot read as an EXR environment map: {e}", path.display());
                let chunks = exr::block::read(std::io::Cursor::new(bytes), false).map_err(exr_error)?;
                for header in chunks.headers().iter().filter(|h| !h.deep) {
                    let (w, h) = (header.layer_size.x(), header.layer_size.y());
                    let samples = header.channels.list.iter().map(|c| {
                        let (sx, sy) = (c.sampling.x().max(1), c.sampling.y().max(1));
                        (w / sx) as u128 * (h / sy) as u128 * c.sample_type.bytes_per_sample() as u128
                    });
                    check_size(path, w, h, samples.sum(), bytes.len())?;
                }
                let image = exr::prelude::read()
                    .no_deep_data()
                    .largest_resolution_level()
                    .rgba_channels(
                        |res, _| (res.width(), vec![Rgb::ZERO; res.width() * res.height()]),
                        |(w, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                            px[pos.y() * *w + pos.x()] = Rgb([r as f64, g as f64, b as f64])
                        },
                    )
                    .first_valid_layer()
                    .all_attributes()
                    .from_chunks(chunks)
                    .map_err(exr_error)?;
                let (w, px) = image.layer_data.channel_data.pixels;
                (w, px.len() / w.max(1), px)
            }
            Some("hdr") => {
                use image::ImageDecoder;
                // As for EXR: the image crate's decoding errors print their cause themselves.
                let hdr_error = |e| invalid!("{}: cannot read as a Radiance HDR environment map: {e}", path.display());
                let (w, h) = image::codecs::hdr::HdrDecoder::new(bytes).map_err(hdr_error)?.dimensions();
                check_size(path, w as usize, h as usize, 4 * w as u128 * h as u128, bytes.len())?;
                let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Hdr)
                    .map_err(hdr_error)?
                    .into_rgb32f();
                let px = img.pixels().map(|p| Rgb(p.0.map(|c| c as f64))).collect();
                (img.width() as usize, img.height() as usize, px)
            }
            _ => bail!("{}: environment maps must be .exr or .hdr files", path.display()),
        };
        if width < 2 || height < 1 {
            bail!("{}: an environment map needs at least 2x1 pixels, got {width}x{height}", path.display());
        }
        if let Some(i) = texels.iter().position(|t| !t.is_finite()) {
            bail!(
                "{}: pixel ({}, {}) is {:?}; radiance must be finite",
                path.display(),
                i % width,
                i / width,
                texels[i].0
            );
        }
        // Lossy EXR compression (DWA) leaves small negative values; radiance cannot be negative.
        let texels = texels.into_iter().map(|t| t.map(|c| c.max(0.0)) * strength).collect();
        Ok(EnvMap::new(width, height, texels, rotation_deg))
    }

    fn new(width: usize, height: usize, texels: Vec<Rgb>, rotation_deg: f64) -> EnvMap {
        // Weight of a texel: its luminance times the solid angle of its row (proportional to cos
        // of the elevation at the row's center).
        let weights: Vec<f64> = texels
            .iter()
            .enumerate()
            .map(|(i, t)| t.luminance() * ((0.5 - ((i / width) as f64 + 0.5) / height as f64) * PI).cos())
            .collect();
        let total: f64 = weights.iter().sum();
        let bins =
            if total > 0.0 { alias_bins(&weights) } else { vec![AliasBin { keep: 1.0, alias: 0 }; weights.len()] };
        let texels = texels
            .iter()
            .zip(&weights)
            .zip(bins)
            .map(|((t, w), bin)| Texel {
                radiance: t.0.map(|c| c as f32),
                probability: if total > 0.0 { (w / total) as f32 } else { 0.0 },
                bin,
            })
            .collect();
        EnvMap { width, height, texels, total, rotation: rotation_deg.to_radians() }
    }

    /// The brightest channel of any texel (as stored, in f32: infinite where the strength took
    /// it beyond f32's range).
    pub fn brightest(&self) -> f64 {
        self.texels.iter().flat_map(|t| t.radiance).fold(0.0, |m, c| m.max(c as f64))
    }

    /// Continuous map coordinates (u right, v down, both in [0, 1)) of a world direction.
    /// Blender's orientation (Cycles' `direction_to_equirectangular`: u = 0.5 - atan2(y, x) / 2 pi,
    /// so the center column looks toward +X); `rotation` turns the lookup direction about +Z as
    /// Blender's Mapping node does (checked against Cycles renders: docs/cycles.md).
    fn uv(&self, d: DVec3) -> (f64, f64) {
        let phi = d.y.atan2(d.x) + self.rotation;
        let u = (0.5 - phi / TAU).rem_euclid(1.0);
        let v = 0.5 - d.z.clamp(-1.0, 1.0).asin() / PI;
        (u, v.clamp(0.0, 1.0))
    }

    fn direction(&self, u: f64, v: f64) -> DVec3 {
        let phi = (0.5 - u) * TAU - self.rotation;
        let elevation = (0.5 - v) * PI;
        let (se, ce) = elevation.sin_cos();
        DVec3::new(phi.cos() * ce, phi.sin() * ce, se)
    }

    fn texel(&self, u: f64, v: f64) -> usize {
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((v * self.height as f64) as usize).min(self.height - 1);
        y * self.width + x
    }

    fn radiance(&self, d: DVec3) -> Rgb {
        let (u, v) = self.uv(d);
        self.texels[self.texel(u, v)].radiance()
    }

    /// Density per solid angle: the texel's share of the weight, spread uniformly over its (u, v)
    /// cell, times the Jacobian 1 / (2 pi^2 cos(elevation)) of the lat-long map.
    fn pdf(&self, d: DVec3) -> f64 {
        let (u, v) = self.uv(d);
        self.texel_pdf(self.texel(u, v), v)
    }

    /// The density per solid angle at map row coordinate `v` in texel `i`.
    fn texel_pdf(&self, i: usize, v: f64) -> f64 {
        let p_uv = self.texels[i].probability as f64 * (self.width * self.height) as f64;
        let cos_e = ((0.5 - v) * PI).cos();
        if cos_e <= 0.0 { 0.0 } else { p_uv / (2.0 * PI * PI * cos_e) }
    }

    /// A texel drawn by its probability, then a point uniform in it; its radiance and pdf are the
    /// texel's own (no lookup of the direction back into the map).
    fn sample(&self, u: [f64; 2]) -> Option<LightSample> {
        if self.total <= 0.0 {
            return None;
        }
        let (i, ry) = alias_sample(self.texels.len(), |i| self.texels[i].bin, u[0]);
        let (x, y) = (i % self.width, i / self.width);
        let (mu, mv) = ((x as f64 + u[1]) / self.width as f64, (y as f64 + ry) / self.height as f64);
        let pdf = self.texel_pdf(i, mv);
        let radiance = self.texels[i].radiance();
        (pdf > 0.0).then(|| LightSample { wi: self.direction(mu, mv), radiance, pdf, delta: false })
    }
}

impl Environment {
    /// Irradiance (luminance) it delivers on average to a surface: pi times its mean radiance.
    fn irradiance(&self) -> f64 {
        match self {
            Environment::Constant(c) => PI * c.luminance(),
            // `total` sums luminance x cos(elevation) over texels of solid angle
            // (2 pi / width)(pi / height) cos(elevation); the sphere is 4 pi.
            Environment::Map(m) => PI * m.total * 2.0 * PI * PI / (m.width * m.height) as f64 / (4.0 * PI),
        }
    }

    pub fn radiance(&self, d: DVec3) -> Rgb {
        match self {
            Environment::Constant(c) => *c,
            Environment::Map(m) => m.radiance(d),
        }
    }

    pub fn pdf(&self, d: DVec3) -> f64 {
        match self {
            Environment::Constant(_) => 1.0 / SPHERE,
            Environment::Map(m) => m.pdf(d),
        }
    }

    pub fn sample(&self, u: [f64; 2]) -> Option<LightSample> {
        match self {
            Environment::Constant(c) => {
                Some(LightSample { wi: uniform_sphere(u), radiance: *c, pdf: 1.0 / SPHERE, delta: false })
            }
            Environment::Map(m) => m.sample(u),
        }
    }
}

impl Sun {
    fn solid_angle(&self) -> f64 {
        TAU * (1.0 - self.half_angle.cos())
    }

    /// Radiance of the disc: irradiance / (pi sin^2(half angle)) for a uniform disc.
    fn disc_radiance(&self) -> Rgb {
        self.irradiance / (PI * self.half_angle.sin().powi(2))
    }

    fn in_disc(&self, d: DVec3) -> bool {
        self.half_angle > 0.0 && d.dot(self.direction) >= self.half_angle.cos()
    }

    pub fn radiance(&self, d: DVec3) -> Rgb {
        if self.in_disc(d) { self.disc_radiance() } else { Rgb::ZERO }
    }

    pub fn pdf(&self, d: DVec3) -> f64 {
        if self.in_disc(d) { 1.0 / self.solid_angle() } else { 0.0 }
    }

    /// Uniform over the disc's cone (or the exact direction for a delta sun).
    pub fn sample(&self, u: [f64; 2]) -> LightSample {
        if self.half_angle <= 0.0 {
            return LightSample { wi: self.direction, radiance: self.irradiance, pdf: 1.0, delta: true };
        }
        let cos_t = 1.0 - u[0] * (1.0 - self.half_angle.cos());
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (s, c) = (TAU * u[1]).sin_cos();
        let (t1, t2) = self.direction.any_orthonormal_pair();
        let wi = (t1 * (c * sin_t) + t2 * (s * sin_t) + self.direction * cos_t).normalize();
        LightSample { wi, radiance: self.disc_radiance(), pdf: 1.0 / self.solid_angle(), delta: false }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_map_is_named_with_its_cause_once() {
        for name in ["missing.exr", "missing.hdr"] {
            let path = std::env::temp_dir().join("dualhair-no-such-dir").join(name);
            let message = format!("{:#}", EnvMap::load(&path, 1.0, 0.0).err().expect("a missing file is an error"));
            assert!(message.starts_with(&path.display().to_string()), "{message}");
            assert_eq!(message.matches("os error 2").count(), 1, "{message}");
        }
    }

    /// A small map with a bright spot, so the distribution is far from uniform.
    fn spotty_map() -> EnvMap {
        let (w, h) = (16, 8);
        let texels = (0..w * h)
            .map(|i| Rgb::splat(if i % w == 5 && i / w == 2 { 50.0 } else { 0.1 + (i % 7) as f64 * 0.1 }))
            .collect();
        EnvMap::new(w, h, texels, 30.0)
    }

    #[test]
    fn env_pdf_integrates_to_one_and_matches_sampling() {
        let map = spotty_map();
        // Integral of the pdf over the sphere by a fine midpoint rule in (u, v).
        let n = 800;
        let mut total = 0.0;
        for j in 0..n {
            let v = (j as f64 + 0.5) / n as f64;
            for i in 0..2 * n {
                let u = (i as f64 + 0.5) / (2 * n) as f64;
                let d = map.direction(u, v);
                total += map.pdf(d) * ((0.5 - v) * PI).cos() * (PI / n as f64) * (TAU / (2 * n) as f64);
            }
        }
        assert!((total - 1.0).abs() < 2e-3, "pdf integrates to {total}");
        // E[L / pdf] over light samples is the integral of the radiance, which the midpoint rule gives too.
        let mut integral = 0.0;
        for j in 0..n {
            let v = (j as f64 + 0.5) / n as f64;
            for i in 0..2 * n {
                let u = (i as f64 + 0.5) / (2 * n) as f64;
                integral += map.radiance(map.direction(u, v)).0[0]
                    * ((0.5 - v) * PI).cos()
                    * (PI / n as f64)
                    * (TAU / (2 * n) as f64);
            }
        }
        let m = 200_000;
        let mut estimate = 0.0;
        for k in 0..m {
            let u = [((k as f64 + 0.5) / m as f64), ((k as f64 * 0.618_033_988_749_895) % 1.0)];
            let s = map.sample(u).unwrap();
            estimate += s.radiance.0[0] / s.pdf / m as f64;
        }
        assert!((estimate - integral).abs() < 0.01 * integral, "{estimate} vs {integral}");
    }

    #[test]
    fn alias_table_gives_each_outcome_its_probability() {
        // The probability of outcome i is its own bin's keep plus what other bins give it as their
        // alias, each bin drawn with 1/n; it must be weight_i / total. Zero weights never come out.
        for weights in [
            vec![1.0, 2.0, 3.0, 4.0],
            vec![0.0, 5.0, 0.0, 1e-9, 1.0],
            (0..1000).map(|i| ((i * 7919) % 101) as f64 * if i % 13 == 0 { 100.0 } else { 1.0 }).collect(),
        ] {
            let bins = alias_bins(&weights);
            let n = weights.len() as f64;
            let mut got = vec![0.0; weights.len()];
            for (i, bin) in bins.iter().enumerate() {
                got[i] += bin.keep as f64 / n;
                got[bin.alias as usize] += (1.0 - bin.keep as f64) / n;
            }
            let total: f64 = weights.iter().sum();
            for (i, (g, w)) in got.iter().zip(&weights).enumerate() {
                assert!((g - w / total).abs() <= 1e-7 * (w / total) + 1e-12, "outcome {i}: {g} vs {}", w / total);
            }
            // Draws land on outcomes with weight, and the rescaled number stays in [0, 1).
            for k in 0..10_000 {
                let (i, rest) = alias_sample(bins.len(), |i| bins[i], (k as f64 + 0.5) / 10_000.0);
                assert!(weights[i] > 0.0 && (0.0..1.0).contains(&rest), "{i} {rest}");
            }
        }
    }

    #[test]
    fn env_samples_carry_the_pdf_of_their_direction() {
        // MIS weighs a light sample's pdf against `pdf(wi)` of other strategies: the two agree.
        let map = spotty_map();
        for k in 0..20_000 {
            let u = [(k as f64 + 0.5) / 20_000.0, (k as f64 * 0.618_033_988_749_895) % 1.0];
            let s = map.sample(u).unwrap();
            let (p, l) = (map.pdf(s.wi), map.radiance(s.wi));
            assert!((p - s.pdf).abs() <= 1e-9 * p, "{} vs {p}", s.pdf);
            assert_eq!(l.0, s.radiance.0);
        }
    }

    #[test]
    fn lat_long_round_trip_and_orientation() {
        let map = spotty_map();
        for (u, v) in [(0.1, 0.2), (0.5, 0.5), (0.93, 0.77)] {
            let (u2, v2) = map.uv(map.direction(u, v));
            assert!((u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12);
        }
        // Top row is up; with rotation 0 the map's center column looks toward +X and u grows
        // toward -Y, as in Blender (Cycles' kernel/camera/projection.h: u = 0.5 - atan2(y, x) / 2 pi).
        let plain = EnvMap::new(4, 2, vec![Rgb::ONE; 8], 0.0);
        assert!(plain.direction(0.3, 0.0).z > 0.999);
        assert!((plain.direction(0.5, 0.5) - DVec3::X).length() < 1e-12);
        assert!((plain.direction(0.75, 0.5) - DVec3::NEG_Y).length() < 1e-12);
        // A rotation of 90 degrees turns the lookup direction by +90 degrees about +Z (Blender's
        // Mapping node): the direction that reads the center column is then -Y.
        let turned = EnvMap::new(4, 2, vec![Rgb::ONE; 8], 90.0);
        assert!((turned.direction(0.5, 0.5) - DVec3::NEG_Y).length() < 1e-12);
    }

    #[test]
    fn picking_one_light_estimates_both() {
        // The mean of L / pdf over Lights::sample is the integral of all radiance over the
        // sphere: 4 pi c for a constant sky plus irradiance x solid angle / (pi sin^2) for the disc.
        use rand::SeedableRng;
        let sun =
            Sun { direction: DVec3::new(0.2, 1.0, 0.35).normalize(), irradiance: Rgb::splat(3.0), half_angle: 0.1 };
        let want = 4.0 * PI * 0.3 + 3.0 * sun.solid_angle() / (PI * 0.1f64.sin().powi(2));
        // The sky's irradiance is pi 0.3 against the sun's 3; a sky a hundred times dimmer gets
        // the floor.
        let lights = Lights::new(Some(Environment::Constant(Rgb::splat(0.3))), Some(sun));
        let share = PI * 0.3 / (PI * 0.3 + 3.0);
        assert!((lights.env_share - share).abs() < 1e-15, "share {} vs {share}", lights.env_share);
        let dim = Lights::new(Some(Environment::Constant(Rgb::splat(3e-3))), Some(sun));
        assert_eq!(dim.env_share, MIN_SHARE);
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let m = 400_000;
        let estimate =
            (0..m).filter_map(|_| lights.sample(&mut rng)).map(|s| s.radiance.0[0] / s.pdf).sum::<f64>() / m as f64;
        assert!((estimate - want).abs() < 0.01 * want, "{estimate} vs {want}");
        // The densities other samplers weigh against are those the samples were drawn with.
        for _ in 0..1000 {
            let s = lights.sample(&mut rng).unwrap();
            let (env, sun) = lights.pdfs(s.wi);
            assert!([env, sun].iter().any(|p| (p - s.pdf).abs() <= 1e-12 * s.pdf), "{} vs {env}, {sun}", s.pdf);
        }
    }

    #[test]
    fn sun_delivers_its_irradiance() {
        // Integral of radiance * cos over the disc, for a surface facing the sun, equals irradiance.
        let sun =
            Sun { direction: DVec3::new(0.3, -0.2, 0.9).normalize(), irradiance: Rgb::splat(3.0), half_angle: 0.05 };
        let m = 100_000;
        let e: f64 = (0..m)
            .map(|k| {
                let s = sun.sample([(k as f64 + 0.5) / m as f64, (k as f64 * 0.754_877_666) % 1.0]);
                s.radiance.0[0] * s.wi.dot(sun.direction) / s.pdf
            })
            .sum::<f64>()
            / m as f64;
        assert!((e - 3.0).abs() < 1e-3, "{e}");
    }
}
