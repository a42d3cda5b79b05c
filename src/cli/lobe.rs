//! `dualhair lobe`: the h-averaged scattering lobe of one fiber as a lat-long image.

use crate::cli::fiber_args::FiberArgs;
use crate::say;
use anyhow::{Result, bail};
use dualhair::analysis::lobe::write_lobe_image;
use dualhair::output::{ImageFormat, ensure_writable};
use precompute::fiber::{Fiber, FiberParams};
use precompute::lobe::lobe_image;
use std::f64::consts::FRAC_PI_2;
use std::path::PathBuf;

/// Writes the lobe of a fiber lit from inclination --theta (azimuth 0) as a lat-long image:
/// x = azimuth from -pi (left) to pi (right), y = inclination from +pi/2 (top) to -pi/2 (bottom).
/// Each pixel is the h-averaged f(wo, wi) |cos theta_i|, so that summing
/// pixel * cos(theta) * dtheta * dphi gives the fiber's albedo.
#[derive(clap::Args, Debug)]
pub struct LobeArgs {
    /// Inclination of the light direction in radians, in [-pi/2, pi/2] (e.g. --theta=-1.0).
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub theta: f64,
    #[command(flatten)]
    pub fiber: FiberArgs,
    /// Image width in pixels (azimuth samples).
    #[arg(long, default_value_t = 512)]
    pub width: usize,
    /// Image height in pixels (inclination samples).
    #[arg(long, default_value_t = 256)]
    pub height: usize,
    /// Output file: .exr for linear RGB float values, .png for a log-scale picture with a color bar.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

pub fn run(args: &LobeArgs) -> Result<()> {
    ensure_writable(&args.output)?;
    if !(-FRAC_PI_2..=FRAC_PI_2).contains(&args.theta) {
        bail!("--theta must be in [-pi/2, pi/2] radians, got {}", args.theta);
    }
    for (name, v) in [("--width", args.width), ("--height", args.height)] {
        if !(1..=16384).contains(&v) {
            bail!("{name} must be between 1 and 16384, got {v}");
        }
    }
    ImageFormat::from_path(&args.output)?; // an unsupported name fails before any work
    let params = args.fiber.params()?;
    let model = Fiber::exact(&params)?;
    let rule = params.h_rule(1.0);
    let image = lobe_image(&model, args.theta, args.width, args.height, &rule);
    write_lobe_image(&args.output, &image, &title(args.theta, &params), "luminance, h-averaged f cos (1/sr)")?;
    let a = image.albedo().0;
    say!(
        "wrote {} ({}x{}); albedo (R, G, B) = ({:.4}, {:.4}, {:.4})",
        args.output.display(),
        image.width,
        image.height,
        a[0],
        a[1],
        a[2]
    )?;
    Ok(())
}

/// The chart's title: the model and its parameters.
fn title(theta: f64, params: &FiberParams) -> String {
    let model = params.model;
    format!("{} lobe, light at theta = {theta:.3} rad: {}", model.caption(), model.describe(params))
}
