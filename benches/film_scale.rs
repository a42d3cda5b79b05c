//! Film-scale groom benchmark: time and memory of every stage of a render of a
//! production-sized groom, and its samples/s.
//!
//! `cargo bench --bench film_scale [-- STRANDS POINTS]`: generates a scalp groom (default 150,000
//! strands of 66 points: 9.9M points, 9.75M segments; fiber radius 1/1000 of the scalp's, as in the
//! bundled groom and the real grooms of docs/usage.md), writes it as .hair to `target/film-scale/`, then, stage by stage as
//! `dualhair render` runs them, loads it, builds the BVH, the density grid and the forward-
//! transmittance lookup (brown fiber under the courtyard HDRI, 160x160 camera), and renders with
//! `path` and `dual` (lookup), and with camera rays alone (the ceiling of `dual`). For each stage it prints the wall time, the process's resident
//! memory after it and its peak during the stage (Linux: `VmRSS`, and `VmHWM` reset before the
//! stage through `/proc/self/clear_refs`), and what the stage keeps. All threads of the machine
//! are used. The fiber's dual-scattering tables come from the test cache (they do not depend on
//! the groom).

#[path = "../tests/common/mod.rs"]
mod common;

use common::CameraRaysAlone;
use dualhair::film::Film;
use dualhair::geometry::meshes::Meshes;
use dualhair::integrators::IntegratorKind;
use dualhair::integrators::dual::inputs::DualInputs;
use dualhair::integrators::dual::transmittance::ForwardLookup;
use dualhair::job::render_prepared;
use dualhair::progress::Silent;
use dualhair::render::render_all;
use dualhair::scene::{EnvSpec, HairSpec, Scene, SceneFile};
use precompute::density::DensityGrid;
use precompute::strands::{Generator, Scalp, write_hair};
use std::path::Path;
use std::time::Instant;

/// (resident, peak resident since the last [`reset_peak`]) of this process, in MB.
fn memory() -> (f64, f64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kb = |key: &str| -> f64 {
        let line = status.lines().find(|l| l.starts_with(key));
        line.and_then(|l| l.split_whitespace().nth(1)).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
    };
    (kb("VmRSS:") * 1.024e-3, kb("VmHWM:") * 1.024e-3)
}

/// Sets the peak resident memory back to the current (Linux 4.0+).
fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Runs one stage and prints a table row: its time, the memory after it and its peak.
fn stage<T>(name: &str, keeps: impl FnOnce(&T) -> String, f: impl FnOnce() -> T) -> T {
    reset_peak();
    let start = Instant::now();
    let out = f();
    let seconds = start.elapsed().as_secs_f64();
    let (now, peak) = memory();
    println!("| {name} | {seconds:.2} s | {now:.0} MB | {peak:.0} MB | {} |", keeps(&out));
    out
}

fn mb(bytes: usize) -> String {
    format!("{:.0} MB", bytes as f64 / 1e6)
}

fn main() {
    let numbers: Vec<u32> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (strands, points) = (numbers.first().copied().unwrap_or(150_000), numbers.get(1).copied().unwrap_or(66));
    let root = env!("CARGO_MANIFEST_DIR");
    let dir = Path::new(root).join("target/film-scale");
    std::fs::create_dir_all(&dir).unwrap();
    let hair = dir.join(format!("scalp_{strands}x{points}.hair"));
    println!("{} threads; the groom: {}", rayon::current_num_threads(), hair.display());
    println!("| stage | time | resident after | peak during | kept |");
    println!("|---|---|---|---|---|");
    let scalp = Scalp { strands, points, radius: 0.0005, ..Default::default() };
    let generated = stage(
        "generate",
        |s: &precompute::strands::Strands| format!("{} points", s.points.len()),
        || Generator::Scalp(scalp).generate().unwrap(),
    );
    let file = std::fs::File::create(&hair).unwrap();
    write_hair(std::io::BufWriter::new(file), &generated, "film-scale benchmark").unwrap();
    drop(generated);

    let mut file = SceneFile::load(Path::new(&format!("{root}/scenes/brown.json"))).unwrap();
    file.hair = HairSpec { file: Some(hair.clone()), generate: None, ..file.hair };
    file.hair.rotate = [0.0; 3];
    file.lights.sun = None;
    file.lights.environment = Some(EnvSpec {
        file: Some(format!("{root}/scenes/hdri/courtyard.exr").into()),
        rotation: 180.0,
        ..EnvSpec::default()
    });
    (file.camera.width, file.camera.height) = (160, 160);
    file.render.spp = 64;

    let strands = stage(
        "load .hair",
        |s: &precompute::strands::Strands| {
            let bytes = s.points.len() * 12 + s.radii.len() * 4 + s.offsets.len() * 4;
            format!("strands {} ({} segments)", mb(bytes), s.segment_count())
        },
        || file.hair().unwrap(),
    );
    let fibers = stage(
        "BVH",
        |f: &dualhair::geometry::strands::Fibers| format!("BVH and capsules {}", mb(f.bytes())),
        || dualhair::geometry::strands::Fibers::new(&strands),
    );
    let mut scene = Scene {
        camera: file.camera(&strands).unwrap(),
        lights: file.lights().unwrap(),
        strands,
        fibers,
        meshes: Meshes::default(),
        fiber: file.fiber,
        render: file.render.clone(),
        dual: file.dual.clone(),
    };
    let tables = common::cache().tables(&scene.fiber, scene.dual.d_b, &Silent).unwrap();
    let grid = stage(
        "density grid",
        |g: &DensityGrid| format!("{} bricks of 8^3 voxels, {}", g.bricks().count(), mb(g.bricks().count() * 2048)),
        || DensityGrid::voxelize(&scene.strands, DensityGrid::auto_voxel_size(&scene.strands)),
    );
    let lookup = stage(
        "forward-transmittance lookup",
        |l: &ForwardLookup| format!("{} maps, {}", l.maps(), mb(l.bytes())),
        || ForwardLookup::build(&scene.strands, &scene.lights, &scene.dual.lookup, &Silent),
    );
    let inputs = DualInputs { tables, grid, lookup: Some(lookup) };
    let samples = (file.camera.width * file.camera.height) as f64 * file.render.spp as f64;
    let spp = format!("{} spp", file.render.spp);
    let rate = |r: &(f64, f64)| format!("{:.3} M samples/s ({:.0}% hit hair)", r.0, 100.0 * r.1);
    let timed = |render: &dyn Fn() -> Film| {
        let start = Instant::now();
        let film = render();
        (samples / start.elapsed().as_secs_f64() / 1e6, film.alpha.iter().sum::<f64>() / film.alpha.len() as f64)
    };
    let mut rates = Vec::new();
    for integrator in [IntegratorKind::Path, IntegratorKind::Dual] {
        scene.render.integrator = integrator;
        let dual = (integrator == IntegratorKind::Dual).then_some(&inputs);
        rates.push(stage(&format!("render `{integrator:?}`, {spp}"), rate, || {
            timed(&|| render_prepared(&scene, dual, &Silent).unwrap())
        }));
    }
    let alone = stage(&format!("camera rays alone, {spp}"), rate, || {
        timed(&|| {
            let sums = render_all(&scene.camera, &CameraRaysAlone(&scene.fibers), file.render.spp, 1, false);
            Film::from_sums(&sums.unwrap())
        })
    });
    println!(
        "dual / path samples/s: {:.1}x; camera rays alone / path: {:.1}x",
        rates[1].0 / rates[0].0,
        alone.0 / rates[0].0
    );
}
