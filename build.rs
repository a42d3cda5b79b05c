//! Computes `DUALHAIR_CODE_ID`, a hash of the sources that make the cache's entries (both crates'
//! `src/`, the manifests and `Cargo.lock`), so that a build never reads a cache entry, nor resumes
//! a render, that a build of other code made. It hashes file contents, so a source tarball and a
//! git clone of the same code agree.

use std::path::{Path, PathBuf};

const INPUTS: [&str; 6] = ["src", "precompute/src", "Cargo.toml", "precompute/Cargo.toml", "Cargo.lock", "build.rs"];

fn files(path: &Path, out: &mut Vec<PathBuf>) {
    if path.is_dir() {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(path).unwrap().map(|e| e.unwrap().path()).collect();
        entries.sort();
        for e in entries {
            files(&e, out);
        }
    } else if path.is_file() {
        out.push(path.to_path_buf());
    }
}

fn main() {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap());
    let mut paths = Vec::new();
    for input in INPUTS {
        println!("cargo:rerun-if-changed={input}");
        files(&root.join(input), &mut paths);
    }
    // 64-bit FNV-1a over each file's path (relative, with '/') and contents.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for p in &paths {
        let name = p.strip_prefix(&root).unwrap().to_string_lossy().replace('\\', "/");
        let contents = std::fs::read(p).unwrap();
        eat(name.as_bytes());
        eat(&(contents.len() as u64).to_le_bytes());
        eat(&contents);
    }
    println!("cargo:rustc-env=DUALHAIR_CODE_ID={h:016x}");
}
