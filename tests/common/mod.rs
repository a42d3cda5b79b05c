//! Helpers shared by the integration tests that render the bundled scenes.
// Each test binary uses some of them.
#![allow(dead_code)]

use dualhair::film::Film;
use dualhair::geometry::strands::Fibers;
use dualhair::integrators::dual::cache::Cache;
use dualhair::integrators::{CameraSample, Integrator};
use dualhair::job::render_scene;
use dualhair::progress::Silent;
use dualhair::sampler::Sampler;
use dualhair::scene::SceneFile;
use glam::{DVec3, Vec3};
use precompute::spectrum::Rgb;
use std::path::{Path, PathBuf};
use std::process::Command;

pub const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The dual integrator's tables and grids, shared by the tests and kept between runs.
pub fn cache() -> Cache {
    Cache::at(format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")))
}

/// A bundled scene, made small.
pub fn bundled(name: &str, size: usize, spp: u32) -> SceneFile {
    let mut file = SceneFile::load(Path::new(&format!("{ROOT}/scenes/{name}.json"))).unwrap();
    file.camera.width = size;
    file.camera.height = size;
    file.render.spp = spp;
    file
}

/// Renders a scene file with its own settings.
pub fn render(file: &SceneFile) -> Film {
    render_scene(&file.build().unwrap(), &cache(), &Silent).unwrap()
}

/// The Python that can import bpy and numpy (tools/cycles_reference.py needs both), if any:
/// `DUALHAIR_BPY_PYTHON`, else `.venv-cycles/bin/python` in the repository
/// (docs/cycles.md).
pub fn bpy_python() -> Option<PathBuf> {
    let candidate = std::env::var_os("DUALHAIR_BPY_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(ROOT).join(".venv-cycles/bin/python"));
    let works = Command::new(&candidate).args(["-c", "import bpy, numpy"]).output().is_ok_and(|o| o.status.success());
    works.then_some(candidate)
}

/// Runs the `dualhair` program with `args`.
pub fn dualhair(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_dualhair")).args(args).output().unwrap()
}

/// The PNG at `path` is a picture, not a blank: a heat map uses many colors.
pub fn assert_picture(path: &Path) {
    let img = image::open(path).unwrap().to_rgb8();
    let mut colors: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colors.sort();
    colors.dedup();
    assert!(colors.len() > 50, "only {} colors", colors.len());
}

/// Every run in `cases` fails with a message containing its expected text, and none leaves a file
/// in `dir`.
pub fn assert_each_fails_naming(cases: &[(Vec<&str>, &str)], dir: &Path) {
    for (args, expect) in cases {
        let out = dualhair(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(err.contains(expect), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read_dir(dir).unwrap().count(), 0, "a failed run left a file behind");
}

/// Camera rays and nothing else: the samples/s that no integrator with one camera ray per sample
/// (as `dual`) can pass, whatever its shading costs (the benchmarks' ceiling).
pub struct CameraRaysAlone<'a>(pub &'a Fibers);

impl Integrator for CameraRaysAlone<'_> {
    fn radiance(&self, origin: Vec3, dir: DVec3, _: &mut impl Sampler) -> CameraSample {
        let hit = self.0.closest_hit(origin, dir.as_vec3(), f32::INFINITY);
        CameraSample { radiance: Rgb::ZERO, hit_hair: hit.is_some(), terms: [Rgb::ZERO; 4] }
    }
}
