//! `dualhair render`: renders a scene file to EXR and PNG.

use crate::cache::{Cache, Fnv, spinner};
use crate::dual::{
    AUTO_SINGLE_BELOW, DualModel, DualScattering, Shadows, crossing_mean, forward_cosine, predicted_multiple_share,
};
use crate::film::Film;
use crate::integrator::PathTracer;
use crate::interrupt::{self, Interrupted};
use crate::output::{ImageFormat, ensure_writable};
use crate::partial::{self, RenderId};
use crate::render::{SUM_CEILING, Sums, render};
use crate::say;
use crate::scene::{IntegratorKind, Sampling, Scene, SceneFile, ShadowMode};
use crate::transmittance::ForwardLookup;
use anyhow::{Context, Result, anyhow, bail, ensure};
use precompute::density::{DensityGrid, read_vdb};
use precompute::fiber::{Fiber, ModelKind, UniformSampled};
use precompute::tables::Tables;
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
    #[arg(long, value_enum)]
    pub integrator: Option<IntegratorKind>,
    /// Direction sampling, combined with light sampling by MIS (default: light for dual, importance
    /// for the others).
    #[arg(long, value_enum)]
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
    #[arg(long, value_enum)]
    pub dual_model: Option<DualModel>,
    /// Shadows in the dual integrator (default: the scene's, else rays).
    #[arg(long, value_enum)]
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

/// Part K of N of a render's samples (K counted from 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    pub k: u32,
    pub n: u32,
}

impl std::str::FromStr for Part {
    type Err = String;

    fn from_str(s: &str) -> Result<Part, String> {
        let bad = || format!("`{s}` is not K/N with 1 <= K <= N");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let part = Part { k: k.trim().parse().map_err(|_| bad())?, n: n.trim().parse().map_err(|_| bad())? };
        (1..=part.n).contains(&part.k).then_some(part).ok_or_else(bad)
    }
}

impl Part {
    /// This part's share of `0..len`: contiguous, the shares of 1/N to N/N tile it in order.
    pub fn share(self, len: u32) -> std::ops::Range<u32> {
        let at = |k: u32| (len as u64 * k as u64 / self.n as u64) as u32;
        at(self.k - 1)..at(self.k)
    }
}

/// The EXR and PNG paths for an output argument.
fn output_paths(output: Option<&Path>) -> Result<(PathBuf, PathBuf)> {
    let out = output.unwrap_or(Path::new("render.exr"));
    Ok(match ImageFormat::from_path(out)? {
        ImageFormat::Exr => (out.to_path_buf(), out.with_extension("png")),
        ImageFormat::Png => (out.with_extension("exr"), out.to_path_buf()),
    })
}

/// Loads the scene and applies the command-line overrides.
pub fn scene_file(args: &RenderArgs) -> Result<SceneFile> {
    let path = args.scene.clone().unwrap_or_else(|| PathBuf::from("scenes/default.json"));
    if args.scene.is_none() && !path.exists() {
        bail!(
            "no scene given and {} does not exist here (run from the repository root or name a scene)",
            path.display()
        );
    }
    let mut file = SceneFile::load(&path)?;
    let r = &mut file.render;
    r.spp = args.spp.unwrap_or(r.spp);
    r.integrator = args.integrator.unwrap_or(r.integrator);
    r.sampling = args.sampling.or(r.sampling);
    r.seed = args.seed.unwrap_or(r.seed);
    r.max_depth = args.max_depth.unwrap_or(r.max_depth);
    file.dual.d_f = args.d_f.unwrap_or(file.dual.d_f);
    file.dual.d_b = args.d_b.unwrap_or(file.dual.d_b);
    file.fiber.model = args.model.unwrap_or(file.fiber.model);
    file.dual.model = args.dual_model.unwrap_or(file.dual.model);
    file.dual.shadows = args.shadows.unwrap_or(file.dual.shadows);
    file.dual.light_samples = args.light_samples.or(file.dual.light_samples);
    file.camera.width = args.width.unwrap_or(file.camera.width);
    file.camera.height = args.height.unwrap_or(file.camera.height);
    Ok(file)
}

/// What the dual integrator precomputes for a scene: the fiber's tables, the hair's density grid
/// and, for `dual.shadows` "lookup", the forward-transmittance lookup.
pub struct DualInputs {
    pub tables: Tables,
    pub grid: DensityGrid,
    pub lookup: Option<ForwardLookup>,
}

impl DualInputs {
    /// The scene's inputs from `cache` (computed there when missing), or its own density grid
    /// file; `None` unless the scene renders with `dual`.
    pub fn load(scene: &Scene, cache: &Cache, progress: bool) -> Result<Option<DualInputs>> {
        if scene.render.integrator != IntegratorKind::Dual {
            return Ok(None);
        }
        let d = &scene.dual;
        let tables = cache.tables(&scene.fiber, d.d_b, progress)?;
        let grid = match &d.density_grid {
            Some(path) => read_vdb(path, "density")?.with_orientation(&scene.strands),
            None => cache.density(&scene.strands, d.voxel_size, progress)?,
        };
        let lookup = match d.shadows {
            ShadowMode::Lookup => Some(cache.lookup(scene, progress)?),
            ShadowMode::Rays => None,
        };
        Ok(Some(DualInputs { tables, grid, lookup }))
    }
}

/// Resolves `auto` to `single` or `dual` from the multiple scattering the fiber's tables
/// predict ([`predicted_multiple_share`]); returns the reason, or `None` for any other integrator.
pub fn resolve_auto(scene: &mut Scene, cache: &Cache, progress: bool) -> Result<Option<String>> {
    if scene.render.integrator != IntegratorKind::Auto {
        return Ok(None);
    }
    let share = predicted_multiple_share(&cache.tables(&scene.fiber, scene.dual.d_b, progress)?);
    let (kind, why) = if share < AUTO_SINGLE_BELOW {
        (IntegratorKind::Single, "below")
    } else {
        (IntegratorKind::Dual, "at or above")
    };
    scene.render.integrator = kind;
    Ok(Some(format!(
        "auto: {kind:?}: the fiber's tables predict {:.1}% of the light from multiple scattering, {why} the {:.0}% threshold",
        100.0 * share,
        100.0 * AUTO_SINGLE_BELOW
    )))
}

/// Renders a built scene with its own settings, on the current rayon pool. The dual integrator's
/// tables and density grid come from `cache` (computed there when missing).
pub fn render_scene(scene: &Scene, cache: &Cache, progress: bool) -> Result<Film> {
    render_prepared(scene, DualInputs::load(scene, cache, progress)?.as_ref(), progress)
}

/// Renders a built scene with inputs already loaded (see [`DualInputs::load`]): rendering alone,
/// what comparisons time. An interrupt is an [`Interrupted`] error.
pub fn render_prepared(scene: &Scene, dual: Option<&DualInputs>, progress: bool) -> Result<Film> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut sums = Sums::empty(w, h, 0, scene.render.terms);
    if !render_into(scene, dual, &mut sums, scene.render.spp, progress)? {
        return Err(Interrupted("interrupted: the render was dropped".into()).into());
    }
    Ok(Film::from_sums(&sums))
}

/// Renders the scene's samples `sums.samples.end..end` into `sums` (see [`render`]); returns
/// whether it got to `end` rather than being interrupted.
pub fn render_into(
    scene: &Scene,
    dual: Option<&DualInputs>,
    sums: &mut Sums,
    end: u32,
    progress: bool,
) -> Result<bool> {
    let sampling = scene.render.sampling();
    let fiber = Fiber::new(&scene.fiber, sampling.fiber_sampler())?;
    let seed = scene.render.seed;
    if let Some(inputs) = dual {
        let d = &scene.dual;
        let dual = DualScattering {
            world: scene.world(),
            fiber: &fiber,
            lights: &scene.lights,
            tables: &inputs.tables,
            grid: &inputs.grid,
            d_f: d.d_f,
            d_b: d.d_b,
            model: d.model,
            sampling,
            shadows: match &inputs.lookup {
                Some(lookup) => Shadows::Lookup(lookup),
                None => Shadows::Rays,
            },
            light_samples: d.light_samples(&scene.lights),
            crossing: crossing_mean(&inputs.tables),
            deflection: forward_cosine(&fiber),
        };
        return Ok(render(&scene.camera, &dual, seed, sums, end, progress));
    }
    let max_depth = match scene.render.integrator {
        IntegratorKind::Single => 1,
        IntegratorKind::Path => scene.render.max_depth,
        IntegratorKind::Dual => bail!("the dual integrator needs its tables and density grid"),
        IntegratorKind::Auto => bail!("`auto` must be resolved to an integrator first (resolve_auto)"),
    };
    let (world, lights) = (scene.world(), &scene.lights);
    match sampling {
        Sampling::Importance | Sampling::Thesis | Sampling::BoxMuller | Sampling::Iterative => {
            let tracer = PathTracer { world, fiber: &fiber, lights, max_depth };
            Ok(render(&scene.camera, &tracer, seed, sums, end, progress))
        }
        Sampling::Uniform => {
            let tracer = PathTracer { world, fiber: &UniformSampled(fiber), lights, max_depth };
            Ok(render(&scene.camera, &tracer, seed, sums, end, progress))
        }
        Sampling::Light => bail!("light sampling alone needs the dual integrator"),
    }
}

/// What identifies a render for `--resume` and `merge`: the scene file with every override
/// applied, spp aside, and whether it collects the terms.
fn render_id(file: &SceneFile, aovs: bool) -> RenderId {
    let mut f = file.clone();
    f.render.spp = 0;
    let fingerprint = Fnv::of_code().bytes(format!("{f:?} aovs {aovs}").as_bytes()).0;
    RenderId {
        fingerprint: format!("{fingerprint:016x}"),
        seed: file.render.seed,
        spp: file.render.spp,
        exposure: file.render.exposure,
    }
}

/// The sums to continue from: the output file's, when resuming and it exists, checked against
/// this render; else none yet.
fn resume_from(
    exr: &Path,
    id: &RenderId,
    samples: &std::ops::Range<u32>,
    size: (usize, usize),
    aovs: bool,
) -> Result<Sums> {
    let empty = Sums::empty(size.0, size.1, samples.start, aovs);
    if !exr.exists() {
        say!("{}: nothing to resume yet; rendering from the start", exr.display())?;
        return Ok(empty);
    }
    let Some(partial) = partial::read(exr)? else {
        bail!(
            "{}: holds no sample sums to resume (only interrupted renders, parts and renders written with --sums do)",
            exr.display()
        );
    };
    let s = &partial.sums;
    let what = |d: String| anyhow!("{}: cannot resume: {d}", exr.display());
    if partial.id.fingerprint != id.fingerprint || partial.id.seed != id.seed {
        return Err(what(
            "it was rendered from another scene, seed or settings, or by another build of dualhair".into(),
        ));
    }
    if (s.width, s.height) != size || s.terms.is_empty() == aovs {
        return Err(what(format!(
            "it is {}x{}{}",
            s.width,
            s.height,
            if aovs { " without the terms" } else { " with --aovs" }
        )));
    }
    if s.samples.start != samples.start || s.samples.end > samples.end {
        return Err(what(format!(
            "it holds samples {}..{}, this render is samples {}..{}",
            s.samples.start, s.samples.end, samples.start, samples.end
        )));
    }
    Ok(partial.sums)
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let (exr, png) = output_paths(args.output.as_deref())?;
    let start = Instant::now();
    ensure_writable(&exr)?;
    let file = scene_file(args)?;
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
    let mut sums = if args.resume {
        resume_from(&exr, &id, &samples, size, args.aovs)?
    } else {
        Sums::empty(size.0, size.1, samples.start, args.aovs)
    };
    interrupt::install();
    // Seconds on a film-scale groom (README, "Film-scale grooms"), so it says what it is doing.
    let building = spinner(!args.quiet, "loading the hair and building its BVH".into());
    let mut scene = file.build()?;
    building.finish_and_clear();
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
    if let Some(why) = resolve_auto(&mut scene, &cache, !args.quiet)? {
        say!("{why}")?;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let dual = pool.install(|| DualInputs::load(&scene, &cache, !args.quiet))?;
    let setup = start.elapsed();
    let resumed = sums.spp();
    if !args.quiet {
        eprintln!(
            "rendering samples {}..{} of {} spp in passes (Ctrl-C writes the finished passes)",
            sums.samples.end, samples.end, id.spp
        );
    }
    let done = pool.install(|| render_into(&scene, dual.as_ref(), &mut sums, samples.end, !args.quiet))?;
    let seconds = (start.elapsed() - setup).as_secs_f64();
    if !done {
        if sums.spp() == 0 {
            return Err(Interrupted("interrupted before the first pass finished: nothing written".into()).into());
        }
        partial::write(&exr, &sums, &id, args.aovs)?;
        Film::from_sums(&sums).write_png(&png, id.exposure)?;
        return Err(Interrupted(format!(
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
