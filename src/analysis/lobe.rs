//! Lat-long images of a fiber's scattering lobe (`dualhair lobe`, `dualhair fibersim`).

use crate::analysis::plot::HeatMap;
use crate::error::Result;
use crate::output::{ImageFormat, write_exr, write_png};
use precompute::lobe::LobeImage;
use std::path::Path;

/// Writes a lat-long lobe image (this command's or `fibersim`'s): `.exr` as linear RGB, `.png` as
/// a log-scale heat map of its luminance titled `title`, the color bar labeled `bar_label`.
pub fn write_lobe_image(path: &Path, image: &LobeImage, title: &str, bar_label: &str) -> Result<()> {
    match ImageFormat::from_path(path)? {
        ImageFormat::Exr => {
            let pixels: Vec<[f32; 3]> = image.pixels.iter().map(|p| p.0.map(|c| c as f32)).collect();
            write_exr(path, image.width, image.height, &pixels)
        }
        ImageFormat::Png => {
            let values: Vec<f64> = image.pixels.iter().map(|p| p.luminance()).collect();
            write_png(path, &HeatMap::lat_long(title, bar_label, image.width, image.height, &values).draw()?)
        }
    }
}
