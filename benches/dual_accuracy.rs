//! Accuracy of `dual` against the path-traced reference, term by term.
//!
//! `cargo bench --bench dual_accuracy [-- FILTER]`: for blond, brown and black curly swatches (and
//! real grooms named in DUALHAIR_ACC_GROOMS), each under its HDRI, a front sun and a back sun,
//! renders a path-traced reference and `dual` with each model variant, and prints two tables:
//!
//! - diagnostics: each image's mean luminance over fully covered hair pixels split into the
//!   terms of [`Term`] (path: by the events on the path; dual: by its terms), as shares of the
//!   reference's total, so the table shows which dual term misses which light;
//! - accuracy: mean luminance ratio dual/path and the relative RMSE of 4x4-pixel block means
//!   over fully covered blocks, with the part both images' noise explains and the rest (bias),
//!   and the mean ratio over every pixel with hair in it (silhouettes carry a back sun's light).
//!
//! - equal time: `path`'s error at `dual`'s render time over `dual`'s (4x4 blocks, the truth's own
//!   error removed from both): a test `path` render (seed 2, DUALHAIR_ACC_PATH_SPP, default the
//!   `dual` spp) gives `path`'s error e_p in t_p seconds, e_p sqrt(t_p / t_dual) at `dual`'s time
//!   t_dual (noise falls as 1 / sqrt(time), `path` has no bias). 3 means `path` needs about 10x
//!   `dual`'s time to match it; below 1 `dual` has no reason to exist on that row. Renders are
//!   timed alone, one after another, caches warm.
//!
//! The `path` line's error column is the test render's own error (all noise), to compare with
//! `dual`'s noise part at the same spp.
//!
//! On stderr, for each `dual` render, where its terms go wrong: the fully covered blocks in thirds
//! by the reference's share of single scattering (least to most directly lit), each term's light
//! over the reference's in each third.
//!
//! With DUALHAIR_ACC_DEFAULT=1 the bundled default scene (`scenes/default.json`, its own lights)
//! is a row too.
//!
//! With DUALHAIR_ACC_SWEEP=1 it also measures speed: the wall time `dual` needs to come within 10%
//! of its converged error, and the time `path` needs for that error, in the same run.
//!
//! Settings: DUALHAIR_ACC_SIZE (pixels, default 48), DUALHAIR_ACC_REF_SPP (default 8192),
//! DUALHAIR_ACC_DUAL_SPP (default 2048), DUALHAIR_ACC_MODELS (comma-separated variants, each
//! `NAME[@D_F/D_B][:SHADOWS]`, NAME as for `render --dual-model`, SHADOWS `lookup` (default) or `rays`;
//! default `zinke2008@0.7/0.7:rays,two_stream:rays,two_stream`),
//! DUALHAIR_ACC_GROOMS (comma-separated .hair files), DUALHAIR_ACC_DUAL (a JSON object whose keys replace those of
//! the scene's `dual` section, e.g. `{"light_samples": 4}`),
//! DUALHAIR_ACC_KEEP=1 (write each `dual` render and the test `path` render to `target/dual-accuracy/kept/`),
//! DUALHAIR_ACC_SAMPLING (`dual`'s direction sampling, as for `render --sampling`), DUALHAIR_ACC_SEEDS (default 1: with more,
//! each `dual` render is repeated with seeds 1, 2, ..., its mean ratio is the mean over seeds with
//! its standard error, its noise part is measured from the block differences of seeds 1 and 2
//! (the variance channels miss the rare bright samples of a back sun) and `path`'s from two test
//! renders with the same seeds the same way (single scattering is the same
//! estimator with the same random numbers in both), and a model rendered both with `rays` and with the lookup gets a line
//! `lookup / rays` with the mean and standard error over seeds of the ratio of the two renders of
//! one seed: same seed, same light directions, so their difference is the lookup's alone).
//! References are kept in `target/dual-accuracy/` and reused by name, size and spp: delete that
//! folder after changing the path tracer or a scene.

use dualhair::analysis::compare::{
    block_relative_difference, block_relative_rmse, hair_pixels, mean_luminance, rectangle, relative_rmse,
};
use dualhair::film::Film;
use dualhair::integrators::Choice;
use dualhair::integrators::Term;
use dualhair::integrators::dual::DualModel;
use dualhair::integrators::dual::cache::Cache;
use dualhair::integrators::dual::options::ShadowMode;
use dualhair::integrators::{IntegratorKind, Sampling};
use dualhair::job::{dual_inputs, render_prepared};
use dualhair::progress::Silent;
use dualhair::scene::{EnvSpec, HairSpec, OneOrRgb, SceneFile, SunSpec};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn env_or<T: std::str::FromStr>(key: &str, default: T) -> T {
    std::env::var(key).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// Renders a scene file, timing the render alone (not building the scene or loading the tables
/// and grid, which the cache holds after the first render); `terms` collects the per-term split.
fn timed_render(file: &SceneFile, cache: &Cache, terms: bool) -> (Film, f64) {
    let mut scene = file.build().unwrap();
    scene.render.terms = terms;
    let inputs = dual_inputs(&scene, cache, &Silent).unwrap();
    let start = Instant::now();
    let film = render_prepared(&scene, inputs.as_ref(), &Silent).unwrap();
    (film, start.elapsed().as_secs_f64())
}

/// The path-traced reference, from `dir` when an earlier run left it there.
fn reference(file: &SceneFile, cache: &Cache, dir: &Path, name: &str) -> Film {
    let path = dir.join(format!("{name}-{}-{}.exr", file.camera.width, file.render.spp));
    if let Ok(film) = Film::read_exr(&path) {
        return film;
    }
    let (film, secs) = timed_render(file, cache, true);
    eprintln!("  reference {name}: {secs:.1} s");
    film.write_exr(&path, true).unwrap();
    film
}

/// (spp, seconds, relative RMSE) of renders at doubling spp.
fn sweep(file: &SceneFile, cache: &Cache, max_spp: u32, reference: &Film, pixels: &[usize]) -> Vec<(u32, f64, f64)> {
    let mut out = Vec::new();
    let mut spp = 1;
    while spp <= max_spp {
        let mut f = file.clone();
        f.render.spp = spp;
        f.render.seed = 1000 + spp as u64;
        // Speed is timed as users render: without the split.
        let (film, secs) = timed_render(&f, cache, false);
        out.push((spp, secs, relative_rmse(&film, reference, pixels)));
        spp *= 2;
    }
    out
}

/// Mean luminance of each term over `pixels`.
fn term_means(film: &Film, pixels: &[usize]) -> [f64; 4] {
    Term::ALL.map(|t| pixels.iter().map(|&i| film.terms[i][t as usize].luminance()).sum::<f64>() / pixels.len() as f64)
}

fn main() {
    let filter = std::env::args().skip(1).find(|a| !a.starts_with('-')).unwrap_or_default();
    let size: usize = env_or("DUALHAIR_ACC_SIZE", 48);
    let (ref_spp, dual_spp): (u32, u32) = (env_or("DUALHAIR_ACC_REF_SPP", 8192), env_or("DUALHAIR_ACC_DUAL_SPP", 2048));
    let models: String = env_or("DUALHAIR_ACC_MODELS", "zinke2008@0.7/0.7:rays,two_stream:rays,two_stream".to_string());
    let grooms: String = env_or("DUALHAIR_ACC_GROOMS", String::new());
    let root = env!("CARGO_MANIFEST_DIR");
    let cache = Cache::at(format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")));
    let refs = PathBuf::from(format!("{root}/target/dual-accuracy"));
    std::fs::create_dir_all(&refs).unwrap();
    println!("{size}x{size} pixels, reference path {ref_spp} spp, dual {dual_spp} spp; 4x4 blocks");
    println!(
        "| hair | light | image | d_f, d_b | single | forward | back | multiback | mean ratio | block rel. RMSE (noise), bias | mean ratio, all hair pixels | equal-time error ratio |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let path_spp: u32 = env_or("DUALHAIR_ACC_PATH_SPP", dual_spp);
    let seed_count: u64 = env_or("DUALHAIR_ACC_SEEDS", 1);
    let mut hairs: Vec<(String, Option<PathBuf>)> = ["blond", "brown", "black"].map(|h| (h.to_string(), None)).to_vec();
    if std::env::var("DUALHAIR_ACC_DEFAULT").is_ok_and(|v| v == "1") {
        hairs.push(("default".to_string(), None));
    }
    for g in grooms.split(',').filter(|g| !g.is_empty()) {
        let stem = Path::new(g).file_stem().unwrap().to_string_lossy().to_string();
        for color in ["blond", "brown", "black"] {
            hairs.push((format!("{stem}/{color}"), Some(PathBuf::from(g))));
        }
    }
    for (hair, groom) in &hairs {
        let lights: &[&str] = if hair == "default" { &["scene"] } else { &["hdri", "front", "back"] };
        for &light in lights {
            let name = format!("{hair} {light}");
            if !name.contains(&filter) {
                continue;
            }
            let color = hair.rsplit('/').next().unwrap();
            let mut file = SceneFile::load(Path::new(&format!("{root}/scenes/{color}.json"))).unwrap();
            if let Some(g) = groom {
                file.hair = HairSpec { file: Some(g.clone()), generate: None, ..file.hair.clone() };
                file.hair.rotate = [0.0; 3];
                file.lights.environment = Some(EnvSpec {
                    file: Some(PathBuf::from(format!("{root}/scenes/hdri/courtyard.exr"))),
                    rotation: 180.0,
                    ..EnvSpec::default()
                });
            }
            file.camera.width = size;
            file.camera.height = size;
            let sun = |direction| SunSpec { direction, irradiance: OneOrRgb::One(3.0), angular_diameter: 0.53 };
            let dim_sky = Some(EnvSpec { color: Some([0.02, 0.025, 0.03]), ..EnvSpec::default() });
            match light {
                "front" => (file.lights.environment, file.lights.sun) = (dim_sky, Some(sun([0.3, -1.0, 0.5]))),
                "back" => (file.lights.environment, file.lights.sun) = (dim_sky, Some(sun([0.2, 1.0, 0.35]))),
                _ => {}
            }
            let mut path = file.clone();
            path.render.integrator = IntegratorKind::Path;
            path.render.spp = ref_spp;
            let reference = reference(&path, &cache, &refs, &name.replace(['/', ' '], "_"));
            let pixels = hair_pixels(&reference);
            let any_hair: Vec<usize> = (0..reference.alpha.len()).filter(|&i| reference.alpha[i] > 0.0).collect();
            let total = mean_luminance(&reference, &pixels);
            let shares = |film: &Film| term_means(film, &pixels).map(|t| format!("{:.3}", t / total)).join(" | ");
            // `path`'s own error from its error E against the truth (both unbiased, independent
            // seeds): E^2 = e^2 (1 + P / R), the truth's error e sqrt(P / R), removed from every
            // error measured against it. The truth's variance estimates are no help under a back
            // sun: a few bright samples dominate them.
            let mut test = path.clone();
            (test.render.spp, test.render.seed) = (path_spp, 2);
            let (test, path_secs) = timed_render(&test, &cache, true);
            let ratio = path_spp as f64 / ref_spp as f64;
            let path_error = block_relative_rmse(&test, &reference, 4).map(|(e, _)| e / (1.0 + ratio).sqrt());
            let truth_error = path_error.unwrap_or(0.0) * ratio.sqrt();
            let own = |e: f64| (e * e - truth_error * truth_error).max(0.0).sqrt();
            // In the error column, `path`'s own error at the test's spp: all noise, to set beside
            // `dual`'s noise at its spp.
            let mut path_at = path_error.map_or("-".into(), |e| format!("{:.1}% at {path_spp} spp", 100.0 * e));
            // With several seeds, `path`'s noise at that spp as `dual`'s is measured: from the
            // difference of two renders with `dual`'s seeds 1 and 2, whose single scattering is
            // `dual`'s sample for sample, so that the two noises differ by the rest alone.
            if seed_count > 1 {
                let mut other = path.clone();
                (other.render.spp, other.render.seed) = (path_spp, 1);
                let other = timed_render(&other, &cache, false).0;
                if let Some(d) = block_relative_difference(&test, &other, &reference, 4) {
                    path_at += &format!(" (noise {:.1}%)", 100.0 * d / 2f64.sqrt());
                }
            }
            println!("| {hair} | {light} | path | - | {} | 1 | {path_at} | 1 | - |", shares(&reference));
            // Each model's mean ratio per seed, by (model with factors, shadows).
            let mut ratios: Vec<((&str, &str), Vec<f64>)> = Vec::new();
            for spec in models.split(',') {
                let (spec_model, shadows) = spec.split_once(':').unwrap_or((spec, "lookup"));
                let (model, d) = spec_model.split_once('@').unwrap_or((spec_model, ""));
                let mut dual = file.clone();
                dual.render.integrator = IntegratorKind::Dual;
                dual.render.spp = dual_spp;
                dual.render.seed = 1;
                dual.dual.model = DualModel::named(model).unwrap();
                dual.dual.shadows = ShadowMode::named(shadows).unwrap();
                if let Ok(sampling) = std::env::var("DUALHAIR_ACC_SAMPLING") {
                    dual.render.sampling = Some(Sampling::named(&sampling).unwrap());
                }
                if let Ok(settings) = std::env::var("DUALHAIR_ACC_DUAL") {
                    // Each key replaces that field of the scene's `dual` section.
                    let mut spec = serde_json::to_value(&dual.dual).unwrap();
                    let serde_json::Value::Object(fields) = serde_json::from_str(&settings).unwrap() else {
                        panic!("DUALHAIR_ACC_DUAL must be a JSON object, got {settings}")
                    };
                    spec.as_object_mut().unwrap().extend(fields);
                    dual.dual = serde_json::from_value(spec).unwrap();
                }
                if let Some((f, b)) = d.split_once('/') {
                    (dual.dual.d_f, dual.dual.d_b) = (f.parse().unwrap(), b.parse().unwrap());
                }
                let (film, secs) = timed_render(&dual, &cache, true);
                // The renders, by row and variant, for a closer look (DUALHAIR_ACC_KEEP=1).
                let keep = |film: &Film, what: &str| {
                    if std::env::var("DUALHAIR_ACC_KEEP").is_ok_and(|v| v == "1") {
                        let kept = refs.join("kept");
                        std::fs::create_dir_all(&kept).unwrap();
                        let stem = format!("{name}-{what}").replace(['/', ' ', ':', '@'], "_");
                        film.write_exr(&kept.join(format!("{stem}.exr")), true).unwrap();
                    }
                };
                keep(&film, spec);
                keep(&test, "path");
                let mut seeds = vec![mean_luminance(&film, &pixels) / total];
                let mut second = None;
                for seed in 2..=seed_count {
                    dual.render.seed = seed;
                    let other = timed_render(&dual, &cache, true).0;
                    seeds.push(mean_luminance(&other, &pixels) / total);
                    keep(&other, &format!("{spec}-seed{seed}"));
                    second.get_or_insert(other);
                }
                // The error's bias part: what the noise does not explain. With a second seed the
                // noise is measured from the two renders' difference; else the variance channels
                // estimate it (too low where a few bright samples dominate, a back sun).
                let blocks = block_relative_rmse(&film, &reference, 4).map_or("no full block".into(), |(e, n)| {
                    let (noise, truth) =
                        match second.as_ref().and_then(|s| block_relative_difference(&film, s, &reference, 4)) {
                            Some(d) => (d / 2f64.sqrt(), truth_error),
                            None => (n, 0.0),
                        };
                    let bias = (e * e - noise * noise - truth * truth).max(0.0).sqrt();
                    format!("{:.1}% ({:.1}%), bias {:.1}%", 100.0 * e, 100.0 * noise, 100.0 * bias)
                });
                let all = mean_luminance(&film, &any_hair) / mean_luminance(&reference, &any_hair);
                let equal_time = match (path_error, block_relative_rmse(&film, &reference, 4)) {
                    (Some(p), Some((e, _))) => format!("{:.2}", p * (path_secs / secs).sqrt() / own(e)),
                    _ => "-".into(),
                };
                println!(
                    "| {hair} | {light} | dual {model} ({shadows}) | {}, {} | {} | {} | {blocks} | {all:.3} | {equal_time} |",
                    dual.dual.d_f,
                    dual.dual.d_b,
                    shares(&film),
                    mean_and_error(&seeds),
                );
                ratios.push(((spec_model, shadows), seeds));
                eprintln!("  {name} {spec}: {}", by_lit_share(&film, &reference));
                eprintln!(
                    "  {name} {spec}: {secs:.1} s (path at {path_spp} spp {path_secs:.1} s), {} hair pixels",
                    pixels.len()
                );
                if std::env::var("DUALHAIR_ACC_SWEEP").is_ok_and(|v| v == "1") {
                    let target = 1.1 * relative_rmse(&film, &reference, &pixels);
                    let mut p = file.clone();
                    p.render.integrator = IntegratorKind::Path;
                    let d = sweep(&dual, &cache, dual_spp, &reference, &pixels);
                    let p = sweep(&p, &cache, ref_spp / 2, &reference, &pixels);
                    let first = |s: &[(u32, f64, f64)]| s.iter().find(|s| s.2 <= target).map(|s| (s.0, s.1));
                    eprintln!("  time to {target:.4}: dual {:?}, path {:?}", first(&d), first(&p));
                }
            }
            for ((model, _), rays) in ratios.iter().filter(|r| r.0.1 == "rays") {
                if let Some((_, lookup)) = ratios.iter().find(|r| r.0 == (*model, "lookup")) {
                    let paired: Vec<f64> = lookup.iter().zip(rays).map(|(l, r)| l / r).collect();
                    println!(
                        "| {hair} | {light} | {model}: lookup / rays | | | | | | {} | | |",
                        mean_and_error(&paired)
                    );
                }
            }
        }
    }
}

/// Where in the image `dual`'s terms go wrong: the 4x4 blocks the reference covers fully, in
/// thirds by the share of single scattering in the reference (low: light that crossed hair;
/// high: the directly lit edge), with `film`'s forward and backward (one or more events) light
/// over the reference's in each third.
fn by_lit_share(film: &Film, reference: &Film) -> String {
    let full: std::collections::HashSet<usize> = hair_pixels(reference).into_iter().collect();
    let mut blocks: Vec<(f64, [f64; 4], [f64; 4])> = Vec::new();
    for by in 0..reference.height / 4 {
        for bx in 0..reference.width / 4 {
            let pixels = rectangle(reference, [4 * bx, 4 * by, 4 * bx + 4, 4 * by + 4]);
            if pixels.iter().all(|i| full.contains(i)) {
                let (f, r) = (term_means(film, &pixels), term_means(reference, &pixels));
                blocks.push((r[0] / r.iter().sum::<f64>().max(1e-300), f, r));
            }
        }
    }
    if blocks.len() < 3 {
        return "too few full blocks for thirds".into();
    }
    blocks.sort_by(|a, b| a.0.total_cmp(&b.0));
    let third = blocks.len() / 3;
    let ratio = |part: &[(f64, [f64; 4], [f64; 4])], terms: &[usize]| {
        let sum = |k: usize| {
            part.iter().map(|b| terms.iter().map(|&t| if k == 0 { b.1[t] } else { b.2[t] }).sum::<f64>()).sum::<f64>()
        };
        format!("{:.2}", sum(0) / sum(1).max(1e-300))
    };
    let thirds = [&blocks[..third], &blocks[third..2 * third], &blocks[2 * third..]];
    let row = |terms: &[usize]| thirds.map(|p| ratio(p, terms)).join("/");
    format!(
        "over path by thirds of {} blocks, least to most directly lit: total {}, single {}, forward {}, backward {}",
        blocks.len(),
        row(&[0, 1, 2, 3]),
        row(&[0]),
        row(&[1]),
        row(&[2, 3])
    )
}

/// "mean" of one value, "mean +- standard error of the mean" of several.
fn mean_and_error(values: &[f64]) -> String {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return format!("{mean:.3}");
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    format!("{mean:.4} +- {:.4}", (var / n).sqrt())
}
