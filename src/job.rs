//! One render of a scene: `auto` resolved, the integrator the scene names built over its world,
//! dual's inputs loaded (cached), samples added into sums, and what identifies a render so that
//! it can be resumed or split into parts and merged.

use crate::error::{Error, Result, bail, invalid};
use crate::film::Film;
use crate::film::partial::{self, RenderId};
use crate::fingerprint::Fnv;
use crate::integrators::dual::cache::Cache;
use crate::integrators::dual::inputs::DualInputs;
use crate::integrators::dual::{
    AUTO_SINGLE_BELOW, DualScattering, Shadows, crossing_mean, forward_cosine, predicted_multiple_share,
};
use crate::integrators::path::PathTracer;
use crate::integrators::{IntegratorKind, Sampling};
use crate::progress::Progress;
use crate::render::{Sums, render};
use crate::scene::{Scene, SceneFile};
use precompute::fiber::{Fiber, UniformSampled};
use std::path::Path;

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

/// The dual integrator's inputs for a scene; `None` unless it renders with `dual`.
pub fn dual_inputs(scene: &Scene, cache: &Cache, progress: &dyn Progress) -> Result<Option<DualInputs>> {
    if scene.render.integrator != IntegratorKind::Dual {
        return Ok(None);
    }
    let inputs = DualInputs::load(&scene.fiber, &scene.dual, &scene.strands, &scene.lights, cache, progress)?;
    Ok(Some(inputs))
}

/// Resolves `auto` to `single` or `dual` from the multiple scattering the fiber's tables
/// predict ([`predicted_multiple_share`]); returns the reason, or `None` for any other integrator.
pub fn resolve_auto(scene: &mut Scene, cache: &Cache, progress: &dyn Progress) -> Result<Option<String>> {
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
pub fn render_scene(scene: &Scene, cache: &Cache, progress: &dyn Progress) -> Result<Film> {
    render_prepared(scene, dual_inputs(scene, cache, progress)?.as_ref(), progress)
}

/// Renders a built scene with inputs already loaded (see [`DualInputs::load`]): rendering alone,
/// what comparisons time. An interrupt is an [`Error::Interrupted`].
pub fn render_prepared(scene: &Scene, dual: Option<&DualInputs>, progress: &dyn Progress) -> Result<Film> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let mut sums = Sums::empty(w, h, 0, scene.render.terms);
    if !render_into(scene, dual, &mut sums, scene.render.spp, progress)? {
        return Err(Error::Interrupted("interrupted: the render was dropped".into()));
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
    progress: &dyn Progress,
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
        Sampling::Importance | Sampling::Flawed(_) => {
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
pub fn render_id(file: &SceneFile, aovs: bool) -> RenderId {
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
pub fn resume_from(
    exr: &Path,
    id: &RenderId,
    samples: &std::ops::Range<u32>,
    size: (usize, usize),
    aovs: bool,
) -> Result<Sums> {
    let empty = Sums::empty(size.0, size.1, samples.start, aovs);
    if !exr.exists() {
        return Ok(empty);
    }
    let Some(partial) = partial::read(exr)? else {
        bail!(
            "{}: holds no sample sums to resume (only interrupted renders, parts and renders written with --sums do)",
            exr.display()
        );
    };
    let s = &partial.sums;
    let what = |d: String| invalid!("{}: cannot resume: {d}", exr.display());
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
