//! Replays what fuzzing found and kept through the fuzz targets' own entry points
//! (fuzz/src/lib.rs, compiled in here): every crash input in fuzz/regressions/<target>/ and every
//! input of the minimized corpus fuzz/corpus/<target>/ must give Ok or an error, never a panic,
//! and allocate no more at once than the fuzzer allowed. Fuzzing itself needs nightly and
//! cargo-fuzz (fuzz/README.md); this runs on stable.

#[path = "../precompute/tests/common/alloc.rs"]
mod allocation;
#[path = "../fuzz/src/lib.rs"]
mod entries;

use std::path::Path;

/// The fuzz runs' `-malloc_limit_mb`: the largest single allocation an input may cause.
const MALLOC_LIMIT: usize = 256 << 20;

/// Runs `entry` on every file of the target's regressions and corpus; fails naming each input
/// that panicked (the panic message is printed above it) or allocated over [`MALLOC_LIMIT`].
fn replay(target: &str, entry: fn(&[u8]) -> Result<(), String>) {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let corpus = fuzz.join("corpus").join(target);
    // A target whose fuzzing found nothing has no regressions directory.
    let regressions = fuzz.join("regressions").join(target);
    let mut inputs: Vec<_> = [&regressions, &corpus]
        .into_iter()
        .filter(|dir| dir.exists())
        .flat_map(|dir| std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()))
        .collect();
    inputs.sort();
    assert!(inputs.iter().any(|p| p.starts_with(&corpus)), "{} holds no inputs", corpus.display());
    let failed: Vec<_> = inputs
        .iter()
        .filter_map(|path| {
            let data = std::fs::read(path).unwrap();
            match allocation::largest_allocation(|| std::panic::catch_unwind(|| entry(&data))) {
                (Err(_), _) => Some(format!("{}: panicked", path.display())),
                (_, largest) if largest > MALLOC_LIMIT => {
                    Some(format!("{}: allocated {largest} bytes at once", path.display()))
                }
                _ => None,
            }
        })
        .collect();
    assert!(failed.is_empty(), "{} of {} {target} inputs failed: {failed:#?}", failed.len(), inputs.len());
}

#[test]
fn hair_inputs_load_or_fail_cleanly() {
    replay("hair", entries::hair);
}

#[test]
fn vdb_inputs_load_or_fail_cleanly() {
    replay("vdb", entries::vdb);
}

#[test]
fn scene_inputs_build_or_fail_cleanly() {
    replay("scene", entries::scene);
}

#[test]
fn envmap_inputs_load_or_fail_cleanly() {
    replay("envmap", entries::envmap);
}

#[test]
fn obj_inputs_load_or_fail_cleanly() {
    replay("obj", entries::obj);
}

#[test]
fn pbrt_inputs_load_or_fail_cleanly() {
    replay("pbrt", entries::pbrt);
}

#[test]
fn usd_inputs_load_or_fail_cleanly() {
    replay("usd", entries::usd);
}
