//! `dualhair calibrate`: the flags of a calibration ([`dualhair::analysis::calibrate`]).

use crate::cli::progress::Terminal;
use crate::say;
use anyhow::{Result, ensure};
use dualhair::analysis::calibrate::{calibrate, write_factors};
use dualhair::film::Film;
use dualhair::integrators::dual::cache::Cache;
use dualhair::scene::{Overrides, SceneFile};
use std::path::PathBuf;

/// Fits d_f and d_b of `dual` to a path-traced reference of the scene (least squares over hair
/// pixels), prints them with the error before and after, and can write them into the scene file.
#[derive(clap::Args, Debug)]
pub struct CalibrateArgs {
    /// Scene file (.json).
    pub scene: PathBuf,
    /// Samples per pixel of the path-traced reference.
    #[arg(long, default_value_t = 1024)]
    pub reference_spp: u32,
    /// Samples per pixel of each dual render.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Image width and height in pixels (small renders suffice: the fit has two unknowns).
    #[arg(long, default_value_t = 64)]
    pub size: usize,
    /// A path-traced reference made elsewhere (an EXR from `dualhair render --integrator path`
    /// of the same scene, camera and size) instead of rendering one.
    #[arg(long, value_name = "EXR")]
    pub reference: Option<PathBuf>,
    /// Write the fitted d_f and d_b into the scene file's `dual` section.
    #[arg(long)]
    pub write: bool,
    /// Hide the progress bars.
    #[arg(long, short)]
    pub quiet: bool,
}

pub fn run(args: &CalibrateArgs) -> Result<()> {
    ensure!(args.size >= 4, "--size must be at least 4 pixels");
    let overrides =
        Overrides { spp: Some(args.spp), width: Some(args.size), height: Some(args.size), ..Overrides::default() };
    let file = SceneFile::load_with(Some(&args.scene), &overrides)?;
    let reference = args.reference.as_deref().map(Film::read_exr).transpose()?;
    let c = calibrate(&file, reference, args.reference_spp, &Cache::default_location(), &Terminal::new(args.quiet))?;
    say!("fitted d_f = {:.3}, d_b = {:.3} (model {:?})", c.d_f, c.d_b, file.dual.model)?;
    let show = |(ratio, rmse): (f64, f64)| {
        format!("mean ratio dual/path {ratio:.3}, 4x4-block rel. RMSE {:.1}%", 100.0 * rmse)
    };
    say!("before (d_f = {}, d_b = {}): {}", file.dual.d_f, file.dual.d_b, show(c.before))?;
    say!("after: {}", show(c.after))?;
    if args.write {
        write_factors(&args.scene, c.d_f, c.d_b)?;
        say!("wrote d_f and d_b into {}", args.scene.display())?;
    }
    Ok(())
}
