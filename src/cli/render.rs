//! `dualhair render`: renders a scene file to EXR and PNG.

use crate::cli::choice;
use crate::cli::progress::Terminal;
use crate::say;
use anyhow::{Context, Result, ensure};
use dualhair::error::Error;
use dualhair::film::Film;
use dualhair::film::partial;
use dualhair::integrators::dual::DualModel;
use dualhair::integrators::dual::cache::Cache;
use dualhair::integrators::dual::options::ShadowMode;
use dualhair::integrators::{IntegratorKind, Sampling};
use dualhair::job::{Part, dual_inputs, render_id, render_into, resolve_auto, resume_from};
use dualhair::output::{ImageFormat, ensure_writable};
use dualhair::progress::Progress;
use dualhair::render::interrupt;
use dualhair::render::{SUM_CEILING, Sums};
use dualhair::scene::{Overrides, SceneFile};
use precompute::fiber::ModelKind;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Renders a scene (a JSON scene file, or a .hair file with every default). Flags override the
/// scene file. Writes linear EXR (RGB + coverage alpha) and a tone-mapped sRGB PNG beside it.
#[derive(clap::Args, Debug, Default)]
pub struct RenderArgs {
    /// Scene file (.json) or hair file (.hair); default: scenes/default.json.
    pub scene: Option<PathBuf>,
    /// Output image, .exr or .png (the other one is written beside it); default: render.exr.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Samples per pixel.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Integrator (default: the scene's, else dual).
    #[arg(long, value_parser = choice::<IntegratorKind>())]
    pub integrator: Option<IntegratorKind>,
    /// Direction sampling, combined with light sampling by MIS (default: light for dual, importance
    /// for the others).
    #[arg(long, value_parser = choice::<Sampling>())]
    pub sampling: Option<Sampling>,
    /// Random seed; the same seed gives the same image.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Most fiber vertices on a path (path integrator).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Forward scattering density factor d_f in [0, 1] (dual integrator).
    #[arg(long)]
    pub d_f: Option<f64>,
    /// Backscattering density factor d_b in [0, 1] (dual integrator).
    #[arg(long)]
    pub d_b: Option<f64>,
    /// Fiber scattering model (default: the scene's `fiber.model`, else chiang); a Marschner
    /// fiber takes its parameters from the scene's `fiber.marschner`.
    #[arg(long)]
    pub model: Option<ModelKind>,
    /// Dual-scattering model (dual integrator; default: the scene's, else two_stream).
    #[arg(long, value_parser = choice::<DualModel>())]
    pub dual_model: Option<DualModel>,
    /// Shadows in the dual integrator (default: the scene's, else rays).
    #[arg(long, value_parser = choice::<ShadowMode>())]
    pub shadows: Option<ShadowMode>,
    /// Light samples per camera hit (dual integrator; default: the scene's, else 4 under an
    /// environment map and 1 otherwise).
    #[arg(long)]
    pub light_samples: Option<u32>,
    /// Image width in pixels.
    #[arg(long)]
    pub width: Option<usize>,
    /// Image height in pixels.
    #[arg(long)]
    pub height: Option<usize>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also write per-pixel variance (variance.R/G/B), sample-count (spp) and the radiance split
    /// into the terms of dual scattering (single, forward, back, multiback: .R/.G/.B) to the EXR.
    #[arg(long)]
    pub aovs: bool,
    /// Render only part K of N (K = 1..N) of the samples, e.g. one task of a Slurm array: samples
    /// (K-1)*spp/N to K*spp/N of every pixel, written as a partial render (EXR only) for
    /// `dualhair merge`, which adds the parts into the image one render would make, bit for bit.
    #[arg(long, value_name = "K/N")]
    pub part: Option<Part>,
    /// Continue the render in the output file (an interrupted one, a part, or one written with
    /// --sums) up to --spp; the result is bit-identical to rendering it in one go. Starts afresh
    /// when the output file does not exist yet.
    #[arg(long)]
    pub resume: bool,
    /// Also store the exact per-pixel sums in the EXR (`exact.*` channels), so that `--resume` can
    /// add samples to it later. Parts and interrupted renders always store them.
    #[arg(long)]
    pub sums: bool,
    /// Hide the progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The EXR and PNG paths for an output argument.
fn output_paths(output: Option<&Path>) -> Result<(PathBuf, PathBuf)> {
    let out = output.unwrap_or(Path::new("render.exr"));
    Ok(match ImageFormat::from_path(out)? {
        ImageFormat::Exr => (out.to_path_buf(), out.with_extension("png")),
        ImageFormat::Png => (out.with_extension("exr"), out.to_path_buf()),
    })
}

impl RenderArgs {
    /// The flags that replace the scene file's values.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            spp: self.spp,
            integrator: self.integrator,
            sampling: self.sampling,
            seed: self.seed,
            max_depth: self.max_depth,
            d_f: self.d_f,
            d_b: self.d_b,
            model: self.model,
            dual_model: self.dual_model,
            shadows: self.shadows,
            light_samples: self.light_samples,
            width: self.width,
            height: self.height,
        }
    }
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let (exr, png) = output_paths(args.output.as_deref())?;
    let start = Instant::now();
    ensure_writable(&exr)?;
    let file = SceneFile::load_with(args.scene.as_deref(), &args.overrides())?;
    file.check_film(args.aovs)?;
    let id = render_id(&file, args.aovs);
    let samples = match args.part {
        Some(part) => {
            let share = part.share(id.spp);
            ensure!(!share.is_empty(), "--part {}/{}: more parts than the {} spp", part.k, part.n, id.spp);
            share
        }
        None => 0..id.spp,
    };
    let size = (file.camera.width, file.camera.height);
    let progress = Terminal::new(args.quiet);
    let mut sums = if args.resume {
        if !exr.exists() {
            say!("{}: nothing to resume yet; rendering from the start", exr.display())?;
        }
        resume_from(&exr, &id, &samples, size, args.aovs)?
    } else {
        Sums::empty(size.0, size.1, samples.start, args.aovs)
    };
    interrupt::install();
    // Seconds on a film-scale groom (docs/usage.md, "Film-scale grooms"), so it says what it is doing.
    let building = progress.task("loading the hair and building its BVH", None);
    let mut scene = file.build()?;
    drop(building);
    if !args.quiet {
        let s = &scene.strands;
        eprintln!(
            "loaded {} strands ({} points) and built the BVH over their {} segments in {:.1} s",
            s.strand_count(),
            s.points.len(),
            s.segment_count(),
            start.elapsed().as_secs_f64()
        );
    }
    scene.render.terms = args.aovs;
    let cache = Cache::default_location();
    if let Some(why) = resolve_auto(&mut scene, &cache, &progress)? {
        say!("{why}")?;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let dual = pool.install(|| dual_inputs(&scene, &cache, &progress))?;
    let setup = start.elapsed();
    let resumed = sums.spp();
    if !args.quiet {
        eprintln!(
            "rendering samples {}..{} of {} spp in passes (Ctrl-C writes the finished passes)",
            sums.samples.end, samples.end, id.spp
        );
    }
    let done = pool.install(|| render_into(&scene, dual.as_ref(), &mut sums, samples.end, &progress))?;
    let seconds = (start.elapsed() - setup).as_secs_f64();
    if !done {
        if sums.spp() == 0 {
            return Err(Error::Interrupted("interrupted before the first pass finished: nothing written".into()).into());
        }
        partial::write(&exr, &sums, &id, args.aovs)?;
        Film::from_sums(&sums).write_png(&png, id.exposure)?;
        return Err(Error::Interrupted(format!(
            "interrupted: wrote {} and {} with the {} finished spp (samples {}..{}) of {}; the same command with --resume continues it",
            exr.display(),
            png.display(),
            sums.spp(),
            sums.samples.start,
            sums.samples.end,
            samples.len()
        ))
        .into());
    }
    let saturated = sums.saturated_pixels();
    if saturated > 0 {
        eprintln!(
            "warning: {saturated} pixels reached the ceiling of their sums ({SUM_CEILING:.1e}, or a NaN or infinite sample): their values or variances are clipped"
        );
    }
    let film = Film::from_sums(&sums);
    if args.part.is_some() || args.sums {
        partial::write(&exr, &sums, &id, args.aovs)?;
    } else {
        film.write_exr(&exr, args.aovs)?;
    }
    let png_note = if args.part.is_some() {
        String::new()
    } else {
        film.write_png(&png, id.exposure)?;
        format!(" and {}", png.display())
    };
    let resumed = if resumed > 0 { format!(", {resumed} of them resumed") } else { String::new() };
    say!(
        "wrote {}{png_note} ({}x{}, {} spp{resumed}, samples {}..{} of {}, {:?}): {} strands, setup {:.2} s, render {seconds:.2} s",
        exr.display(),
        film.width,
        film.height,
        film.spp,
        sums.samples.start,
        sums.samples.end,
        id.spp,
        scene.render.integrator,
        scene.strands.strand_count(),
        setup.as_secs_f64(),
    )?;
    Ok(())
}
