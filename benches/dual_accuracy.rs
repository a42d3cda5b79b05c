//! Accuracy and speed of `dual` against the path-traced reference (issue 5's table).
//!
//! `cargo bench --bench dual_accuracy [-- FILTER]`: for blond, brown and black curly swatches,
//! under their HDRI and under a backlight (a sun behind the hair in a dim sky), renders a path
//! traced reference, then `dual` and `path` at doubling spp (other seeds), and reports
//!
//! - relative RMSE of `dual` against the reference over hair pixels (compare module), with the
//!   part noise explains (both images' pixel variances), and the ratio of mean luminances, at the
//!   highest dual spp, and the error without the noise, sqrt(RMSE^2 - noise^2) (the expected squared
//!   error is the squared bias plus the noise variance);
//! - the wall time `dual` needs to come within 10% of that converged error, and the wall time
//!   `path` needs to reach the same error, measured in the same run.
//!
//! Sizes: DUALHAIR_ACC_SIZE (pixels, default 40), DUALHAIR_ACC_REF_SPP (default 16384),
//! DUALHAIR_ACC_DUAL_SPP (highest, default 8192), DUALHAIR_ACC_PATH_SPP (highest, default 4096).

use dualhair::cache::Cache;
use dualhair::compare::{hair_pixels, mean_luminance, relative_noise, relative_rmse};
use dualhair::film::Film;
use dualhair::render_cmd::{DualInputs, render_prepared};
use dualhair::scene::{EnvSpec, IntegratorKind, OneOrRgb, SceneFile, SunSpec};
use std::path::Path;
use std::time::Instant;

fn env_or(key: &str, default: u32) -> u32 {
    std::env::var(key).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// Renders a scene file, timing the render alone (not building the scene or loading the tables
/// and grid, which the cache holds after the first render).
fn timed_render(file: &SceneFile, cache: &Cache) -> (Film, f64) {
    let scene = file.build().unwrap();
    let inputs = DualInputs::load(&scene, cache, false).unwrap();
    let start = Instant::now();
    let film = render_prepared(&scene, inputs.as_ref(), false).unwrap();
    (film, start.elapsed().as_secs_f64())
}

/// (spp, seconds, relative RMSE) of renders at doubling spp, the time of each render alone, and
/// the last (highest spp) image.
fn sweep(
    file: &SceneFile,
    cache: &Cache,
    max_spp: u32,
    reference: &Film,
    pixels: &[usize],
) -> (Vec<(u32, f64, f64)>, Film) {
    let mut out = Vec::new();
    let mut spp = 1;
    loop {
        let mut f = file.clone();
        f.render.spp = spp;
        f.render.seed = 1000 + spp as u64;
        let (film, secs) = timed_render(&f, cache);
        out.push((spp, secs, relative_rmse(&film, reference, pixels)));
        if spp * 2 > max_spp {
            return (out, film);
        }
        spp *= 2;
    }
}

/// First render in a sweep whose error is at most `target`.
fn first_within(sweep: &[(u32, f64, f64)], target: f64) -> Option<(u32, f64)> {
    sweep.iter().find(|s| s.2 <= target).map(|s| (s.0, s.1))
}

fn main() {
    let filter = std::env::args().skip(1).find(|a| !a.starts_with('-')).unwrap_or_default();
    let size = env_or("DUALHAIR_ACC_SIZE", 40) as usize;
    let (ref_spp, dual_spp, path_spp) = (
        env_or("DUALHAIR_ACC_REF_SPP", 16384),
        env_or("DUALHAIR_ACC_DUAL_SPP", 8192),
        env_or("DUALHAIR_ACC_PATH_SPP", 4096),
    );
    let root = env!("CARGO_MANIFEST_DIR");
    let cache = Cache::at(format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")));
    println!(
        "{size}x{size} pixels, reference {ref_spp} spp path; dual up to {dual_spp} spp, path up to {path_spp} spp"
    );
    println!(
        "| scene | light | mean ratio dual/path | rel. RMSE | noise part | without noise | dual time to converge | path time to same error | speedup |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for hair in ["blond", "brown", "black"] {
        for light in ["hdri", "backlight"] {
            if !format!("{hair} {light}").contains(&filter) {
                continue;
            }
            let mut file = SceneFile::load(Path::new(&format!("{root}/scenes/{hair}.json"))).unwrap();
            file.camera.width = size;
            file.camera.height = size;
            if light == "backlight" {
                file.lights.environment = Some(EnvSpec { color: Some([0.02, 0.025, 0.03]), ..EnvSpec::default() });
                file.lights.sun = Some(SunSpec {
                    direction: [0.2, 1.0, 0.35],
                    irradiance: OneOrRgb::One(3.0),
                    angular_diameter: 0.53,
                });
            }
            let mut reference = file.clone();
            reference.render.integrator = IntegratorKind::Path;
            reference.render.spp = ref_spp;
            let (reference, ref_secs) = timed_render(&reference, &cache);
            let pixels = hair_pixels(&reference);

            let mut dual = file.clone();
            dual.render.integrator = IntegratorKind::Dual;
            let (dual_sweep, converged) = sweep(&dual, &cache, dual_spp, &reference, &pixels);
            let error = relative_rmse(&converged, &reference, &pixels);
            let noise = relative_noise(&converged, &reference, &pixels);
            let ratio = mean_luminance(&converged, &pixels) / mean_luminance(&reference, &pixels);

            let mut path = file.clone();
            path.render.integrator = IntegratorKind::Path;
            let (path_sweep, _) = sweep(&path, &cache, path_spp, &reference, &pixels);
            let target = 1.1 * error;
            let dual_hit = first_within(&dual_sweep, target);
            let path_hit = first_within(&path_sweep, target);
            let show = |h: Option<(u32, f64)>| h.map_or("not reached".into(), |(s, t)| format!("{t:.3} s ({s} spp)"));
            let speedup = match (dual_hit, path_hit) {
                (Some(d), Some(p)) => format!("{:.2}x", p.1 / d.1),
                (Some(d), None) => {
                    format!("> {:.2}x", path_sweep.iter().map(|s| s.1).fold(0.0, f64::max) / d.1)
                }
                _ => "-".into(),
            };
            println!(
                "| {hair} | {light} | {ratio:.3} | {:.1}% | {:.1}% | {:.1}% | {} | {} | {speedup} |",
                100.0 * error,
                100.0 * noise,
                100.0 * (error * error - noise * noise).max(0.0).sqrt(),
                show(dual_hit),
                show(path_hit)
            );
            eprintln!("  reference {ref_secs:.1} s, {} hair pixels", pixels.len());
            eprintln!("  dual sweep (spp, s, err): {dual_sweep:.4?}");
            eprintln!("  path sweep (spp, s, err): {path_sweep:.4?}");
        }
    }
}
