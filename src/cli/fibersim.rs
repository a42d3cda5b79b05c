//! `dualhair fibersim`: the Monte Carlo ground truth of one rough fiber (d'Eon, Marschner and Hanika 2014,
//! section 2.1) as a lat-long image, directly comparable with `dualhair lobe`.

use crate::cli::fiber_args::FiberArgs;
use crate::say;
use anyhow::{Result, bail};
use dualhair::analysis::lobe::write_lobe_image;
use dualhair::output::{ImageFormat, ensure_writable};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use precompute::fiber::FiberParams;
use precompute::fibersim::{FiberSim, MAX_HEIGHT, MAX_RAYS, MAX_WIDTH, Simulation};
use precompute::spectrum::Rgb;
use std::f64::consts::FRAC_PI_2;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// What `dualhair fibersim --help` says (the subcommand's long description).
pub const LONG_ABOUT: &str = r#"Monte Carlo ground truth of one rough fiber (d'Eon, Marschner and Hanika 2014,
section 2.1), written as a lat-long image comparable with `dualhair lobe`.

Rays arrive from direction --theta (azimuth 0) at offsets uniform across an infinite
unit-radius dielectric cylinder. Every surface event samples Walter et al. 2007's Beckmann
microfacet BSDF with Smith shadowing, using --beta-m (radians) as the Beckmann width, and
reflects or refracts with the Fresnel probability; --alpha tilts the shading normal (positive
puts R toward the root); the interior absorbs sigma_a per unit radius (--sigma-a, melanin or
--color). Exit directions are binned per lobe into an image laid out as `dualhair lobe`'s:
x = azimuth -pi..pi, y = inclination pi/2 (top)..-pi/2, pixel = exiting energy per steradian
per unit incident energy, so summing pixel * cos(theta) * dtheta * dphi gives the albedo.
It prints each lobe's energy (R, TT, TRT, rest = p >= 3) with its standard error, and the
fractions absorbed, lost (Smith shadowing; tilted scales met from behind) and truncated (still
inside after 32 internal segments). Only --beta-m, --alpha, --eta and the absorption flags matter; --model, --beta-n (except
through --color), --alpha-r and --beta-r are ignored."#;

/// Flags of `dualhair fibersim` ([`LONG_ABOUT`]).
#[derive(clap::Args, Debug)]
pub struct FibersimArgs {
    /// Inclination of the light direction in radians, in [-pi/2, pi/2] (e.g. --theta=-1.0).
    #[arg(long, default_value_t = 0.5, allow_negative_numbers = true)]
    pub theta: f64,
    #[command(flatten)]
    pub fiber: FiberArgs,
    /// Number of rays, 1 to 1e9.
    #[arg(long, default_value_t = 1_000_000)]
    pub rays: u64,
    /// Random seed; a given seed gives the same image whatever the number of threads.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Image width in pixels (azimuth bins).
    #[arg(long, default_value_t = 400)]
    pub width: usize,
    /// Image height in pixels (inclination bins).
    #[arg(long, default_value_t = 100)]
    pub height: usize,
    /// Which lobe the image shows: r, tt, trt, rest (p >= 3) or all (their sum).
    #[arg(long, value_enum, default_value_t = Lobe::All)]
    pub lobe: Lobe,
    /// Output file: .exr for linear RGB float values, .png for a log-scale picture with a color bar.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

/// A lobe of the simulation, or all of them.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    R,
    Tt,
    Trt,
    Rest,
    All,
}

impl Lobe {
    /// The lobe's name in titles and reports.
    fn name(self) -> &'static str {
        match self {
            Lobe::R => "R",
            Lobe::Tt => "TT",
            Lobe::Trt => "TRT",
            Lobe::Rest => "rest (p >= 3)",
            Lobe::All => "all lobes",
        }
    }
}

/// Validates the flags, runs the simulation, writes the image and prints where the energy went.
pub fn run(args: &FibersimArgs) -> Result<()> {
    ensure_writable(&args.output)?;
    if !(-FRAC_PI_2..=FRAC_PI_2).contains(&args.theta) {
        bail!("--theta must be in [-pi/2, pi/2] radians, got {}", args.theta);
    }
    if !(1..=MAX_RAYS).contains(&args.rays) {
        bail!("--rays must be between 1 and {MAX_RAYS}, got {}", args.rays);
    }
    for (name, v, max) in [("--width", args.width, MAX_WIDTH), ("--height", args.height, MAX_HEIGHT)] {
        if !(1..=max).contains(&v) {
            bail!("{name} must be between 1 and {max}, got {v}");
        }
    }
    ImageFormat::from_path(&args.output)?; // an unsupported name fails before any work
    let params = args.fiber.params()?;
    let fiber = FiberSim::new(&params, args.theta)?;

    // The bar appears only once the run has taken a second (and only on a terminal).
    let bar = ProgressBar::hidden();
    bar.set_length(args.rays);
    bar.set_style(
        ProgressStyle::with_template("{spinner} tracing [{bar:40}] {pos}/{len} rays, ETA {eta}")
            .expect("static progress template")
            .progress_chars("=> "),
    );
    let start = Instant::now();
    let mut shown = false;
    let sim = fiber.simulate(args.rays, args.seed, args.width, args.height, &mut |done| {
        if !shown && start.elapsed() > Duration::from_secs(1) {
            bar.set_draw_target(ProgressDrawTarget::stderr());
            shown = true;
        }
        bar.set_position(done);
    })?;
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();

    let image = match args.lobe {
        Lobe::R => &sim.images[0],
        Lobe::Tt => &sim.images[1],
        Lobe::Trt => &sim.images[2],
        Lobe::Rest => &sim.images[3],
        Lobe::All => &sim.total_image(),
    };
    write_lobe_image(&args.output, image, &title(args, &params), "luminance, exiting energy (1/sr)")?;
    say!(
        "wrote {} ({}x{}, {}); {} rays in {:.2} s ({:.2} M rays/s)",
        args.output.display(),
        image.width,
        image.height,
        args.lobe.name(),
        args.rays,
        seconds,
        args.rays as f64 / seconds / 1e6
    )?;
    report(&sim)?;
    Ok(())
}

/// Prints where the light went, per RGB channel, with Monte Carlo standard errors.
fn report(sim: &Simulation) -> std::io::Result<()> {
    let t = &sim.tally;
    let rgb = |v: Rgb| format!("{:.6} {:.6} {:.6}", v.0[0], v.0[1], v.0[2]);
    say!("energy fractions (R G B channels):")?;
    for (p, name) in ["R", "TT", "TRT", "rest"].iter().enumerate() {
        say!("  {name:<16} {}  (std. error {})", rgb(t.lobes[p]), rgb(sim.std_error(p)))?;
    }
    say!("  {:<16} {}", "total albedo", rgb(sim.albedo()))?;
    say!("  {:<16} {}", "absorbed", rgb(t.absorbed))?;
    say!("  {:<16} {}", "lost: Smith G", rgb(t.microfacet_loss))?;
    say!("  {:<16} {}", "lost: scales", rgb(t.shading_loss))?;
    say!("  {:<16} {}", "truncated", rgb(t.truncated))
}

/// The chart's title: the lobe and the parameters.
fn title(args: &FibersimArgs, params: &FiberParams) -> String {
    let s = params.sigma_a().0;
    format!(
        "Simulated fiber, {}: theta_i {:.3}, beta {}, alpha {} deg, eta {}, sigma_a {:.2}/{:.2}/{:.2}",
        args.lobe.name(),
        args.theta,
        params.beta_m,
        params.alpha,
        params.eta,
        s[0],
        s[1],
        s[2]
    )
}
