//! `dualhair converge`: the flags of a convergence run ([`dualhair::analysis::converge`]).

use crate::cli::progress::Terminal;
use crate::say;
use anyhow::Result;
use dualhair::analysis::converge::{self, ConvergeSettings, Method};
use dualhair::job::Part;
use std::path::PathBuf;

/// Renders a scene with several methods at doubling spp and several seeds, and measures error
/// against a ground truth (MSE) and change per doubling (relative variance), over hair pixels.
#[derive(clap::Args, Debug)]
pub struct ConvergeArgs {
    /// Scene file (.json) or hair file (.hair); default: scenes/default.json.
    pub scene: Option<PathBuf>,
    /// Methods to compare, INTEGRATOR-SAMPLING, comma separated: dual-importance, dual-uniform,
    /// dual-light, single-importance, single-uniform, path-importance, path-uniform, and for a
    /// Marschner fiber INTEGRATOR-thesis (its sampler with the thesis's stated density), for a
    /// Sadeghi fiber INTEGRATOR-box_muller (Hery and Ramamoorthi's sampler), for a d'Eon 2014
    /// fiber INTEGRATOR-iterative (its Appendix A loop as printed); a `dual`
    /// method may end in -K for K light samples per camera hit (dual-light-1, dual-light-4).
    #[arg(long, value_delimiter = ',', default_value = "dual-importance,dual-uniform")]
    pub methods: Vec<Method>,
    /// Samples per pixel, comma separated; powers of two give the per-doubling measure.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32,64,128,256,512")]
    pub spp: Vec<u32>,
    /// Independent seeds per method and spp (the scene's seed, +1, +2, ...).
    #[arg(long, default_value_t = 3)]
    pub seeds: u32,
    /// Ground truth method (default: dual-importance when every method is dual, else
    /// path-importance).
    #[arg(long)]
    pub truth: Option<Method>,
    /// Ground truth spp (default: 8 times the largest spp).
    #[arg(long)]
    pub truth_spp: Option<u32>,
    /// Measure over the pixel rectangle X0,Y0,X1,Y1 ([X0, X1) x [Y0, Y1), from the top left)
    /// instead of the pixels the truth's hair covers fully.
    #[arg(long, value_delimiter = ',', value_name = "X0,Y0,X1,Y1")]
    pub rect: Option<Vec<usize>>,
    /// Output folder.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Image width in pixels (overrides the scene).
    #[arg(long)]
    pub width: Option<usize>,
    /// Image height in pixels (overrides the scene).
    #[arg(long)]
    pub height: Option<usize>,
    /// Forward scattering density factor d_f (dual).
    #[arg(long)]
    pub d_f: Option<f64>,
    /// Backscattering density factor d_b (dual).
    #[arg(long)]
    pub d_b: Option<f64>,
    /// Most fiber vertices on a path (path).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Fiber scattering model (overrides the scene's `fiber.model`).
    #[arg(long)]
    pub model: Option<precompute::fiber::ModelKind>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render only part K of N (K = 1..N) of the renders (the truth among them), e.g. one task
    /// of a Slurm array, and skip the measures; `dualhair merge` gathers the parts' folders and
    /// measures them as one run. Parts may also share one folder: then rerunning without --part
    /// measures.
    #[arg(long, value_name = "K/N")]
    pub part: Option<Part>,
    /// Hide the progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

impl ConvergeArgs {
    fn settings(&self) -> ConvergeSettings {
        ConvergeSettings {
            scene: self.scene.clone(),
            methods: self.methods.clone(),
            spp: self.spp.clone(),
            seeds: self.seeds,
            truth: self.truth,
            truth_spp: self.truth_spp,
            rect: self.rect.clone(),
            output: self.output.clone(),
            width: self.width,
            height: self.height,
            d_f: self.d_f,
            d_b: self.d_b,
            max_depth: self.max_depth,
            model: self.model,
            threads: self.threads,
            part: self.part,
            measure_only: false,
        }
    }
}

pub fn run(args: &ConvergeArgs) -> Result<()> {
    let done = converge::run(&args.settings(), &Terminal::new(args.quiet))?;
    say!("{done}")?;
    Ok(())
}
