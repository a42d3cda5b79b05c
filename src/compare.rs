//! Image comparisons over hair pixels: the measures accuracy and convergence are judged by.
//!
//! Hair pixels are those the reference covers fully (alpha 1: every camera sample hit hair), so
//! the background and the hair's silhouette, where coverage itself is noisy, stay out. Errors are
//! over all three channels of those pixels.

use crate::film::Film;

/// Indices of the pixels `reference` covers fully.
pub fn hair_pixels(reference: &Film) -> Vec<usize> {
    (0..reference.alpha.len()).filter(|&i| reference.alpha[i] >= 1.0).collect()
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
    let mse =
        pixels.iter().map(|&i| (test.mean[i] - reference.mean[i]).0.iter().map(|d| d * d).sum::<f64>()).sum::<f64>()
            / (3 * pixels.len()) as f64;
    mse.sqrt() / mean_value(reference, pixels)
}

/// The part of [`relative_rmse`] that noise alone explains: the root of the mean summed variance
/// of both images' pixel means, relative to the same mean value.
pub fn relative_noise(test: &Film, reference: &Film, pixels: &[usize]) -> f64 {
    let var = pixels.iter().map(|&i| (test.variance[i] + reference.variance[i]).0.iter().sum::<f64>()).sum::<f64>()
        / (3 * pixels.len()) as f64;
    var.sqrt() / mean_value(reference, pixels)
}
