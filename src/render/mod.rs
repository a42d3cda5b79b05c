//! The render loop: progressive passes over the image, rows in parallel, one deterministic sampler
//! per pixel.
//!
//! Sample `i` of a pixel draws its numbers from the pixel's own [`PixelSampler`] (a function of
//! seed, pixel, sample index and request), and every sum is kept in fixed point ([`Exact`]), where
//! addition is exact and so associative: an image depends only on the seed and the set of samples,
//! never on the thread count, on how the samples were cut into passes, or on whether they were
//! rendered in one process, resumed after an interrupt, or split across machines and merged.

pub mod interrupt;

use crate::camera::Camera;
use crate::integrators::Integrator;
use crate::progress::Progress;
use crate::sampler::PixelSampler;
use precompute::spectrum::Rgb;
use rayon::prelude::*;
use std::ops::Range;
use std::time::Instant;

/// Fixed-point scale of [`Exact`]: 2^60 units per unit of radiance. A sample is truncated to
/// 2^-60 (8.7e-19, far below f32's resolution of any stored value), and sums saturate at
/// i128::MAX / 2^60 = 1.5e20, so a pixel may take 1e9 samples of radiance 1e5 before its sum of
/// squares does.
const SCALE: f64 = (1u64 << 60) as f64;

/// The largest sum a pixel holds, i128::MAX / 2^60 = 1.5e20: beyond it a sum saturates.
pub const SUM_CEILING: f64 = i128::MAX as f64 / SCALE;

/// `v` in units of 2^-60, truncated toward zero (deterministic like any rounding, and one
/// instruction where the value fits in an i64, as all but huge radiances do; the f64-to-i128
/// conversion is a library call).
fn fixed(v: f64) -> i128 {
    let x = v * SCALE;
    if x.abs() < 9.2e18 {
        x as i64 as i128
    } else if x.is_nan() {
        i128::MAX
    } else {
        x as i128 // saturates
    }
}

/// A sum of RGB values in fixed point (see `SCALE`). A non-finite sample saturates (NaN counts
/// as +inf) rather than vanishing, so a broken sample shows as a bright pixel, not lost light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Exact(pub [i128; 3]);

impl Exact {
    fn add_value(&mut self, v: Rgb) {
        for (s, v) in self.0.iter_mut().zip(v.0) {
            *s = s.saturating_add(fixed(v));
        }
    }

    fn add(&mut self, other: &Exact) {
        for (s, o) in self.0.iter_mut().zip(other.0) {
            *s = s.saturating_add(o);
        }
    }

    /// The sum as a floating-point value.
    pub fn value(&self) -> Rgb {
        Rgb(self.0.map(|s| s as f64 / SCALE))
    }
}

/// Running sums of one pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelSums {
    pub sum: Exact,
    pub sum_sq: Exact,
    pub hits: u32,
}

impl PixelSums {
    fn add_sample(&mut self, l: Rgb, hit: bool) {
        self.sum.add_value(l);
        self.sum_sq.add_value(l * l);
        self.hits += hit as u32;
    }

    fn add(&mut self, other: &PixelSums) {
        self.sum.add(&other.sum);
        self.sum_sq.add(&other.sum_sq);
        self.hits += other.hits;
    }
}

/// Per pixel, the sums of its light per dual-scattering term ([`crate::integrators::Term`]).
pub type TermSums = [Exact; 4];

/// The sums of an image's samples `samples` (the same range for every pixel). Rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Sums {
    pub width: usize,
    pub height: usize,
    pub samples: Range<u32>,
    pub pixels: Vec<PixelSums>,
    /// Per pixel, when the render collects the split into terms; empty otherwise.
    pub terms: Vec<TermSums>,
}

impl Sums {
    /// No samples yet: a render that will start at sample `start`.
    pub fn empty(width: usize, height: usize, start: u32, terms: bool) -> Sums {
        let n = width * height;
        Sums {
            width,
            height,
            samples: start..start,
            pixels: vec![PixelSums::default(); n],
            terms: vec![TermSums::default(); if terms { n } else { 0 }],
        }
    }

    pub fn spp(&self) -> u32 {
        self.samples.len() as u32
    }

    /// Pixels whose sum or sum of squares saturated (a sample beyond [`SUM_CEILING`] in all, a
    /// NaN or infinite sample): their value or variance is clipped.
    pub fn saturated_pixels(&self) -> usize {
        let full = |e: &Exact| e.0.iter().any(|&s| s == i128::MAX || s == i128::MIN);
        self.pixels.iter().filter(|p| full(&p.sum) || full(&p.sum_sq)).count()
    }

    /// Adds the sums of the samples that follow this one's (`other.samples.start ==
    /// self.samples.end`, same size and terms: the caller checks).
    pub fn append(&mut self, other: &Sums) {
        debug_assert_eq!(self.samples.end, other.samples.start);
        self.pixels.par_iter_mut().zip(&other.pixels).for_each(|(a, b)| a.add(b));
        self.terms.par_iter_mut().zip(&other.terms).for_each(|(a, b)| a.iter_mut().zip(b).for_each(|(a, b)| a.add(b)));
        self.samples.end = other.samples.end;
    }

    fn clear(&mut self, samples: Range<u32>) {
        self.pixels.par_iter_mut().for_each(|p| *p = PixelSums::default());
        self.terms.par_iter_mut().for_each(|t| *t = TermSums::default());
        self.samples = samples;
    }
}

/// Renders the samples `sums.samples.end..end` into `sums`, in passes. Returns whether it got to
/// `end`: after an interrupt ([`interrupt::requested`]) it drops the unfinished pass, so `sums`
/// holds only finished samples. Reports rows done to `progress`.
pub fn render(
    camera: &Camera,
    tracer: &impl Integrator,
    seed: u64,
    sums: &mut Sums,
    end: u32,
    progress: &dyn Progress,
) -> bool {
    let (w, h) = (camera.width, camera.height);
    assert_eq!((sums.width, sums.height), (w, h), "sums of another image size");
    let todo = end.saturating_sub(sums.samples.end);
    let task = progress.task("rendering", Some(todo as u64 * h as u64));
    let mut pass = Sums::empty(w, h, 0, !sums.terms.is_empty());
    let (start, mut size) = (Instant::now(), 1);
    while sums.samples.end < end && !interrupt::requested() {
        let samples = sums.samples.end..(sums.samples.end + size).min(end);
        task.status(&format!("{} of {end} spp", samples.end));
        pass.clear(samples.clone());
        let pass_start = Instant::now();
        let row = |y: usize, row: &mut [PixelSums], terms: &mut [TermSums]| {
            if interrupt::requested() {
                return;
            }
            for (x, px) in row.iter_mut().enumerate() {
                let mut sampler = PixelSampler::new(seed, (y * w + x) as u64);
                for i in samples.clone() {
                    sampler.start(i);
                    let [dx, dy] = sampler.pixel_position();
                    let (o, d) = camera.ray(x as f64 + dx, y as f64 + dy);
                    let s = tracer.radiance(o, d, &mut sampler);
                    px.add_sample(s.radiance, s.hit_hair);
                    if let Some(t) = terms.get_mut(x) {
                        t.iter_mut().zip(&s.terms).for_each(|(t, l)| t.add_value(*l));
                    }
                }
            }
            task.advance(samples.len() as u64);
        };
        if pass.terms.is_empty() {
            pass.pixels.par_chunks_mut(w).enumerate().for_each(|(y, r)| row(y, r, &mut []));
        } else {
            let rows = pass.pixels.par_chunks_mut(w).zip(pass.terms.par_chunks_mut(w));
            rows.enumerate().for_each(|(y, (r, t))| row(y, r, t));
        }
        if interrupt::requested() {
            break;
        }
        sums.append(&pass);
        size = next_pass_size(size, pass_start.elapsed().as_secs_f64(), start.elapsed().as_secs_f64());
    }
    drop(task);
    sums.samples.end >= end
}

/// The spp of the next pass after one of `size` spp took `seconds`, `elapsed` seconds into the
/// render: passes of about a tenth of the time so far (1 s to 60 s), so an interrupt loses little,
/// growing at most 4x at a time. Timing only decides where passes end, never the image.
fn next_pass_size(size: u32, seconds: f64, elapsed: f64) -> u32 {
    let target = (0.1 * elapsed).clamp(1.0, 60.0);
    let per_sample = seconds.max(1e-6) / size as f64;
    ((target / per_sample) as u32).clamp(1, size.saturating_mul(4))
}

/// Renders samples `0..spp` in one go (no interrupt handling beyond [`render`]'s): what tests and
/// benchmarks time. Returns `None` when interrupted.
pub fn render_all(camera: &Camera, tracer: &impl Integrator, spp: u32, seed: u64, terms: bool) -> Option<Sums> {
    let mut sums = Sums::empty(camera.width, camera.height, 0, terms);
    render(camera, tracer, seed, &mut sums, spp, &crate::progress::Silent).then_some(sums)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_point_sums_are_exact_and_saturate() {
        let mut a = Exact::default();
        for v in [0.1, 0.2, 0.3] {
            a.add_value(Rgb([v, -v, 1e-19]));
        }
        // 0.1 + 0.2 + 0.3 in fixed point is the sum of the three rounded values, whatever order.
        let mut b = Exact::default();
        for v in [0.3, 0.1, 0.2] {
            b.add_value(Rgb([v, -v, 1e-19]));
        }
        assert_eq!(a, b);
        assert!((a.value().0[0] - 0.6).abs() < 1e-17 && (a.value().0[1] + 0.6).abs() < 1e-17);
        let mut c = Exact::default();
        c.add_value(Rgb([f64::INFINITY, f64::NAN, f64::NEG_INFINITY]));
        c.add_value(Rgb([1.0, 1.0, -1.0]));
        assert_eq!(c.0, [i128::MAX, i128::MAX, i128::MIN]);
    }

    #[test]
    fn passes_stay_between_one_spp_and_four_times_the_last() {
        assert_eq!(next_pass_size(1, 1e-3, 0.0), 4);
        assert_eq!(next_pass_size(8, 100.0, 10.0), 1);
        // 10 ms per spp, 200 s in: a 20 s pass is 2000 spp, but at most 4x the last one.
        assert_eq!(next_pass_size(1000, 10.0, 200.0), 2000);
        assert_eq!(next_pass_size(100, 1.0, 200.0), 400);
    }
}
