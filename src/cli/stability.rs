//! `dualhair stability`: the flags of the stability survey ([`dualhair::analysis::stability`]).

use crate::cli::progress::Terminal;
use crate::say;
use anyhow::Result;
use dualhair::analysis::stability::{self, StabilitySettings};
use std::path::PathBuf;

/// Runs every model x sampler over d'Eon, Marschner and Hanika 2014's parameter grid and writes where each fails: a CSV
/// per part and a heat map per measure (PNG), with a summary.md, into the output folder.
///
/// The full grid (theta_i x alpha x mu_a x beta x eta, 16,800 points per method) is checked for
/// NaN/Inf, negative values, samples disagreeing with eval_pdf and failed draws. Three slices
/// through it (theta_i x beta; theta_i x mu_a and theta_i x alpha at beta = 0.04) get the
/// integrals: albedo, pdf integral, the method's own estimate against the albedo and against
/// uniform sampling, and (theta_i x beta) the distance to the Monte Carlo rough-cylinder
/// simulation. Takes about ten minutes on two cores with the defaults.
#[derive(clap::Args, Debug)]
pub struct StabilityArgs {
    /// Output folder (created if missing).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Directions per estimate at each point of the slices.
    #[arg(long, default_value_t = 4_000)]
    pub samples: usize,
    /// Rays of the rough-cylinder simulation per point of the beta slice (split into two halves
    /// whose distance is the noise floor; a quarter as many samples of each model), and of each
    /// model and the simulation at the four points drawn side by side; 0 skips the comparison.
    #[arg(long, default_value_t = 200_000)]
    pub rays: u64,
    /// Offsets h per point of the full grid, each with 8 random directions and 8 samples.
    #[arg(long, default_value_t = 4)]
    pub hits: usize,
    /// Every third value of each grid axis only (a quick look; tests use it).
    #[arg(long)]
    pub quick: bool,
    /// Seed of every random number drawn.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Hide the progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

impl StabilityArgs {
    fn settings(&self) -> StabilitySettings {
        StabilitySettings {
            output: self.output.clone(),
            samples: self.samples,
            rays: self.rays,
            hits: self.hits,
            quick: self.quick,
            seed: self.seed,
            threads: self.threads,
        }
    }
}

pub fn run(args: &StabilityArgs) -> Result<()> {
    say!("{}", stability::run(&args.settings(), &Terminal::new(args.quiet))?)?;
    Ok(())
}
