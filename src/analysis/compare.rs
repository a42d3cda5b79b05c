//! Image comparisons over hair pixels: the measures accuracy and convergence are judged by.
//!
//! Hair pixels are those the reference covers fully (alpha 1: every camera sample hit hair), so
//! the background and the hair's silhouette, where coverage itself is noisy, stay out; a pixel
//! rectangle can replace them (as the thesis's Figure 6.5 region). Errors are over all three
//! channels of those pixels, in linear radiance.

use crate::film::Film;
use precompute::spectrum::Rgb;

/// Whether a pixel counts as fully covered: every sample hit hair. Coverage is a count ratio in
/// our films; other renderers' float sums (Cycles) can miss 1 by rounding, hence the margin.
fn covered(alpha: f64) -> bool {
    alpha >= 1.0 - 1e-5
}

/// Indices of the pixels `reference` covers fully.
pub fn hair_pixels(reference: &Film) -> Vec<usize> {
    (0..reference.alpha.len()).filter(|&i| covered(reference.alpha[i])).collect()
}

/// Indices of the pixels in the rectangle [x0, x1) x [y0, y1) (clipped to the image).
pub fn rectangle(film: &Film, [x0, y0, x1, y1]: [usize; 4]) -> Vec<usize> {
    let (x1, y1) = (x1.min(film.width), y1.min(film.height));
    (y0..y1).flat_map(|y| (x0..x1).map(move |x| y * film.width + x)).collect()
}

/// Mean squared difference between two images over `pixels` and channels (the thesis's "distance
/// expressed in variance", Tables 6.1 and 6.2).
pub fn mse(a: &Film, b: &Film, pixels: &[usize]) -> f64 {
    pixels.iter().map(|&i| (a.mean[i] - b.mean[i]).0.iter().map(|d| d * d).sum::<f64>()).sum::<f64>()
        / (3 * pixels.len()) as f64
}

/// Mean over `pixels` and channels of the variance of the pixel means: the part of an [`mse`]
/// against this image that its own noise explains.
pub fn mean_variance(film: &Film, pixels: &[usize]) -> f64 {
    pixels.iter().map(|&i| film.variance[i].0.iter().sum::<f64>()).sum::<f64>() / (3 * pixels.len()) as f64
}

/// Mean luminance over `pixels`.
pub fn mean_luminance(film: &Film, pixels: &[usize]) -> f64 {
    pixels.iter().map(|&i| film.mean[i].luminance()).sum::<f64>() / pixels.len() as f64
}

/// Mean over `pixels` and channels of the reference.
fn mean_value(film: &Film, pixels: &[usize]) -> f64 {
    pixels.iter().map(|&i| film.mean[i].0.iter().sum::<f64>()).sum::<f64>() / (3 * pixels.len()) as f64
}

/// Relative RMSE of `test` against `reference`: sqrt(mean squared difference) / mean value, over
/// `pixels` and channels.
pub fn relative_rmse(test: &Film, reference: &Film, pixels: &[usize]) -> f64 {
    mse(test, reference, pixels).sqrt() / mean_value(reference, pixels)
}

/// The part of [`relative_rmse`] that noise alone explains: the root of the mean summed variance
/// of both images' pixel means, relative to the same mean value.
pub fn relative_noise(test: &Film, reference: &Film, pixels: &[usize]) -> f64 {
    (mean_variance(test, pixels) + mean_variance(reference, pixels)).sqrt() / mean_value(reference, pixels)
}

/// Means of `block` x `block` pixel blocks of `film` (mean radiance and variance of that mean
/// per channel), over the blocks `reference` covers fully, in row order.
fn block_means(film: &Film, reference: &Film, block: usize) -> Vec<(Rgb, Rgb)> {
    let (bw, bh) = (film.width / block, film.height / block);
    let n = (block * block) as f64;
    let mut out = Vec::new();
    for by in 0..bh {
        for bx in 0..bw {
            let pixels = rectangle(film, [bx * block, by * block, (bx + 1) * block, (by + 1) * block]);
            if pixels.iter().all(|&i| covered(reference.alpha[i])) {
                let sum = |v: &[Rgb]| pixels.iter().fold(Rgb::ZERO, |a, &i| a + v[i]);
                out.push((sum(&film.mean) / n, sum(&film.variance) / (n * n)));
            }
        }
    }
    out
}

/// Relative RMSE of `block` x `block` pixel block means over the blocks `reference` covers
/// fully (all channels), and the part both images' noise explains: the accuracy measure of
/// the dual-scattering accuracy tables, steadier than per-pixel errors where a pixel holds only a few fibers. `None` when
/// the reference covers no block fully.
pub fn block_relative_rmse(test: &Film, reference: &Film, block: usize) -> Option<(f64, f64)> {
    let (t, r) = (block_means(test, reference, block), block_means(reference, reference, block));
    if r.is_empty() {
        return None;
    }
    let k = (3 * r.len()) as f64;
    let mean = r.iter().map(|b| b.0.0.iter().sum::<f64>()).sum::<f64>() / k;
    let mse = t.iter().zip(&r).map(|(a, b)| (a.0 - b.0).0.iter().map(|d| d * d).sum::<f64>()).sum::<f64>() / k;
    let noise = t.iter().zip(&r).map(|(a, b)| (a.1 + b.1).0.iter().sum::<f64>()).sum::<f64>() / k;
    Some((mse.sqrt() / mean, noise.sqrt() / mean))
}

/// Relative RMS of the difference of `a`'s and `b`'s `block` x `block` block means over the
/// blocks `reference` covers fully, relative to `reference`'s mean there: for two renders that
/// differ only in their seed, sqrt(2) times either one's noise, an estimate that, unlike the
/// variance channels, holds where a few bright samples dominate a pixel (a back sun).
pub fn block_relative_difference(a: &Film, b: &Film, reference: &Film, block: usize) -> Option<f64> {
    let (a, b, r) =
        (block_means(a, reference, block), block_means(b, reference, block), block_means(reference, reference, block));
    if r.is_empty() {
        return None;
    }
    let k = (3 * r.len()) as f64;
    let mean = r.iter().map(|b| b.0.0.iter().sum::<f64>()).sum::<f64>() / k;
    let mse = a.iter().zip(&b).map(|(a, b)| (a.0 - b.0).0.iter().map(|d| d * d).sum::<f64>()).sum::<f64>() / k;
    Some(mse.sqrt() / mean)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(width: usize, values: &[f64], alpha: &[f64]) -> Film {
        Film {
            width,
            height: values.len() / width,
            spp: 1,
            mean: values.iter().map(|&v| Rgb([v, 2.0 * v, 0.0])).collect(),
            alpha: alpha.to_vec(),
            variance: vec![Rgb([0.5, 0.0, 0.25]); values.len()],
            terms: vec![[Rgb::ZERO; 4]; values.len()],
        }
    }

    #[test]
    fn measures_match_hand_computed_values() {
        // 2x2 images; the reference covers pixels 0, 1 and 3 fully.
        let reference = film(2, &[1.0, 2.0, 3.0, 4.0], &[1.0, 1.0, 0.5, 1.0]);
        let test = film(2, &[2.0, 2.0, 0.0, 1.0], &[1.0, 0.0, 1.0, 1.0]);
        let hair = hair_pixels(&reference);
        assert_eq!(hair, vec![0, 1, 3]);
        // Differences per pixel (R, G, B): (1, 2, 0), (0, 0, 0), (-3, -6, 0): squares sum to
        // 1 + 4 + 9 + 36 = 50 over 3 pixels x 3 channels.
        assert!((mse(&test, &reference, &hair) - 50.0 / 9.0).abs() < 1e-12);
        // Mean value of the reference over those pixels and channels: (3 + 6 + 12) / 9.
        assert!((relative_rmse(&test, &reference, &hair) - (50.0f64 / 9.0).sqrt() / (21.0 / 9.0)).abs() < 1e-12);
        // Variance 0.5 + 0 + 0.25 per pixel over 3 channels, from each image.
        assert!((mean_variance(&test, &hair) - 0.25).abs() < 1e-12);
        assert!((relative_noise(&test, &reference, &hair) - 0.5f64.sqrt() / (21.0 / 9.0)).abs() < 1e-12);
        let y = |v: f64| 0.2126 * v + 0.7152 * 2.0 * v;
        assert!((mean_luminance(&reference, &hair) - (y(1.0) + y(2.0) + y(4.0)) / 3.0).abs() < 1e-12);
    }

    #[test]
    fn block_errors_match_hand_computed_values() {
        // 4x2 images in 2x2 blocks; the reference covers the left block fully, the right one
        // not (its last pixel has alpha 0.5).
        let reference = film(4, &[1.0, 3.0, 1.0, 1.0, 1.0, 3.0, 1.0, 1.0], &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.5]);
        let test = film(4, &[2.0, 2.0, 9.0, 9.0, 4.0, 4.0, 9.0, 9.0], &[1.0; 8]);
        // Left block means: reference 2 (R), 4 (G), 0 (B); test 3, 6, 0. Differences 1, 2, 0.
        let (rmse, noise) = block_relative_rmse(&test, &reference, 2).unwrap();
        assert!((rmse - (5.0f64 / 3.0).sqrt() / 2.0).abs() < 1e-12, "{rmse}");
        // Each image's block-mean variance per channel is the pixel variance / 4: (0.5 + 0.25) / 4
        // summed over channels, from both images, over 3 channels.
        assert!((noise - (2.0 * 0.75 / 4.0 / 3.0f64).sqrt() / 2.0).abs() < 1e-12, "{noise}");
        // No block covered fully: no measure.
        assert!(block_relative_rmse(&test, &reference, 4).is_none());
        // Test against reference as the second image: the same block differences, relative to
        // the reference's mean; the right block still left out.
        let d = block_relative_difference(&test, &reference, &reference, 2).unwrap();
        assert!((d - (5.0f64 / 3.0).sqrt() / 2.0).abs() < 1e-12, "{d}");
        assert!(block_relative_difference(&test, &reference, &reference, 4).is_none());
    }

    #[test]
    fn a_rectangle_replaces_the_hair_mask() {
        let f = film(3, &[0.0; 6], &[0.0; 6]);
        assert!(hair_pixels(&f).is_empty());
        assert_eq!(rectangle(&f, [1, 0, 3, 2]), vec![1, 2, 4, 5]);
        // Clipped to the image.
        assert_eq!(rectangle(&f, [2, 1, 10, 10]), vec![5]);
        assert!(rectangle(&f, [2, 2, 3, 3]).is_empty());
    }
}
