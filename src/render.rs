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

/// Where in its pixel sample `i` goes: the first two dimensions of the Sobol sequence (a (0, 2)
/// sequence: every power-of-two prefix is stratified in every elementary interval; Kollig and
/// Keller 2002's generator for the second dimension), each XOR-scrambled by the pixel's own random
/// word, which keeps the stratification and makes each sample uniform over the pixel.
fn pixel_offset(i: u32, scramble: [u32; 2]) -> [f64; 2] {
    let first = i.reverse_bits();
    let (mut second, mut v, mut n) = (0u32, 1u32 << 31, i);
    while n != 0 {
        if n & 1 != 0 {
            second ^= v;
        }
        n >>= 1;
        v ^= v >> 1;
    }
    [first ^ scramble[0], second ^ scramble[1]].map(|b| b as f64 / 4_294_967_296.0)
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
            let scramble: [u32; 2] = rng.random();
            for i in 0..spp {
                let [dx, dy] = pixel_offset(i, scramble);
                let (o, d) = camera.ray(x as f64 + dx, y as f64 + dy);
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

#[cfg(test)]
mod tests {
    use super::pixel_offset;

    #[test]
    fn pixel_offsets_are_a_scrambled_0_2_net() {
        // Every elementary interval of area 1/16 (16x1, 8x2, 4x4, 2x8, 1x16 cells) holds exactly
        // one of the first 16 samples, scrambled or not (Niederreiter's (0, m, 2)-net property).
        for scramble in [[0, 0], [0x1234_5678, 0x9abc_def0], [u32::MAX, 7]] {
            let points: Vec<[f64; 2]> = (0..16).map(|i| pixel_offset(i, scramble)).collect();
            for k in 0..=4 {
                let (nx, ny) = (1usize << k, 1usize << (4 - k));
                let mut count = vec![0; 16];
                for p in &points {
                    assert!(p.iter().all(|c| (0.0..1.0).contains(c)));
                    count[(p[1] * ny as f64) as usize * nx + (p[0] * nx as f64) as usize] += 1;
                }
                assert!(count.iter().all(|&c| c == 1), "{nx}x{ny} cells, scramble {scramble:?}: {count:?}");
            }
        }
    }
}
