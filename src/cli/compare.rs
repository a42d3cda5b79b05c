//! `dualhair compare`: how far one image is from another over the hair, in the measures the
//! docs' tables use (mean ratio, per-pixel and 4x4-block relative RMSE).

use crate::say;
use anyhow::{Result, bail, ensure};
use dualhair::analysis::compare::{block_relative_rmse, hair_pixels, mean_luminance, relative_noise, relative_rmse};
use dualhair::film::Film;
use std::path::PathBuf;

/// Compares TEST against REFERENCE over the pixels REFERENCE covers fully (alpha 1). Prints one
/// JSON object: mean luminance of each and their ratio, relative RMSE per pixel and of BLOCK x
/// BLOCK block means over the blocks REFERENCE covers fully (with the part the images' own noise
/// explains when they carry variance channels, as `dualhair render --aovs` writes them), and the
/// pixel count.
#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// The image under test (EXR with R, G, B, A).
    pub test: PathBuf,
    /// The reference image (EXR with R, G, B, A); its alpha picks the pixels compared.
    pub reference: PathBuf,
    /// Block size for the block relative RMSE.
    #[arg(long, default_value_t = 4)]
    pub block: usize,
}

pub fn run(args: &CompareArgs) -> Result<()> {
    ensure!(args.block >= 1, "--block must be at least 1");
    let (test, reference) = (Film::read_exr(&args.test)?, Film::read_exr(&args.reference)?);
    if (test.width, test.height) != (reference.width, reference.height) {
        bail!(
            "{} is {}x{} but {} is {}x{}",
            args.test.display(),
            test.width,
            test.height,
            args.reference.display(),
            reference.width,
            reference.height
        );
    }
    let pixels = hair_pixels(&reference);
    ensure!(!pixels.is_empty(), "{}: no pixel is fully covered by hair (alpha 1)", args.reference.display());
    let (pixel_rmse, pixel_noise) =
        (relative_rmse(&test, &reference, &pixels), relative_noise(&test, &reference, &pixels));
    let blocks = block_relative_rmse(&test, &reference, args.block);
    let (test_mean, reference_mean) = (mean_luminance(&test, &pixels), mean_luminance(&reference, &pixels));
    let report = serde_json::json!({
        "test": args.test,
        "reference": args.reference,
        "pixels": pixels.len(),
        "test_mean_luminance": test_mean,
        "reference_mean_luminance": reference_mean,
        "mean_ratio": test_mean / reference_mean,
        "pixel_rel_rmse": pixel_rmse,
        "pixel_rel_noise": pixel_noise,
        "block": args.block,
        "block_rel_rmse": blocks.map(|b| b.0),
        "block_rel_noise": blocks.map(|b| b.1),
    });
    say!("{}", serde_json::to_string_pretty(&report)?)?;
    Ok(())
}
