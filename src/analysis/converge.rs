//! Convergence runs (`dualhair converge`): convergence and speed comparisons of integrators and sampling strategies
//! (the thesis's Tables 6.1 and 6.2 and Figure 6.8, Lemein 2020 section 6.3), as tables and charts.
//!
//! Every method renders the scene at every spp with K seeds; each render is timed alone (scene,
//! tables and grid are ready before the clock starts) and written to `DIR/renders/`. Then, over
//! hair pixels (or a rectangle):
//!
//! - `mse`: mean squared difference from the ground truth (Table 6.2), linear radiance;
//! - `rel_variance`: mean squared difference from the same method and seed at half the spp
//!   (Table 6.1). The half-spp render's samples are the first half of this one's (each pixel
//!   draws from one stream per seed), so this is how much the image still changes per doubling.
//!
//! The ground truth is a high-spp render of the method family under test, cached in `DIR`, with
//! its own noise (the mean variance of its pixel means, in MSE units) reported: errors near it are
//! noise, not error. Rerunning with the same `DIR` reuses every finished render whose scene and
//! settings match, so an interrupted run picks up where it stopped.

use crate::analysis::compare::{hair_pixels, mean_variance, mse, rectangle};
use crate::analysis::plot::register_fonts;
use crate::error::{Context, Error, Result, bail, ensure, invalid};
use crate::film::Film;
use crate::fingerprint::Fnv;
use crate::integrators::dual::cache::Cache;
use crate::integrators::dual::inputs::DualInputs;
use crate::integrators::dual::options::MAX_LIGHT_SAMPLES;
use crate::integrators::{Choice, IntegratorKind, Sampling};
use crate::job::{Part, dual_inputs, render_prepared};
use crate::output::write_atomically;
use crate::progress::{Progress, Silent};
use crate::render::interrupt;
use crate::scene::{Overrides, Scene, SceneFile};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Renders a scene with several methods at doubling spp and several seeds, and measures error
/// against a ground truth (MSE) and change per doubling (relative variance), over hair pixels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConvergeSettings {
    /// Scene file (.json) or hair file (.hair); default: scenes/default.json.
    pub scene: Option<PathBuf>,
    /// Methods to compare, INTEGRATOR-SAMPLING, comma separated: dual-importance, dual-uniform,
    /// dual-light, single-importance, single-uniform, path-importance, path-uniform, and for a
    /// Marschner fiber INTEGRATOR-thesis (its sampler with the thesis's stated density), for a
    /// Sadeghi fiber INTEGRATOR-box_muller (Hery and Ramamoorthi's sampler), for a d'Eon 2014
    /// fiber INTEGRATOR-iterative (its Appendix A loop as printed); a `dual`
    /// method may end in -K for K light samples per camera hit (dual-light-1, dual-light-4).
    pub methods: Vec<Method>,
    /// Samples per pixel, comma separated; powers of two give the per-doubling measure.
    pub spp: Vec<u32>,
    /// Independent seeds per method and spp (the scene's seed, +1, +2, ...).
    pub seeds: u32,
    /// Ground truth method (default: dual-importance when every method is dual, else
    /// path-importance).
    pub truth: Option<Method>,
    /// Ground truth spp (default: 8 times the largest spp).
    pub truth_spp: Option<u32>,
    /// Measure over the pixel rectangle X0,Y0,X1,Y1 ([X0, X1) x [Y0, Y1), from the top left)
    /// instead of the pixels the truth's hair covers fully.
    pub rect: Option<Vec<usize>>,
    /// Output folder.
    pub output: PathBuf,
    /// Image width in pixels (overrides the scene).
    pub width: Option<usize>,
    /// Image height in pixels (overrides the scene).
    pub height: Option<usize>,
    /// Forward scattering density factor d_f (dual).
    pub d_f: Option<f64>,
    /// Backscattering density factor d_b (dual).
    pub d_b: Option<f64>,
    /// Most fiber vertices on a path (path).
    pub max_depth: Option<u32>,
    /// Fiber scattering model (overrides the scene's `fiber.model`).
    pub model: Option<precompute::fiber::ModelKind>,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// Render only part K of N (K = 1..N) of the renders (the truth among them), e.g. one task
    /// of a Slurm array, and skip the measures; `dualhair merge` gathers the parts' folders and
    /// measures them as one run. Parts may also share one folder: then rerunning without --part
    /// measures.
    #[serde(skip)]
    pub part: Option<Part>,
    /// Measure finished renders only; a missing one is an error (what `merge` runs).
    #[serde(skip)]
    pub measure_only: bool,
}

/// An integrator with a direction sampler, written INTEGRATOR-SAMPLING, and for `dual` perhaps
/// its light samples per camera hit, INTEGRATOR-SAMPLING-K (else the scene's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(into = "String", try_from = "String")]
pub struct Method {
    pub integrator: IntegratorKind,
    pub sampling: Sampling,
    pub light_samples: Option<u32>,
}

impl std::str::FromStr for Method {
    type Err = String;

    fn from_str(s: &str) -> Result<Method, String> {
        let (i, rest) = s.split_once('-').ok_or_else(|| format!("`{s}` is not INTEGRATOR-SAMPLING"))?;
        let (smp, k) = rest.split_once('-').map_or((rest, None), |(smp, k)| (smp, Some(k)));
        let light_samples = k
            .map(|k| {
                k.parse()
                    .ok()
                    .filter(|k| (1..=MAX_LIGHT_SAMPLES).contains(k))
                    .ok_or(format!("`{k}`: light samples must be 1 to {MAX_LIGHT_SAMPLES}"))
            })
            .transpose()?;
        let method = Method {
            integrator: IntegratorKind::named(i).ok_or(format!("`{i}`: no such integrator"))?,
            sampling: Sampling::named(smp).ok_or(format!("`{smp}`: no such sampling"))?,
            light_samples,
        };
        if light_samples.is_some() && method.integrator != IntegratorKind::Dual {
            return Err(format!("`{s}`: light samples per camera hit are for dual only"));
        }
        if method.integrator == IntegratorKind::Auto {
            return Err("`auto` is no method to compare: name single, dual or path".into());
        }
        if method.sampling == Sampling::Light && method.integrator != IntegratorKind::Dual {
            return Err(format!("`{s}`: light sampling alone is for dual only"));
        }
        Ok(method)
    }
}

impl From<Method> for String {
    fn from(m: Method) -> String {
        m.to_string()
    }
}

impl TryFrom<String> for Method {
    type Error = String;

    fn try_from(s: String) -> Result<Method, String> {
        s.parse()
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}-{}", self.integrator.name(), self.sampling.name())?;
        self.light_samples.map_or(Ok(()), |k| write!(f, "-{k}"))
    }
}

/// One render of the run.
struct Job {
    method: Method,
    spp: u32,
    seed: u64,
    path: PathBuf,
}

impl Job {
    fn sidecar(&self) -> PathBuf {
        self.path.with_extension("json")
    }
}

/// A finished render's record.
struct Row {
    method: Method,
    spp: u32,
    seed: u64,
    seconds: f64,
    mse: f64,
    rel_variance: Option<f64>,
}

/// What identifies a scene for reuse: everything but the settings a job sets itself.
fn fingerprint(file: &SceneFile) -> String {
    let mut f = file.clone();
    f.render.spp = 1;
    f.render.seed = 0;
    f.render.integrator = IntegratorKind::Dual;
    f.render.sampling = Some(Sampling::Importance);
    format!("{:016x}", Fnv::of_code().bytes(format!("{f:?}").as_bytes()).0)
}

/// Seconds a finished render took, if `job`'s files exist and were made from this scene.
fn finished(job: &Job, scene: &str) -> Option<f64> {
    let meta: serde_json::Value = serde_json::from_slice(&std::fs::read(job.sidecar()).ok()?).ok()?;
    let same = meta["scene"] == scene
        && meta["method"] == job.method.to_string()
        && meta["spp"] == job.spp
        && meta["seed"] == job.seed;
    (same && job.path.exists()).then(|| meta["seconds"].as_f64()).flatten()
}

/// The run's scene, built once, and the dual integrator's inputs, loaded at its first `dual` job.
struct Prepared<'a> {
    scene: Scene,
    fingerprint: String,
    /// The scene's own light samples per camera hit, for methods that do not name theirs.
    light_samples: Option<u32>,
    cache: &'a Cache,
    dual: Option<DualInputs>,
}

/// The jobs of part `part`: each job goes, largest first, to the part with the fewest samples so
/// far (the lowest K on ties), so parts get about equal work whatever the order of the jobs.
fn part_jobs<'a>(jobs: &[&'a Job], part: Part) -> Vec<&'a Job> {
    let mut order: Vec<usize> = (0..jobs.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(jobs[i].spp));
    let mut load = vec![0u64; part.n as usize];
    let mut mine = Vec::new();
    for i in order {
        let k = (0..load.len()).min_by_key(|&k| load[k]).expect("at least one part");
        load[k] += jobs[i].spp as u64;
        if k + 1 == part.k as usize {
            mine.push(jobs[i]);
        }
    }
    mine
}

/// Renders a job unless it is finished (then its recorded time is reused) and returns its time
/// in seconds; `done` is (renders before this one, all renders) for the message on an interrupt.
fn render_job(
    job: &Job,
    prepared: &mut Prepared,
    aovs: bool,
    pool: &rayon::ThreadPool,
    done: (usize, usize),
    dir: &Path,
) -> Result<f64> {
    if let Some(seconds) = finished(job, &prepared.fingerprint) {
        return Ok(seconds);
    }
    match pool.install(|| run_job(job, prepared, aovs)) {
        Err(Error::Interrupted(_)) => Err(Error::Interrupted(format!(
            "interrupted: {} of {} renders finished and kept in {}; the same command continues from them",
            done.0,
            done.1,
            dir.display()
        ))),
        result => result,
    }
}

/// Renders a job and returns its time in seconds. Only rendering is timed: building the scene
/// and loading the tables and grid are not.
fn run_job(job: &Job, prepared: &mut Prepared, aovs: bool) -> Result<f64> {
    let fingerprint = prepared.fingerprint.clone();
    prepared.scene.dual.light_samples = job.method.light_samples.or(prepared.light_samples);
    let r = &mut prepared.scene.render;
    r.integrator = job.method.integrator;
    r.sampling = Some(job.method.sampling);
    r.spp = job.spp;
    r.seed = job.seed;
    let dual = if job.method.integrator == IntegratorKind::Dual {
        if prepared.dual.is_none() {
            prepared.dual = dual_inputs(&prepared.scene, prepared.cache, &Silent)?;
        }
        prepared.dual.as_ref()
    } else {
        None
    };
    let start = Instant::now();
    let film = render_prepared(&prepared.scene, dual, &Silent)?;
    let seconds = start.elapsed().as_secs_f64();
    film.write_exr(&job.path, aovs)?;
    let meta = json!({"scene": fingerprint, "method": job.method.to_string(), "spp": job.spp, "seed": job.seed,
                      "seconds": seconds});
    write_atomically(&job.sidecar(), |tmp| Ok(std::fs::write(tmp, serde_json::to_vec_pretty(&meta)?)?))?;
    Ok(seconds)
}

/// Runs the comparison (or the part of it `args.part` names) and returns what it did, in a line.
/// The renders report to `progress` as they go.
pub fn run(args: &ConvergeSettings, progress: &dyn Progress) -> Result<String> {
    ensure!(!args.methods.is_empty(), "--methods: name at least one method");
    ensure!(!args.spp.is_empty() && args.spp.iter().all(|&s| s >= 1), "--spp: give spp values of at least 1");
    ensure!(args.seeds >= 1, "--seeds must be at least 1");
    if let Some(r) = &args.rect {
        ensure!(r.len() == 4 && r[0] < r[2] && r[1] < r[3], "--rect takes X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1");
    }
    // The scene's absolute path, so that a run's renders are recognized (their fingerprint names
    // the scene's files) whatever folder a part or a merge runs in.
    let scene_path = args.scene.clone().unwrap_or_else(|| PathBuf::from("scenes/default.json"));
    let scene_path = std::fs::canonicalize(&scene_path)
        .with_context(|| format!("{}: cannot find the scene", scene_path.display()))?;
    let overrides = Overrides {
        width: args.width,
        height: args.height,
        d_f: args.d_f,
        d_b: args.d_b,
        max_depth: args.max_depth,
        model: args.model,
        ..Overrides::default()
    };
    let file = SceneFile::load_with(Some(&scene_path), &overrides)?;
    let scene = file.build()?; // every value checked before any work
    for method in args.methods.iter().chain(&args.truth) {
        method
            .sampling
            .check_model(file.fiber.model)
            .map_err(|e| crate::error::invalid!("method {method}: sampling {e}"))?;
    }
    let mut spps = args.spp.clone();
    spps.sort_unstable();
    spps.dedup();
    let max_spp = *spps.last().expect("checked non-empty");
    let all_dual = args.methods.iter().all(|m| m.integrator == IntegratorKind::Dual);
    let truth_method = args.truth.unwrap_or(Method {
        integrator: if all_dual { IntegratorKind::Dual } else { IntegratorKind::Path },
        sampling: Sampling::Importance,
        light_samples: None,
    });
    let truth_spp = args.truth_spp.unwrap_or(8 * max_spp);
    let base_seed = file.render.seed;

    let renders = args.output.join("renders");
    std::fs::create_dir_all(&renders).with_context(|| format!("{}: cannot create the folder", renders.display()))?;
    let truth = Job {
        method: truth_method,
        spp: truth_spp,
        // Far from the run's seeds, so the truth's noise is independent of theirs.
        seed: base_seed.wrapping_add(1_000_003),
        path: args.output.join(format!("truth-{truth_method}-{truth_spp}spp.exr")),
    };
    let mut jobs = Vec::new();
    for &method in &args.methods {
        for k in 0..args.seeds as u64 {
            for &spp in &spps {
                let path = renders.join(format!("{method}-{spp}spp-seed{k}.exr"));
                jobs.push(Job { method, spp, seed: base_seed.wrapping_add(k), path });
            }
        }
    }

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    let cache = Cache::default_location();
    let light_samples = file.dual.light_samples;
    let mut prepared = Prepared { scene, fingerprint: fingerprint(&file), light_samples, cache: &cache, dual: None };
    let total: u64 = jobs.iter().map(|j| j.spp as u64).sum::<u64>() + truth_spp as u64;
    let all: Vec<&Job> = std::iter::once(&truth).chain(&jobs).collect();
    if let Some(part) = args.part {
        let mine = part_jobs(&all, part);
        let bar = progress.task("samples", Some(mine.iter().map(|j| j.spp as u64).sum()));
        interrupt::install();
        for (i, job) in mine.iter().enumerate() {
            bar.status(&format!("{} {} spp seed {} ({}/{})", job.method, job.spp, job.seed, i + 1, mine.len()));
            render_job(job, &mut prepared, std::ptr::eq(*job, &truth), &pool, (i, mine.len()), &args.output)?;
            bar.advance(job.spp as u64);
        }
        drop(bar);
        // With the scene's absolute path, so a merge may run in any folder.
        let args = ConvergeSettings { scene: Some(scene_path), ..args.clone() };
        let record = json!({"part": [part.k, part.n], "args": args});
        let path = args.output.join(format!("part-{}-of-{}.json", part.k, part.n));
        write_atomically(&path, |tmp| Ok(std::fs::write(tmp, serde_json::to_vec_pretty(&record)?)?))?;
        return Ok(format!(
            "part {}/{}: {} of the {} renders done in {}; when every part is done, `dualhair merge` their folders \
             (or rerun without --part if the parts share this folder)",
            part.k,
            part.n,
            mine.len(),
            all.len(),
            args.output.display()
        ));
    }
    let bar = progress.task("samples", Some(total));
    if !args.measure_only {
        interrupt::install();
    }
    let mut reused = 0;
    let mut seconds = Vec::new();
    for (i, job) in all.iter().enumerate() {
        bar.status(&format!("{} {} spp seed {} ({}/{})", job.method, job.spp, job.seed, i + 1, all.len()));
        let s = match finished(job, &prepared.fingerprint) {
            Some(s) => {
                reused += 1;
                s
            }
            None if args.measure_only => bail!(
                "{}: this render is missing or was made from another scene or settings or by another build: did every part finish?",
                job.path.display()
            ),
            None => render_job(job, &mut prepared, i == 0, &pool, (i, all.len()), &args.output)?,
        };
        seconds.push(s);
        bar.advance(job.spp as u64);
    }
    drop(bar);

    // Measures, from the files (the same whether a render is fresh or reused).
    let truth_film = Film::read_exr(&truth.path)?;
    let pixels = match &args.rect {
        Some(r) => rectangle(&truth_film, [r[0], r[1], r[2], r[3]]),
        None => hair_pixels(&truth_film),
    };
    ensure!(
        !pixels.is_empty(),
        "no pixels to measure: the truth has no fully covered hair pixel{}",
        if args.rect.is_some() { " in the rectangle" } else { "; give --rect" }
    );
    let truth_noise = mean_variance(&truth_film, &pixels);
    let mut rows = Vec::new();
    // The images of the current method and seed by spp: jobs come grouped by method and seed, so
    // only one group's images are ever held.
    let (mut group, mut images) = (None, BTreeMap::<u32, Film>::new());
    for (job, &secs) in jobs.iter().zip(&seconds[1..]) {
        if group != Some((job.method, job.seed)) {
            group = Some((job.method, job.seed));
            images.clear();
        }
        let film = Film::read_exr(&job.path)?;
        ensure!(
            (film.width, film.height) == (truth_film.width, truth_film.height),
            "{}: its size differs from the truth's",
            job.path.display()
        );
        let rel_variance =
            (job.spp % 2 == 0).then(|| images.get(&(job.spp / 2))).flatten().map(|half| mse(&film, half, &pixels));
        rows.push(Row {
            method: job.method,
            spp: job.spp,
            seed: job.seed,
            seconds: secs,
            mse: mse(&film, &truth_film, &pixels),
            rel_variance,
        });
        images.insert(job.spp, film);
    }
    let summary = Summary { args, truth: &truth, truth_noise, pixels: pixels.len(), rows: &rows };
    summary.write(&args.output)?;
    Ok(format!(
        "{} renders ({reused} reused), truth {truth_method} at {truth_spp} spp (noise {truth_noise:.3e} in MSE units), \
         {} pixels measured; wrote {}",
        jobs.len() + 1,
        pixels.len(),
        args.output.display()
    ))
}

/// `dualhair merge` of the folders of `converge --part K/N` runs: checks that they are the parts
/// 1..N of one run, gathers their renders in `out` and measures them as `converge` would.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<String> {
    let mut run: Option<(u32, ConvergeSettings)> = None;
    let mut seen = BTreeMap::new();
    for dir in dirs {
        let records: Vec<PathBuf> = std::fs::read_dir(dir)
            .with_context(|| format!("{}: cannot read the folder", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("part-") && n.ends_with(".json"))
            })
            .collect();
        ensure!(!records.is_empty(), "{}: no part-K-of-N.json: not a folder of `converge --part`", dir.display());
        for record in records {
            let text = std::fs::read(&record).with_context(|| format!("{}: cannot read", record.display()))?;
            let (part, mut args): ([u32; 2], ConvergeSettings) = serde_json::from_slice::<serde_json::Value>(&text)
                .ok()
                .and_then(|v| {
                    Some((
                        serde_json::from_value(v["part"].clone()).ok()?,
                        serde_json::from_value(v["args"].clone()).ok()?,
                    ))
                })
                .ok_or_else(|| invalid!("{}: not a part record of `converge --part`", record.display()))?;
            // Settings that do not change the renders may differ between parts.
            (args.output, args.threads) = (out.to_path_buf(), None);
            match &run {
                None => run = Some((part[1], args)),
                Some((n, first)) => ensure!(
                    *n == part[1] && *first == args,
                    "{}: a part of another run (its scene, methods, spp, seeds or part count differ)",
                    record.display()
                ),
            }
            seen.entry(part[0]).or_insert(dir.clone());
        }
        if std::fs::canonicalize(dir).ok() != std::fs::canonicalize(out).ok() {
            copy_renders(dir, out)?;
        }
    }
    let (n, mut args) = run.ok_or_else(|| invalid!("no converge folders to merge"))?;
    let missing: Vec<String> = (1..=n).filter(|k| !seen.contains_key(k)).map(|k| format!("{k}/{n}")).collect();
    ensure!(missing.is_empty(), "parts {} are missing", missing.join(", "));
    args.measure_only = true;
    self::run(&args, &Silent)
}

/// Copies a converge folder's renders and truth (images and their records) into `out`.
fn copy_renders(dir: &Path, out: &Path) -> Result<()> {
    for sub in ["", "renders"] {
        let (from, to) = (dir.join(sub), out.join(sub));
        std::fs::create_dir_all(&to).with_context(|| format!("{}: cannot create the folder", to.display()))?;
        let Ok(entries) = std::fs::read_dir(&from) else { continue };
        for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
            let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
            let wanted = if sub.is_empty() { name.starts_with("truth-") } else { path.is_file() };
            if wanted {
                std::fs::copy(&path, to.join(name))
                    .with_context(|| format!("{}: cannot copy into {}", path.display(), to.display()))?;
            }
        }
    }
    Ok(())
}

/// Mean and sample standard deviation.
fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 { v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) } else { 0.0 };
    (mean, var.sqrt())
}

/// One method at one spp, over the seeds.
struct Point {
    spp: u32,
    /// Mean render time.
    seconds: f64,
    /// Mean and standard deviation of the MSE.
    mse: (f64, f64),
    /// Number of seeds behind the means.
    seeds: usize,
    /// The same of the relative variance, where there is a half-spp render.
    rel_variance: Option<(f64, f64)>,
}

/// Per method, its points by increasing spp.
type Stats = BTreeMap<Method, Vec<Point>>;

struct Summary<'a> {
    args: &'a ConvergeSettings,
    truth: &'a Job,
    truth_noise: f64,
    pixels: usize,
    rows: &'a [Row],
}

impl Summary<'_> {
    fn stats(&self) -> Stats {
        let mut out: Stats = BTreeMap::new();
        let mut groups: BTreeMap<(Method, u32), Vec<&Row>> = BTreeMap::new();
        for r in self.rows {
            groups.entry((r.method, r.spp)).or_default().push(r);
        }
        for ((method, spp), rows) in groups {
            let seconds = mean_std(&rows.iter().map(|r| r.seconds).collect::<Vec<_>>()).0;
            let mse = mean_std(&rows.iter().map(|r| r.mse).collect::<Vec<_>>());
            let rv: Vec<f64> = rows.iter().filter_map(|r| r.rel_variance).collect();
            let rel_variance = (!rv.is_empty()).then(|| mean_std(&rv));
            out.entry(method).or_default().push(Point { spp, seconds, mse, seeds: rows.len(), rel_variance });
        }
        out
    }

    fn write(&self, dir: &Path) -> Result<()> {
        let mut csv = String::from("method,spp,seed,seconds,mse,rel_variance\n");
        for r in self.rows {
            let rv = r.rel_variance.map(|v| format!("{v:e}")).unwrap_or_default();
            writeln!(csv, "{},{},{},{},{:e},{rv}", r.method, r.spp, r.seed, r.seconds, r.mse)?;
        }
        write_atomically(&dir.join("results.csv"), |tmp| Ok(std::fs::write(tmp, &csv)?))?;

        let rows: Vec<_> = self
            .rows
            .iter()
            .map(|r| {
                json!({"method": r.method.to_string(), "spp": r.spp, "seed": r.seed, "seconds": r.seconds,
                       "mse": r.mse, "rel_variance": r.rel_variance})
            })
            .collect();
        let doc = json!({
            "scene": self.args.scene.as_ref().map_or("scenes/default.json".into(), |p| p.display().to_string()),
            "pixels": self.pixels,
            "region": self.args.rect.as_ref().map_or("hair pixels (truth alpha = 1)".to_string(), |r| format!("{r:?}")),
            "truth": {"method": self.truth.method.to_string(), "spp": self.truth.spp, "seed": self.truth.seed,
                      "noise_mse": self.truth_noise},
            "rows": rows,
        });
        write_atomically(&dir.join("results.json"), |tmp| Ok(std::fs::write(tmp, serde_json::to_vec_pretty(&doc)?)?))?;

        let stats = self.stats();
        write_atomically(&dir.join("summary.md"), |tmp| Ok(std::fs::write(tmp, self.markdown(&stats))?))?;
        for ext in ["png", "svg"] {
            draw_chart(&stats, false, self.truth_noise, &dir.join(format!("error_vs_spp.{ext}")))?;
            draw_chart(&stats, true, self.truth_noise, &dir.join(format!("error_vs_time.{ext}")))?;
        }
        Ok(())
    }

    fn markdown(&self, stats: &Stats) -> String {
        let mut md = String::new();
        let methods: Vec<&Method> = stats.keys().collect();
        let seeds = self.args.seeds;
        let _ = writeln!(md, "# Convergence\n");
        let _ = writeln!(
            md,
            "Ground truth: {} at {} spp; its own noise is {:.3e} in MSE units, so MSE values near it are \
             noise. Measured over {} pixels ({}). Values are mean +- standard deviation over {seeds} seed(s), \
             in linear radiance squared.\n",
            self.truth.method,
            self.truth.spp,
            self.truth_noise,
            self.pixels,
            if self.args.rect.is_some() { "the given rectangle" } else { "fully covered hair pixels" }
        );
        let table = |md: &mut String, title: &str, cell: &dyn Fn(&Point) -> String| {
            let _ = writeln!(md, "## {title}\n");
            let _ = writeln!(md, "| spp | {} |", methods.iter().map(|m| m.to_string()).collect::<Vec<_>>().join(" | "));
            let _ = writeln!(md, "|---|{}", "---|".repeat(methods.len()));
            let spps: std::collections::BTreeSet<u32> = stats.values().flatten().map(|p| p.spp).collect();
            for spp in spps {
                let cells: Vec<String> = methods
                    .iter()
                    .map(|m| stats[m].iter().find(|p| p.spp == spp).map_or(String::new(), cell))
                    .collect();
                let _ = writeln!(md, "| {spp} | {} |", cells.join(" | "));
            }
            let _ = writeln!(md);
        };
        table(&mut md, "Relative variance between successive doublings (thesis Table 6.1)", &|p| {
            p.rel_variance.map_or("-".into(), |(m, d)| format!("{m:.3e} +- {d:.1e}"))
        });
        table(&mut md, "Mean squared error against the ground truth (thesis Table 6.2)", &|p| {
            format!("{:.3e} +- {:.1e}", p.mse.0, p.mse.1)
        });
        table(&mut md, "Render time (seconds, mean)", &|p| format!("{:.3}", p.seconds));
        md
    }
}

/// Line colors of the methods, in order.
const COLORS: [RGBColor; 7] = [
    RGBColor(210, 40, 40),
    RGBColor(40, 70, 210),
    RGBColor(30, 150, 50),
    RGBColor(230, 140, 0),
    RGBColor(140, 40, 170),
    RGBColor(0, 150, 160),
    RGBColor(90, 90, 90),
];

/// Log-log chart of MSE (mean over seeds, bars +- its standard error) against spp, or against mean
/// render time, one line per method, with the truth's noise level dashed. The bars show how well
/// the plotted mean is known: a spread of +- one standard deviation of a skewed, heavy-tailed
/// MSE (uniform sampling at low spp) reaches below zero, off a log axis. A bar reaching below a
/// tenth of its mean (two seeds far apart) is cut there.
fn draw_chart(stats: &Stats, by_time: bool, truth_noise: f64, path: &Path) -> Result<()> {
    const SIZE: (u32, u32) = (1100, 760);
    let title = if by_time { "error vs. wall time (speed vs. accuracy)" } else { "error vs. samples per pixel" };
    let x_label = if by_time { "render time (s)" } else { "samples per pixel" };
    let draw = |root: &DrawingArea<_, Shift>| -> Result<()> {
        chart(root, stats, by_time, truth_noise, title, x_label).map_err(|e| invalid!("drawing the chart failed: {e}"))
    };
    match path.extension().and_then(|e| e.to_str()) {
        Some("png") => {
            let mut buf = vec![255u8; (SIZE.0 * SIZE.1 * 3) as usize];
            draw(&BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area())?;
            let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, buf).ok_or_else(|| invalid!("chart buffer size"))?;
            crate::output::write_png(path, &image)
        }
        Some("svg") => {
            let mut svg = String::new();
            chart(
                &SVGBackend::with_string(&mut svg, SIZE).into_drawing_area(),
                stats,
                by_time,
                truth_noise,
                title,
                x_label,
            )
            .map_err(|e| invalid!("drawing the chart failed: {e}"))?;
            write_atomically(path, |tmp| Ok(std::fs::write(tmp, &svg)?))
        }
        _ => bail!("{}: charts are .png or .svg", path.display()),
    }
}

fn chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    stats: &Stats,
    by_time: bool,
    truth_noise: f64,
    title: &str,
    x_label: &str,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    register_fonts();
    root.fill(&WHITE)?;
    let x = |p: &Point| if by_time { p.seconds.max(1e-6) } else { p.spp as f64 };
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0f64, f64::INFINITY, 0.0f64);
    let bar = |p: &Point| {
        let (mean, std) = p.mse;
        let error = std / (p.seeds as f64).sqrt();
        ((mean - error).max(mean * 0.1), mean + error)
    };
    for p in stats.values().flatten() {
        x0 = x0.min(x(p));
        x1 = x1.max(x(p));
        y0 = y0.min(bar(p).0);
        y1 = y1.max(bar(p).1);
    }
    if truth_noise > 0.0 {
        y0 = y0.min(truth_noise);
    }
    let (y0, y1) = ((y0 * 0.7).max(1e-30), (y1 * 1.4).max(1e-29));
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d((x0 * 0.8..x1 * 1.25).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc("mean squared error vs. ground truth (bars: standard error over seeds)")
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 14))
        .draw()?;
    for (k, (method, series)) in stats.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        let line: Vec<(f64, f64)> = series.iter().map(|p| (x(p), p.mse.0)).collect();
        chart
            .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))?
            .label(method.to_string())
            .legend(move |(px, py)| PathElement::new(vec![(px, py), (px + 24, py)], color.stroke_width(2)));
        chart.draw_series(line.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
        chart.draw_series(series.iter().map(|p| {
            let (low, high) = bar(p);
            ErrorBar::new_vertical(x(p), low, p.mse.0, high, color.stroke_width(1), 6)
        }))?;
    }
    if truth_noise > 0.0 {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0 * 0.8, truth_noise), (x1 * 1.25, truth_noise)],
                8,
                6,
                BLACK.stroke_width(1),
            ))?
            .label("ground truth's own noise")
            .legend(|(px, py)| PathElement::new(vec![(px, py), (px + 24, py)], BLACK.stroke_width(1)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .border_style(BLACK)
        .background_style(WHITE.mix(0.9))
        .label_font(("sans-serif", 14))
        .draw()?;
    root.present()?;
    Ok(())
}
