//! The render loop: rows in parallel, one deterministic sampler per pixel.
//!
//! Each pixel's samples draw their numbers from the pixel's own [`PixelSampler`] (a function of
//! seed, pixel, sample index and request), and each pixel's sums are accumulated in sample order
//! by one thread, so an image depends only on the seed, never on the thread count or scheduling.

use crate::camera::Camera;
use crate::film::{Film, PixelSums};
use crate::integrator::{Integrator, Terms};
use crate::sampler::PixelSampler;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

/// Renders `spp` box-filtered samples per pixel; `progress` shows a bar with ETA on a terminal;
/// `terms` also collects each pixel's light per term.
pub fn render(camera: &Camera, tracer: &impl Integrator, spp: u32, seed: u64, progress: bool, terms: bool) -> Film {
    let (w, h) = (camera.width, camera.height);
    let bar = if progress { ProgressBar::new(h as u64) } else { ProgressBar::hidden() };
    bar.set_style(
        ProgressStyle::with_template("{spinner} rendering [{bar:40}] {pos}/{len} rows, {elapsed} elapsed, ETA {eta}")
            .expect("static progress template")
            .progress_chars("=> "),
    );
    let mut sums = vec![PixelSums::default(); w * h];
    let mut term_sums: Vec<Terms> = vec![Terms::default(); if terms { w * h } else { 0 }];
    let row = |y: usize, row: &mut [PixelSums], terms: &mut [Terms]| {
        for (x, px) in row.iter_mut().enumerate() {
            let mut sampler = PixelSampler::new(seed, (y * w + x) as u64);
            for i in 0..spp {
                sampler.start(i);
                let [dx, dy] = sampler.pixel_position();
                let (o, d) = camera.ray(x as f64 + dx, y as f64 + dy);
                let s = tracer.radiance(o, d, &mut sampler);
                px.add(s.radiance, s.hit_hair);
                if let Some(t) = terms.get_mut(x) {
                    t.iter_mut().zip(&s.terms).for_each(|(t, l)| *t += *l);
                }
            }
        }
        bar.inc(1);
    };
    if terms {
        let rows = sums.par_chunks_mut(w).zip(term_sums.par_chunks_mut(w));
        rows.enumerate().for_each(|(y, (r, t))| row(y, r, t));
    } else {
        sums.par_chunks_mut(w).enumerate().for_each(|(y, r)| row(y, r, &mut []));
    }
    bar.finish_and_clear();
    Film::from_sums(w, h, spp, &sums, &term_sums)
}
