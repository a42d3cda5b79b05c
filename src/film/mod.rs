//! The film: per-pixel estimates and their output as EXR (with coverage, variance and sample
//! count) and as a tone-mapped PNG.

pub mod partial;

use crate::error::{Context, Result, ensure, invalid};
use crate::integrators::{Term, Terms};
use crate::output::{write_atomically, write_png};
use crate::render::{PixelSums, Sums, TermSums};
use exr::prelude::*;
use precompute::spectrum::Rgb;
use std::path::Path;

/// The first layer of an EXR file, with every channel and attribute.
pub type ExrLayer = Layer<AnyChannels<FlatSamples>>;

/// Reads the first valid layer of an EXR file.
pub fn read_exr_layer(path: &Path) -> Result<ExrLayer> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .with_context(|| format!("{}: cannot read the EXR image", path.display()))?;
    Ok(image.layer_data)
}

/// Channels and header attributes (name, value) a writer adds to a film's own.
#[derive(Default)]
pub struct ExrExtras {
    pub channels: Vec<AnyChannel<FlatSamples>>,
    pub attributes: Vec<(&'static str, AttributeValue)>,
}

/// A rendered image: per pixel the mean radiance, the hair coverage (alpha) and the variance of
/// the mean (per channel), from `spp` samples per pixel. Rows top to bottom.
pub struct Film {
    pub width: usize,
    pub height: usize,
    pub spp: u32,
    pub mean: Vec<Rgb>,
    pub alpha: Vec<f64>,
    pub variance: Vec<Rgb>,
    /// Mean radiance per [`Term`] (the diagnostic split), when the render collected it; empty
    /// otherwise.
    pub terms: Vec<Terms>,
}

impl Film {
    /// Bytes one pixel of a render holds at its peak: its sums, its film, and the EXR's 32-bit
    /// channels and the PNG's bytes as they are written (with `aovs`, the terms' sums and
    /// channels too).
    pub fn bytes_per_pixel(aovs: bool) -> u64 {
        let base = size_of::<PixelSums>() + 2 * size_of::<Rgb>() + size_of::<f64>() + 4 * 4 + 4;
        let terms = size_of::<TermSums>() + size_of::<Terms>() + 16 * 4;
        (base + if aovs { terms } else { 0 }) as u64
    }

    /// The film of some sums: per pixel the mean, its variance and the coverage.
    pub fn from_sums(sums: &Sums) -> Film {
        let spp = sums.spp();
        let n = spp.max(1) as f64;
        let mean: Vec<Rgb> = sums.pixels.iter().map(|s| s.sum.value() / n).collect();
        let variance = sums
            .pixels
            .iter()
            .zip(&mean)
            .map(|(s, m)| {
                if spp > 1 {
                    ((s.sum_sq.value() - *m * s.sum.value()) / (n - 1.0) / n).map(|v| v.max(0.0))
                } else {
                    Rgb::ZERO
                }
            })
            .collect();
        let alpha = sums.pixels.iter().map(|s| s.hits as f64 / n).collect();
        let terms = sums.terms.iter().map(|t| t.map(|t| t.value() / n)).collect();
        Film { width: sums.width, height: sums.height, spp, mean, alpha, variance, terms }
    }

    /// Writes R, G, B, A (coverage) as 32-bit float, plus `variance.R/G/B` (variance of each
    /// pixel's mean), `spp`, and the radiance per term when collected (`single.R`, ...,
    /// `multiback.B`; see [`Term`]) when `aovs` is set. The header's `spp` attribute holds the
    /// sample count.
    pub fn write_exr(&self, path: &Path, aovs: bool) -> Result<()> {
        self.write_exr_with(path, aovs, ExrExtras::default())
    }

    /// [`Film::write_exr`] with more channels and header attributes.
    pub fn write_exr_with(&self, path: &Path, aovs: bool, extras: ExrExtras) -> Result<()> {
        let f32s = |f: &dyn Fn(usize) -> f64| FlatSamples::F32((0..self.mean.len()).map(|i| f(i) as f32).collect());
        let mut channels = vec![
            AnyChannel::new("R", f32s(&|i| self.mean[i].0[0])),
            AnyChannel::new("G", f32s(&|i| self.mean[i].0[1])),
            AnyChannel::new("B", f32s(&|i| self.mean[i].0[2])),
            AnyChannel::new("A", f32s(&|i| self.alpha[i])),
        ];
        if aovs {
            for (c, name) in ["variance.R", "variance.G", "variance.B"].iter().enumerate() {
                channels.push(AnyChannel::new(*name, f32s(&|i| self.variance[i].0[c])));
            }
            channels.push(AnyChannel::new("spp", f32s(&|_| self.spp as f64)));
            for term in Term::ALL.iter().filter(|_| !self.terms.is_empty()) {
                for (c, channel) in ["R", "G", "B"].iter().enumerate() {
                    let (term, name) = (*term, format!("{}.{channel}", term.name()));
                    channels.push(AnyChannel::new(name.as_str(), f32s(&|i| self.terms[i][term as usize].0[c])));
                }
            }
        }
        channels.extend(extras.channels);
        let mut attributes = LayerAttributes::named("dualhair");
        let spp = AttributeValue::I32(self.spp.min(i32::MAX as u32) as i32);
        attributes
            .other
            .extend(std::iter::once(("spp", spp)).chain(extras.attributes).map(|(k, v)| (Text::from(k), v)));
        let layer = Layer::new(
            (self.width, self.height),
            attributes,
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels.into()),
        );
        write_atomically(path, |tmp| Ok(Image::from_layer(layer).write().to_file(tmp)?))
    }

    /// Reads an EXR written by [`Film::write_exr`] (R, G, B and A; the variance channels and
    /// the spp (header, else `spp` channel) when present, else 0), checking that every channel is there and finite.
    pub fn read_exr(path: &Path) -> Result<Film> {
        Film::from_layer(path, &read_exr_layer(path)?)
    }

    /// The film in a layer read from `path` (see [`Film::read_exr`]).
    pub fn from_layer(path: &Path, layer: &ExrLayer) -> Result<Film> {
        let (width, height) = (layer.size.width(), layer.size.height());
        let channel = |name: &str| -> Result<Option<Vec<f64>>> {
            let Some(c) = layer.channel_data.list.iter().find(|c| c.name.to_string() == name) else {
                return Ok(None);
            };
            let v: Vec<f64> = c.sample_data.values_as_f32().map(f64::from).collect();
            ensure!(v.len() == width * height, "{}: channel {name} has the wrong size", path.display());
            ensure!(v.iter().all(|x| x.is_finite()), "{}: channel {name} holds NaN or infinite values", path.display());
            Ok(Some(v))
        };
        let n = width * height;
        let need =
            |name: &str| channel(name)?.ok_or_else(|| invalid!("{}: the image has no {name} channel", path.display()));
        let or_zero = |name: &str| Ok::<_, crate::error::Error>(channel(name)?.unwrap_or_else(|| vec![0.0; n]));
        let (r, g, b, a) = (need("R")?, need("G")?, need("B")?, need("A")?);
        let (vr, vg, vb) = (or_zero("variance.R")?, or_zero("variance.G")?, or_zero("variance.B")?);
        let spp = match layer.attributes.other.get(&Text::from("spp")) {
            Some(AttributeValue::I32(n)) => (*n).max(0) as u32,
            _ => channel("spp")?.and_then(|s| s.first().copied()).unwrap_or(0.0) as u32,
        };
        let collected = channel("single.R")?.is_some();
        let mut terms = vec![Terms::default(); if collected { n } else { 0 }];
        for term in Term::ALL.iter().copied().filter(|_| collected) {
            for (c, channel) in ["R", "G", "B"].iter().enumerate() {
                for (t, v) in terms.iter_mut().zip(or_zero(&format!("{}.{channel}", term.name()))?) {
                    t[term as usize].0[c] = v;
                }
            }
        }
        Ok(Film {
            width,
            height,
            spp,
            mean: (0..n).map(|i| Rgb([r[i], g[i], b[i]])).collect(),
            alpha: a,
            variance: (0..n).map(|i| Rgb([vr[i], vg[i], vb[i]])).collect(),
            terms,
        })
    }

    /// Writes an sRGB PNG of the radiance scaled by 2^`exposure`, clipped to [0, 1].
    pub fn write_png(&self, path: &Path, exposure: f64) -> Result<()> {
        let scale = exposure.exp2();
        let encode = |v: f64| {
            let v = (v * scale).clamp(0.0, 1.0);
            let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
            (s * 255.0 + 0.5) as u8
        };
        let img = image::RgbImage::from_fn(self.width as u32, self.height as u32, |x, y| {
            image::Rgb(self.mean[y as usize * self.width + x as usize].0.map(encode))
        });
        write_png(path, &img)
    }
}
