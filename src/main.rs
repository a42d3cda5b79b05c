use clap::{Parser, Subcommand};
use dualhair::calibrate_cmd::{self, CalibrateArgs};
use dualhair::converge_cmd::{self, ConvergeArgs};
use dualhair::lobe_cmd::{self, LobeArgs};
use dualhair::precompute_cmd::{self, PrecomputeCommand};
use dualhair::render_cmd::{self, RenderArgs};

/// dualhair: a hair renderer that makes multiple scattering cheap (dual scattering with a
/// voxel hair-density grid, d'Eon importance sampling, and a path-traced reference).
#[derive(Parser, Debug)]
#[command(version, about, long_about = None)]
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
    /// Compare methods: error vs. spp and vs. wall time, with tables and charts.
    Converge(ConvergeArgs),
    /// Fit dual's d_f and d_b to a path-traced reference of a scene.
    Calibrate(CalibrateArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Render(args) => render_cmd::run(args),
        Command::Precompute(command) => precompute_cmd::run(command),
        Command::Lobe(args) => lobe_cmd::run(args),
        Command::Converge(args) => converge_cmd::run(args),
        Command::Calibrate(args) => calibrate_cmd::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
