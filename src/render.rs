//! The render loop: rows in parallel, one deterministic random stream per pixel.
//!
//! Each pixel's samples come from its own PCG stream seeded by (seed, pixel index), and each
//! pixel's sums are accumulated in sample order by one thread, so an image depends only on the
//! seed, never on the thread count or scheduling.

use crate::camera::Camera;
use crate::film::{Film, PixelSums};
use crate::integrator::{Integrator, Terms};
use indicatif::{ProgressBar, ProgressStyle};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

/// SplitMix64 finalizer: decorrelates the seeds of neighbouring pixels.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

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
            let mut rng = Pcg64Mcg::seed_from_u64(mix(seed ^ mix((y * w + x) as u64)));
            for _ in 0..spp {
                let (o, d) = camera.ray(x as f64 + rng.random::<f64>(), y as f64 + rng.random::<f64>());
                let s = tracer.radiance(o, d, &mut rng);
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
