//! `dualhair render`: renders a scene file to EXR and PNG.

use crate::cache::Cache;
use crate::dual::{AUTO_SINGLE_BELOW, DualModel, DualScattering, Shadows, predicted_multiple_share};
use crate::film::Film;
use crate::integrator::PathTracer;
use crate::output::ImageFormat;
use crate::render::render;
use crate::scene::{IntegratorKind, Sampling, Scene, SceneFile, ShadowMode};
use crate::transmittance::ForwardLookup;
use anyhow::{Context, Result, bail};
use precompute::density::{DensityGrid, read_vdb};
use precompute::fiber::{Fiber, FiberModel, ModelKind, UniformSampled};
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
    /// Shadows in the dual integrator (default: the scene's, else lookup).
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
            Some(path) => read_vdb(path, "density")?,
            None => cache.density(&scene.strands, d.voxel_size)?,
        };
        let lookup = match d.shadows {
            ShadowMode::Lookup => Some(cache.lookup(scene, &grid, progress)?),
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
/// what comparisons time.
pub fn render_prepared(scene: &Scene, dual: Option<&DualInputs>, progress: bool) -> Result<Film> {
    let sampling = scene.render.sampling();
    let fiber = Fiber::new(&scene.fiber, sampling.fiber_sampler())?;
    let (spp, seed) = (scene.render.spp, scene.render.seed);
    if let Some(inputs) = dual {
        let d = &scene.dual;
        let dual = DualScattering {
            fibers: &scene.fibers,
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
        };
        return Ok(render(&scene.camera, &dual, spp, seed, progress, scene.render.terms));
    }
    let max_depth = match scene.render.integrator {
        IntegratorKind::Single => 1,
        IntegratorKind::Path => scene.render.max_depth,
        IntegratorKind::Dual => bail!("the dual integrator needs its tables and density grid"),
        IntegratorKind::Auto => bail!("`auto` must be resolved to an integrator first (resolve_auto)"),
    };
    match sampling {
        Sampling::Importance | Sampling::Thesis | Sampling::BoxMuller | Sampling::Iterative => {
            Ok(path_trace(scene, &fiber, max_depth, progress))
        }
        Sampling::Uniform => Ok(path_trace(scene, &UniformSampled(fiber), max_depth, progress)),
        Sampling::Light => bail!("light sampling alone needs the dual integrator"),
    }
}

/// Path traces a built scene with the fiber model `fiber`, at most `max_depth` fiber vertices.
fn path_trace(scene: &Scene, fiber: &impl FiberModel, max_depth: u32, progress: bool) -> Film {
    let tracer = PathTracer { fibers: &scene.fibers, fiber, lights: &scene.lights, max_depth };
    render(&scene.camera, &tracer, scene.render.spp, scene.render.seed, progress, scene.render.terms)
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let (exr, png) = output_paths(args.output.as_deref())?;
    let start = Instant::now();
    let mut scene = scene_file(args)?.build()?;
    scene.render.terms = args.aovs;
    let cache = Cache::default_location();
    if let Some(why) = resolve_auto(&mut scene, &cache, !args.quiet)? {
        println!("{why}");
    }
    let setup = start.elapsed();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let film = pool.install(|| render_scene(&scene, &cache, !args.quiet))?;
    film.write_exr(&exr, args.aovs)?;
    film.write_png(&png, scene.render.exposure)?;
    println!(
        "wrote {} and {} ({}x{}, {} spp, {:?}): {} strands, setup {:.2} s, render {:.2} s",
        exr.display(),
        png.display(),
        film.width,
        film.height,
        film.spp,
        scene.render.integrator,
        scene.strands.strand_count(),
        setup.as_secs_f64(),
        (start.elapsed() - setup).as_secs_f64()
    );
    Ok(())
}
