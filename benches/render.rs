//! Renderer benchmark: BVH build time and ray rates on a groom, then camera samples/s of `path`,
//! `dual` with shadow rays and `dual` with the forward-transmittance lookup, each `dual` with one
//! light sample per camera hit as a path has one per vertex (and the lookup's build time and
//! memory), on the bundled swatches and, given one, the groom; the samples/s of camera rays alone,
//! the ceiling of any integrator that traces one camera ray per sample; and `dual` with the
//! lookup at its default light samples per hit (4 under an environment map), in camera samples/s.
//! `cargo bench --bench render -- [HAIR_FILE]`; without a file it uses a generated scalp of 30,000
//! strands for the ray rates. All threads of the machine are used. With a Python that has `bpy`
//! (`DUALHAIR_BPY_PYTHON`, else `.venv-cycles/bin/python`), Blender Cycles path traces each scene
//! too (tools/cycles_reference.py), in the same run.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{CameraRaysAlone, bpy_python};
use dualhair::camera::Camera;
use dualhair::geometry::strands::Fibers;
use dualhair::integrators::IntegratorKind;
use dualhair::integrators::dual::options::ShadowMode;
use dualhair::integrators::dual::transmittance::ForwardLookup;
use dualhair::job::{dual_inputs, render_prepared};
use dualhair::progress::Silent;
use dualhair::render::render_all;
use dualhair::scene::{EnvSpec, HairSpec, OneOrRgb, SceneFile, SunSpec};
use glam::Vec3;
use precompute::strands::{Generator, Scalp, read_hair};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

fn rate(label: &str, count: usize, f: impl Fn() -> usize) {
    let start = Instant::now();
    let hits = f();
    let s = start.elapsed().as_secs_f64();
    println!(
        "{label}: {count} in {s:.3} s = {:.2} M/s ({:.1}% hit)",
        count as f64 / s / 1e6,
        100.0 * hits as f64 / count as f64
    );
}

/// Cycles' path-traced camera samples/s on `file` (M/s): from a render at `spp` and one at 1 spp,
/// so that turning the curves into Cycles' own and building its BVH are not counted, as this
/// benchmark does not count ours.
fn cycles_rate(python: &Path, file: &SceneFile, spp: u32) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, serde_json::to_string(file).unwrap()).unwrap();
    let seconds = |spp: u32| {
        let out = std::process::Command::new(python)
            .arg(format!("{}/tools/cycles_reference.py", env!("CARGO_MANIFEST_DIR")))
            .arg(&scene)
            .arg("-o")
            .arg(dir.path().join("cycles.exr"))
            .args(["--spp", &spp.to_string(), "--dualhair", env!("CARGO_BIN_EXE_dualhair")])
            .output()
            .unwrap();
        assert!(out.status.success(), "cycles_reference.py failed: {}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        let report: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
        report["render_seconds"].as_f64().unwrap()
    };
    let (one, many) = (seconds(1), seconds(spp));
    (file.camera.width * file.camera.height * (spp - 1) as usize) as f64 / (many - one) / 1e6
}

fn main() {
    // cargo bench passes `--bench`; the first other argument is the hair file.
    let file = std::env::args().skip(1).find(|a| !a.starts_with("--"));
    let strands = match &file {
        Some(f) => read_hair(Path::new(f)).unwrap_or_else(|e| panic!("{e}")),
        None => Generator::Scalp(Scalp { strands: 30_000, ..Default::default() }).generate().unwrap(),
    };
    println!(
        "hair: {} ({} strands, {} segments), {} threads",
        file.as_deref().unwrap_or("generated scalp"),
        strands.strand_count(),
        strands.segment_count(),
        rayon::current_num_threads()
    );
    let mut fibers = None;
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let start = Instant::now();
        fibers = Some(Fibers::new(&strands));
        best = best.min(start.elapsed().as_secs_f64());
    }
    let fibers = fibers.unwrap();
    println!("BVH build (best of 3): {best:.3} s");

    let (lo, hi) = strands.bounds();
    let camera = Camera::framing(lo, hi, 30.0, 1024, 1024);
    let n = camera.width * camera.height;
    rate("camera rays (closest hit)", n, || {
        (0..n)
            .into_par_iter()
            .filter(|&i| {
                let (o, d) = camera.ray((i % 1024) as f64 + 0.5, (i / 1024) as f64 + 0.5);
                fibers.closest_hit(o, d.as_vec3(), f32::INFINITY).is_some()
            })
            .count()
    });
    // Incoherent rays: random origins inside the bounds, random directions.
    let m = 1 << 20;
    let rays: Vec<(Vec3, Vec3)> = (0..m)
        .map(|i| {
            let mut rng = Pcg64Mcg::seed_from_u64(i as u64);
            let o = lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random());
            let d =
                Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5).normalize();
            (o, d)
        })
        .collect();
    rate("incoherent rays (closest hit)", m, || {
        rays.par_iter().filter(|(o, d)| fibers.closest_hit(*o, *d, f32::INFINITY).is_some()).count()
    });
    rate("incoherent rays (shadow)", m, || {
        rays.par_iter().filter(|(o, d)| fibers.occluded(*o, *d, f32::INFINITY)).count()
    });

    let root = env!("CARGO_MANIFEST_DIR");
    let cache = common::cache();
    // Camera samples/s of path, dual with shadow rays and dual with the lookup, in one run: the
    // swatches, and the groom when one is given (brown fiber, courtyard HDRI plus a sun).
    let mut scenes: Vec<(String, SceneFile)> = ["backlit_swatch", "blond", "brown", "black"]
        .iter()
        .map(|n| (n.to_string(), SceneFile::load(Path::new(&format!("{root}/scenes/{n}.json"))).unwrap()))
        .collect();
    if let Some(f) = &file {
        let mut groom = SceneFile::load(Path::new(&format!("{root}/scenes/brown.json"))).unwrap();
        groom.hair = HairSpec { file: Some(f.into()), generate: None, ..groom.hair };
        groom.hair.rotate = [0.0; 3];
        groom.lights.environment = Some(EnvSpec {
            file: Some(format!("{root}/scenes/hdri/courtyard.exr").into()),
            rotation: 180.0,
            ..EnvSpec::default()
        });
        groom.lights.sun =
            Some(SunSpec { direction: [0.3, -1.0, 0.5], irradiance: OneOrRgb::One(3.0), angular_diameter: 0.53 });
        (groom.camera.width, groom.camera.height) = (256, 256);
        scenes.push(("groom".into(), groom));
    }
    let spp = 16;
    let python = bpy_python();
    if python.is_none() {
        println!("(no Python with bpy: Cycles is not measured)");
    }
    println!(
        "| scene | path | dual (rays) | dual (lookup) | lookup / path | lookup / rays | camera rays alone / path | dual (lookup, default light samples) | lookup build | lookup memory | Cycles path | path / Cycles |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, mut file) in scenes {
        file.render.spp = spp;
        let mut rates = Vec::new();
        let mut build = (0.0, 0);
        // One light sample per camera hit, as a path samples one light per vertex; then the
        // default (`DualSpec::light_samples`), in camera samples/s.
        for (integrator, shadows, light_samples) in [
            (IntegratorKind::Path, ShadowMode::Rays, None),
            (IntegratorKind::Dual, ShadowMode::Rays, Some(1)),
            (IntegratorKind::Dual, ShadowMode::Lookup, Some(1)),
            (IntegratorKind::Dual, ShadowMode::Lookup, None),
        ] {
            file.render.integrator = integrator;
            file.dual.shadows = shadows;
            file.dual.light_samples = light_samples;
            let scene = file.build().unwrap();
            // Tables, grid and lookup first, so that only rendering is timed.
            let inputs = dual_inputs(&scene, &cache, &Silent).unwrap();
            if shadows == ShadowMode::Lookup && light_samples.is_some() {
                let start = Instant::now();
                let lookup = ForwardLookup::build(&scene.strands, &scene.lights, &file.dual.lookup, &Silent);
                build = (start.elapsed().as_secs_f64(), lookup.bytes());
            }
            let samples = scene.camera.width * scene.camera.height * spp as usize;
            let start = Instant::now();
            render_prepared(&scene, inputs.as_ref(), &Silent).unwrap();
            rates.push(samples as f64 / start.elapsed().as_secs_f64() / 1e6);
        }
        let scene = file.build().unwrap();
        let samples = scene.camera.width * scene.camera.height * spp as usize;
        let start = Instant::now();
        render_all(&scene.camera, &CameraRaysAlone(&scene.fibers), spp, scene.render.seed, false);
        let alone = samples as f64 / start.elapsed().as_secs_f64() / 1e6;
        // Cycles at 4x the spp: its per-sample time is the difference of two renders.
        file.render.integrator = IntegratorKind::Path;
        let cycles = python.as_deref().map(|p| cycles_rate(p, &file, 4 * spp));
        println!(
            "| {name} | {:.3} M/s | {:.3} M/s | {:.3} M/s | {:.1}x | {:.1}x | {:.1}x | {:.3} M/s ({}) | {:.1} s | {:.1} MB | {} | {} |",
            rates[0],
            rates[1],
            rates[2],
            rates[2] / rates[0],
            rates[2] / rates[1],
            alone / rates[0],
            rates[3],
            file.dual.light_samples(&scene.lights),
            build.0,
            build.1 as f64 / 1e6,
            cycles.map_or("-".into(), |c| format!("{c:.3} M/s")),
            cycles.map_or("-".into(), |c| format!("{:.2}x", rates[0] / c)),
        );
    }
}
