mod cli;

use clap::{Parser, Subcommand};
use cli::calibrate::{self as calibrate_cmd, CalibrateArgs};
use cli::compare::{self as compare_cmd, CompareArgs};
use cli::converge::{self as converge_cmd, ConvergeArgs};
use cli::convert::{self as convert_cmd, ConvertArgs};
use cli::fibersim::{self as fibersim_cmd, FibersimArgs};
use cli::lobe::{self as lobe_cmd, LobeArgs};
use cli::merge::{self as merge_cmd, MergeArgs};
use cli::precompute::{self as precompute_cmd, PrecomputeCommand};
use cli::render::{self as render_cmd, RenderArgs};
use cli::resolve::{self as resolve_cmd, ResolveArgs};
use cli::stability::{self as stability_cmd, StabilityArgs};
use dualhair::error::Error;
use dualhair::render::interrupt::EXIT_STATUS;

/// dualhair: a hair renderer that makes multiple scattering cheap (dual scattering with a
/// voxel hair-density grid, d'Eon importance sampling, and a path-traced reference).
#[derive(Parser, Debug)]
// The version names the code too: cache entries and resumable renders are keyed by it.
#[command(version = concat!(env!("CARGO_PKG_VERSION"), " (code ", env!("DUALHAIR_CODE_ID"), ")"), about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to EXR and PNG.
    Render(RenderArgs),
    /// Precompute and export the dual-scattering tables or the hair-density grid.
    #[command(subcommand)]
    Precompute(PrecomputeCommand),
    /// Write a lat-long image of a single fiber's scattering lobe.
    Lobe(LobeArgs),
    /// Simulate a rough fiber's scattering by Monte Carlo (d'Eon, Marschner and Hanika 2014, sec. 2.1) into a lat-long image.
    #[command(long_about = fibersim_cmd::LONG_ABOUT)]
    Fibersim(FibersimArgs),
    /// Compare methods: error vs. spp and vs. wall time, with tables and charts.
    Converge(ConvergeArgs),
    /// Measure where every fiber model and sampler fails over d'Eon, Marschner and Hanika 2014's parameter grid.
    Stability(StabilityArgs),
    /// Add the parts of a split render (`render --part K/N`) into one image, or gather the folders
    /// of a split `converge` run.
    Merge(MergeArgs),
    /// Compare an image with a reference over the hair: mean ratio and relative RMSE.
    Compare(CompareArgs),
    /// Fit dual's d_f and d_b to a path-traced reference of a scene.
    Calibrate(CalibrateArgs),
    /// Write a scene with everything derived made explicit (hair as a .hair file in world units,
    /// camera, sigma_a, absolute paths), e.g. for tools/cycles_reference.py.
    Resolve(ResolveArgs),
    /// Convert hair between formats (.hair, .hair.gz, pbrt-v4 curves in, .hair or .hair.gz out),
    /// with the transform flags of scene files.
    Convert(ConvertArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Render(args) => render_cmd::run(args),
        Command::Precompute(command) => precompute_cmd::run(command),
        Command::Lobe(args) => lobe_cmd::run(args),
        Command::Fibersim(args) => fibersim_cmd::run(args),
        Command::Converge(args) => converge_cmd::run(args),
        Command::Stability(args) => stability_cmd::run(args),
        Command::Merge(args) => merge_cmd::run(args),
        Command::Compare(args) => compare_cmd::run(args),
        Command::Calibrate(args) => calibrate_cmd::run(args),
        Command::Resolve(args) => resolve_cmd::run(args),
        Command::Convert(args) => convert_cmd::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) if matches!(e.downcast_ref::<Error>(), Some(Error::Interrupted(_))) => {
            eprintln!("{e:#}");
            std::process::ExitCode::from(EXIT_STATUS)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
