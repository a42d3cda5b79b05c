//! The fuzz targets' entry points, one per reader. Each takes the bytes of a file and returns Ok
//! or the reader's error message; it panics only on a bug: a reader that panics, or breaks what
//! it promises (strands that do not validate, an error that does not name the file or that
//! prints a cause twice).
//! `tests/fuzz_replay.rs` includes this file to replay the corpora and regressions on stable, so
//! the fuzzer and the test run the same code.

use dualhair::geometry::meshes::parse_obj;
use dualhair::lights::EnvMap;
use dualhair::scene::SceneFile;
use precompute::density::parse_vdb;
use precompute::strands::{Generator, parse_hair, parse_pbrt_curves, parse_usd_curves};
use std::error::Error;
use std::path::{Component, Path};

/// The most hair points a fuzzed scene may generate. Up to `MAX_TOTAL_POINTS` (10M) is a
/// legitimate groom, but it takes seconds and a GB to generate and build a BVH for, and the
/// fuzzer would spend its time there and trip its memory limit; the generators' own bound is
/// tested in precompute. 20k points keep a build near a millisecond.
pub const MAX_SCENE_POINTS: u64 = 20_000;

/// Where fuzzed scenes live: a directory that does not exist, so every file they name is missing.
const SCENE: &str = "/nonexistent-dualhair-fuzz/scene.json";

/// The first four bytes of an OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// A .hair file: `parse_hair`, whose strands must pass `validate`.
pub fn hair(data: &[u8]) -> Result<(), String> {
    let strands = parse_hair(data).map_err(|e| message(&e))?;
    strands.validate().expect("parse_hair returned strands that do not validate");
    Ok(())
}

/// A .vdb file, read for the grid the renderer reads ("density").
pub fn vdb(data: &[u8]) -> Result<(), String> {
    const NAME: &str = "fuzz.vdb";
    named(parse_vdb(data, Path::new(NAME), "density").map(drop).map_err(|e| message(&e)), NAME)
}

/// A lat-long environment map. `EnvMap::from_bytes` takes the format from the extension, so the
/// name is chosen by the magic number: the seeds are real .exr and .hdr files.
pub fn envmap(data: &[u8]) -> Result<(), String> {
    let name = if data.starts_with(&EXR_MAGIC) { "fuzz.exr" } else { "fuzz.hdr" };
    named(EnvMap::from_bytes(data, Path::new(name), 1.0, 0.0).map(drop).map_err(|e| message(&e)), name)
}

/// A Wavefront OBJ mesh (`parse_obj`: its `mtllib` lines are never followed).
pub fn obj(data: &[u8]) -> Result<(), String> {
    const NAME: &str = "fuzz.obj";
    let triangles = parse_obj(data, Path::new(NAME)).map_err(|e| message(&e))?;
    assert!(triangles.iter().flatten().all(|p| p.is_finite()), "parse_obj returned a vertex that is not finite");
    named(Ok(()), NAME)
}

/// A pbrt-v4 scene's curves, with its files in memory: the input is `fuzz.pbrt` in a directory
/// holding nothing else, so `Include "fuzz.pbrt"` includes itself and any other file is missing
/// (file reads are confined by construction).
pub fn pbrt(data: &[u8]) -> Result<(), String> {
    const NAME: &str = "/nonexistent-dualhair-fuzz/fuzz.pbrt";
    let read = |p: &Path| match p == Path::new(NAME) {
        true => Ok(data.to_vec()),
        false => Err(std::io::Error::from(std::io::ErrorKind::NotFound)),
    };
    let strands = parse_pbrt_curves(Path::new(NAME), &read).map_err(|e| message(&e));
    named(strands.map(|s| s.validate().expect("parse_pbrt_curves returned strands that do not validate")), "fuzz.pbrt")
}

/// A USD stage's BasisCurves, from a text (.usda) file in memory as the only file there is (so
/// every layer it refers to is missing: reads are confined by construction). Binary crate files
/// (.usdc, and .usdz packages of them) are not fuzzed: openusd 0.6's crate reader sizes its
/// buffers by the file's own counts (fuzz/README.md, "Open findings").
pub fn usd(data: &[u8]) -> Result<(), String> {
    const NAME: &str = "fuzz.usda";
    if data.starts_with(b"PXR-USDC") || data.starts_with(b"PK") {
        return Err("fuzz: a crate file or package, not fuzzed".into());
    }
    let strands = parse_usd_curves(NAME, data).map_err(|e| message(&e));
    named(strands.map(|s| s.validate().expect("parse_usd_curves returned strands that do not validate")), NAME)
}

/// A scene file, parsed and built (hair, meshes, camera, lights, BVH).
pub fn scene(data: &[u8]) -> Result<(), String> {
    let text = std::str::from_utf8(data).map_err(|e| e.to_string())?;
    let scene = SceneFile::parse(text, Path::new(SCENE)).map_err(|e| message(&e))?;
    // An absolute path or ".." would leave the missing directory and could reach a real file:
    // /dev/zero would be read forever.
    let dir = Path::new(SCENE).parent().expect("SCENE has a directory");
    let env_file = scene.lights.environment.as_ref().and_then(|e| e.file.as_ref());
    let named = [scene.hair.file.as_ref(), env_file, scene.dual.density_grid.as_ref()].into_iter().flatten();
    for file in named.chain(scene.meshes.iter().map(|m| &m.file)) {
        if !file.starts_with(dir) || file.components().any(|c| c == Component::ParentDir) {
            return Err(format!("fuzz: {} is outside {}", file.display(), dir.display()));
        }
    }
    if let Some(generator) = &scene.hair.generate {
        let (strands, points) = match generator {
            Generator::Straight(g) => (g.strands, g.points),
            Generator::Wavy(g) => (g.strands, g.points),
            Generator::Curly(g) => (g.strands, g.points),
            Generator::Ball(g) => (g.strands, g.points),
            Generator::Scalp(g) => (g.strands, g.points),
        };
        if u64::from(strands) * u64::from(points) > MAX_SCENE_POINTS {
            return Err(format!("fuzz: {strands} x {points} points is over {MAX_SCENE_POINTS}"));
        }
    }
    scene.build().map(drop).map_err(|e| message(&e))
}

/// The error with its causes, as anyhow's `{:#}` prints it, after checking that no cause is
/// printed twice: an error whose message already ends with its cause must not also return that
/// cause as its `source`.
fn message(error: &(dyn Error + 'static)) -> String {
    let mut text = error.to_string();
    let mut outer = error;
    while let Some(inner) = outer.source() {
        let (outer_text, inner_text) = (outer.to_string(), inner.to_string());
        assert!(!outer_text.ends_with(&inner_text), "the cause is printed twice: {text}: {inner_text}");
        text = format!("{text}: {inner_text}");
        outer = inner;
    }
    text
}

/// `result`, after checking that an error names the file `name`.
fn named(result: Result<(), String>, name: &str) -> Result<(), String> {
    if let Err(message) = &result {
        assert!(message.contains(name), "the error does not name the file: {message}");
    }
    result
}
