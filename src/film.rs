//! The film: per-pixel estimates and their output as EXR (with coverage, variance and sample
//! count) and as a tone-mapped PNG.

use crate::integrator::{Term, Terms};
use crate::output::{write_atomically, write_png};
use anyhow::{Context, Result, anyhow, ensure};
use exr::prelude::*;
use precompute::spectrum::Rgb;
use std::path::Path;

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

/// Running sums of one pixel's samples.
#[derive(Clone, Copy, Default)]
pub struct PixelSums {
    pub sum: Rgb,
    pub sum_sq: Rgb,
    pub hits: u32,
}

impl PixelSums {
    pub fn add(&mut self, l: Rgb, hit: bool) {
        self.sum += l;
        self.sum_sq += l * l;
        self.hits += hit as u32;
    }
}

impl Film {
    /// The film from each pixel's sums, and its sums per term (empty when not collected).
    pub fn from_sums(width: usize, height: usize, spp: u32, sums: &[PixelSums], term_sums: &[Terms]) -> Film {
        let n = spp as f64;
        let mean: Vec<Rgb> = sums.iter().map(|s| s.sum / n).collect();
        let variance = sums
            .iter()
            .zip(&mean)
            .map(
                |(s, m)| {
                    if spp > 1 { ((s.sum_sq - *m * s.sum) / (n - 1.0) / n).map(|v| v.max(0.0)) } else { Rgb::ZERO }
                },
            )
            .collect();
        let alpha = sums.iter().map(|s| s.hits as f64 / n).collect();
        let terms = term_sums.iter().map(|s| s.map(|t| t / n)).collect();
        Film { width, height, spp, mean, alpha, variance, terms }
    }

    /// Writes R, G, B, A (coverage) as 32-bit float, plus `variance.R/G/B` (variance of each
    /// pixel's mean), `spp`, and the radiance per term when collected (`single.R`, ...,
    /// `multiback.B`; see [`Term`]) when `aovs` is set.
    pub fn write_exr(&self, path: &Path, aovs: bool) -> Result<()> {
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
        let layer = Layer::new(
            (self.width, self.height),
            LayerAttributes::named("dualhair"),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels.into()),
        );
        write_atomically(path, |tmp| Ok(Image::from_layer(layer).write().to_file(tmp)?))
    }

    /// Reads an EXR written by [`Film::write_exr`] (R, G, B and A; the variance channels and
    /// `spp` when present, else 0), checking that every channel is there and finite.
    pub fn read_exr(path: &Path) -> Result<Film> {
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
            .with_context(|| format!("{}: cannot read the EXR image", path.display()))?;
        let layer = &image.layer_data;
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
            |name: &str| channel(name)?.ok_or_else(|| anyhow!("{}: the image has no {name} channel", path.display()));
        let or_zero = |name: &str| Ok::<_, anyhow::Error>(channel(name)?.unwrap_or_else(|| vec![0.0; n]));
        let (r, g, b, a) = (need("R")?, need("G")?, need("B")?, need("A")?);
        let (vr, vg, vb) = (or_zero("variance.R")?, or_zero("variance.G")?, or_zero("variance.B")?);
        let spp = channel("spp")?.and_then(|s| s.first().copied()).unwrap_or(0.0) as u32;
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
