//! Renderer benchmark: BVH build time and ray rates on a groom, and path-tracing rate on the
//! backlit swatch scene. `cargo bench --bench render -- [HAIR_FILE]`; without a file it uses a
//! generated scalp of 30,000 strands. All threads of the machine are used.

use dualhair::cache::Cache;
use dualhair::camera::Camera;
use dualhair::fibers::Fibers;
use dualhair::render_cmd::{DualInputs, render_prepared};
use dualhair::scene::{IntegratorKind, SceneFile};
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
    let cache = Cache::at(format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")));
    let mut swatch = SceneFile::load(Path::new(&format!("{root}/scenes/backlit_swatch.json"))).unwrap();
    swatch.render.spp = 16;
    for integrator in [IntegratorKind::Path, IntegratorKind::Dual] {
        swatch.render.integrator = integrator;
        let scene = swatch.build().unwrap();
        // Tables and grid first, so that only rendering is timed.
        let inputs = DualInputs::load(&scene, &cache, false).unwrap();
        let paths = scene.camera.width * scene.camera.height * 16;
        rate(&format!("{integrator:?}, backlit swatch (camera samples)"), paths, || {
            let film = render_prepared(&scene, inputs.as_ref(), false).unwrap();
            film.alpha.iter().filter(|&&a| a > 0.0).count() * 16
        });
    }
}
