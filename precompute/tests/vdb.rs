//! OpenVDB files: our writer read back through vdb-rs (`read_vdb`) and by real OpenVDB (Debian's
//! python3-openvdb, an independent C++ implementation), files written by real OpenVDB read by
//! `read_vdb`, and bad, truncated and lying files.
//!
//! The OpenVDB tests need `/usr/bin/python3` with the `pyopenvdb` module (Debian package
//! python3-openvdb, installed by `.ci/run`); without it they fail and say so.

use precompute::density::{DensityGrid, VdbError, read_vdb, write_vdb};
use precompute::strands::Generator;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::alloc::largest_allocation;
use crate::common::damage::{each_bit_flip, each_byte_flipped, each_truncation};

// ---------------------------------------------------------------------------------------------
// Helpers

/// A fresh directory for one test.
fn test_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("vdb-tests").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn vdb_bytes(grid: &DensityGrid) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_vdb(&mut bytes, grid, "density").unwrap();
    bytes
}

/// Voxels with the bits of their values.
type VoxelBits = Vec<([i32; 3], u32)>;

/// Every non-zero voxel with its value's bits, sorted.
fn voxel_bits(grid: &DensityGrid) -> VoxelBits {
    let mut v: Vec<_> = grid.voxels().map(|(p, d)| (p, d.to_bits())).collect();
    v.sort_unstable();
    v
}

/// Voxels in several clusters over different root nodes (4096^3 voxels each), negative indices,
/// single voxels far out, values over the whole positive f32 range including subnormals, and
/// explicit zeros (inactive, so not stored).
fn synthetic() -> DensityGrid {
    let mut rng = Pcg64::seed_from_u64(7);
    let mut voxels = Vec::new();
    for (center, n) in [([0, 0, 0], 6000), ([-4100, 4090, 130], 3000), ([9000, -12000, -8193], 500)] {
        for _ in 0..n {
            let p = center.map(|c: i32| c + rng.random_range(-12..12));
            voxels.push((p, 10f32.powf(rng.random_range(-6.0..6.0))));
        }
    }
    for (p, v) in [
        ([-8193, 12000, -1], f32::MAX),
        ([1 << 20, -(1 << 20), 5], 1e-40),
        ([3, 3, 3], f32::MIN_POSITIVE),
        ([4, 3, 3], 0.0),
        ([5, 3, 3], 0.0),
    ] {
        voxels.push((p, v));
    }
    DensityGrid::from_voxels(0.0123, 1.7e-4, voxels)
}

fn curly() -> DensityGrid {
    let strands = Generator::Curly(Default::default()).generate().unwrap();
    DensityGrid::voxelize(&strands, DensityGrid::auto_voxel_size(&strands))
}

/// A small grid (two leaves in one root node), for the byte-by-byte tests.
fn small() -> DensityGrid {
    let voxels = (0..40).map(|i| ([i % 11, i / 11, i % 3], 0.25 + i as f32));
    DensityGrid::from_voxels(0.5, 0.01, voxels)
}

fn assert_same(read: &DensityGrid, written: &DensityGrid, what: &str) {
    let (a, b) = (voxel_bits(read), voxel_bits(written));
    assert_eq!(a.len(), b.len(), "{what}: voxel count");
    assert!(a == b, "{what}: voxels or values differ");
    assert_eq!(read.voxel_size.to_bits(), written.voxel_size.to_bits(), "{what}: voxel size");
    assert_eq!(read.fiber_width.to_bits(), written.fiber_width.to_bits(), "{what}: fiber width");
}

/// Runs the system python with OpenVDB's bindings; fails the test, saying what to install, when
/// they are missing.
fn python(script: &str, args: &[&str]) -> String {
    const INSTALL: &str = "the OpenVDB tests need /usr/bin/python3 with pyopenvdb, an independent OpenVDB \
                           implementation: install Debian's python3-openvdb (apt-get install python3-openvdb)";
    let out = Command::new("/usr/bin/python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run /usr/bin/python3 ({e}); {INSTALL}"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("No module named 'pyopenvdb'"), "pyopenvdb is missing; {INSTALL}");
    assert!(out.status.success(), "python with pyopenvdb failed:\n{stderr}");
    String::from_utf8(out.stdout).unwrap()
}

/// Reads grid `density` of a file with real OpenVDB and prints what it found, one fact a line.
const OPENVDB_SUMMARY: &str = r#"
import math, struct, sys
import pyopenvdb as vdb
g = vdb.read(sys.argv[1], 'density')
values, lines, tiles = [], [], 0
for it in g.citerOnValues():
    if it['count'] != 1:
        tiles += 1
    values.append(it['value'])
    i, j, k = it['min']
    lines.append('voxel %d %d %d %d' % (i, j, k, struct.unpack('<I', struct.pack('<f', it['value']))[0]))
lo, hi = g.evalActiveVoxelBoundingBox()
print('class', g.gridClass)
print('active', g.activeVoxelCount())
print('tiles', tiles)
print('sum', repr(math.fsum(values)))
print('voxel_size', ' '.join(repr(x) for x in g.transform.voxelSize()))
print('world_min', ' '.join(repr(x) for x in g.transform.indexToWorld(lo)))
print('world_max', ' '.join(repr(x) for x in g.transform.indexToWorld(hi)))
print('fiber_width', repr(g['fiber_width']))
print('background', repr(g.background))
print('\n'.join(lines))
"#;

/// Key -> rest of line, plus the voxel lines.
fn parse_summary(out: &str) -> (HashMap<&str, &str>, VoxelBits) {
    let mut facts = HashMap::new();
    let mut voxels = Vec::new();
    for line in out.lines() {
        let (key, rest) = line.split_once(' ').unwrap();
        if key == "voxel" {
            let n: Vec<i64> = rest.split(' ').map(|x| x.parse().unwrap()).collect();
            voxels.push(([n[0] as i32, n[1] as i32, n[2] as i32], n[3] as u32));
        } else {
            facts.insert(key, rest);
        }
    }
    voxels.sort_unstable();
    (facts, voxels)
}

fn floats(s: &str) -> Vec<f64> {
    s.split(' ').map(|x| x.parse().unwrap()).collect()
}

fn assert_close(got: f64, want: f64, rel: f64, what: &str) {
    assert!((got - want).abs() <= rel * want.abs().max(1e-300), "{what}: {got} vs {want}");
}

/// Writes bytes to the new file `dir/name`, reads grid `density` from it and removes it; also
/// returns the largest allocation the read made. (A new name each time: overwriting a file on
/// ext4 waits for the old data to reach the disk.)
fn read_bytes(dir: &Path, name: &str, bytes: &[u8]) -> (PathBuf, Result<DensityGrid, VdbError>, usize) {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let (result, largest) = largest_allocation(|| read_vdb(&path, "density"));
    std::fs::remove_file(&path).unwrap();
    (path, result, largest)
}

/// A bad file's error: names the file, and is not vdb-rs failing after validation let it through.
fn assert_clean_error(path: &Path, result: Result<DensityGrid, VdbError>, what: &str) -> VdbError {
    let e = result.err().unwrap_or_else(|| panic!("{what}: read without error"));
    let msg = e.to_string();
    assert!(msg.contains(&path.display().to_string()), "{what}: message does not name the file: {msg}");
    assert!(!matches!(e, VdbError::Reader { .. }), "{what}: got past validation: {msg}");
    e
}

// ---------------------------------------------------------------------------------------------
// Round trips through vdb-rs

#[test]
fn synthetic_grid_round_trips_bit_exactly() {
    let dir = test_dir("synthetic");
    let grid = synthetic();
    let bytes = vdb_bytes(&grid);
    assert_eq!(bytes, vdb_bytes(&grid), "the same grid must give the same file");
    let (_, read, _) = read_bytes(&dir, "synthetic.vdb", &bytes);
    assert_same(&read.unwrap(), &grid, "synthetic");
}

#[test]
fn voxelized_hair_round_trips_bit_exactly() {
    let dir = test_dir("curly");
    let grid = curly();
    println!("curly: {} voxels", grid.voxels().count());
    assert!(grid.voxels().count() > 1000, "the curly grid should be substantial");
    let (_, read, _) = read_bytes(&dir, "curly.vdb", &vdb_bytes(&grid));
    let read = read.unwrap();
    assert_same(&read, &grid, "curly");
    assert_eq!(read.total_length().to_bits(), grid.total_length().to_bits());
}

#[test]
fn empty_grid_round_trips() {
    let dir = test_dir("empty");
    let grid = DensityGrid::from_voxels(0.1, 0.002, []);
    let (_, read, _) = read_bytes(&dir, "empty.vdb", &vdb_bytes(&grid));
    assert_same(&read.unwrap(), &grid, "empty");
}

#[test]
fn writer_refuses_what_openvdb_cannot_hold() {
    let mut sink = Vec::new();
    assert!(write_vdb(&mut sink, &DensityGrid::from_voxels(0.0, 0.01, []), "density").is_err());
    assert!(write_vdb(&mut sink, &DensityGrid::from_voxels(f64::NAN, 0.01, []), "density").is_err());
    assert!(write_vdb(&mut sink, &DensityGrid::from_voxels(0.1, 0.0, []), "density").is_err());
    assert!(write_vdb(&mut sink, &DensityGrid::from_voxels(0.1, 0.01, [([1, 2, 3], -1.0)]), "density").is_err());
    assert!(write_vdb(&mut sink, &DensityGrid::from_voxels(0.1, 0.01, [([1, 2, 3], f32::NAN)]), "density").is_err());
    assert!(write_vdb(&mut sink, &small(), "a\u{1e}b").is_err());
    assert!(sink.is_empty(), "nothing is written on error");
}

// ---------------------------------------------------------------------------------------------
// Real OpenVDB

/// Real OpenVDB reads our file: every active voxel and value, the count, the sum, the voxel size,
/// the world bounds of the active voxels (so the half-voxel translation is right), the metadata.
fn assert_openvdb_reads(grid: &DensityGrid, what: &str) {
    let dir = test_dir(&format!("openvdb-reads-{what}"));
    let path = dir.join("grid.vdb");
    std::fs::write(&path, vdb_bytes(grid)).unwrap();
    let out = python(OPENVDB_SUMMARY, &[path.to_str().unwrap()]);
    let (facts, voxels) = parse_summary(&out);
    println!("{what}: {}", out.lines().filter(|l| !l.starts_with("voxel")).collect::<Vec<_>>().join("; "));

    let ours = voxel_bits(grid);
    assert_eq!(facts["class"], "fog volume", "{what}");
    assert_eq!(facts["active"].parse::<usize>().unwrap(), ours.len(), "{what}: active voxel count");
    assert_eq!(facts["tiles"], "0", "{what}");
    assert!(voxels == ours, "{what}: OpenVDB's voxels or values differ from ours");
    let sum: f64 = grid.voxels().map(|(_, d)| d as f64).sum();
    assert_close(facts["sum"].parse().unwrap(), sum, 1e-12, &format!("{what}: sum"));
    for s in floats(facts["voxel_size"]) {
        assert_eq!(s, grid.voxel_size, "{what}: voxel size");
    }
    assert_eq!(facts["fiber_width"].parse::<f64>().unwrap(), grid.fiber_width, "{what}: fiber width");
    assert_eq!(facts["background"].parse::<f64>().unwrap(), 0.0, "{what}");
    // Our voxel centers: ((i, j, k) + 1/2) s.
    let s = grid.voxel_size;
    let lo: Vec<f64> = (0..3).map(|k| (ours.iter().map(|v| v.0[k]).min().unwrap() as f64 + 0.5) * s).collect();
    let hi: Vec<f64> = (0..3).map(|k| (ours.iter().map(|v| v.0[k]).max().unwrap() as f64 + 0.5) * s).collect();
    for (k, (got, want)) in floats(facts["world_min"]).into_iter().zip(lo).enumerate() {
        assert_close(got, want, 1e-12, &format!("{what}: world min, axis {k}"));
    }
    for (k, (got, want)) in floats(facts["world_max"]).into_iter().zip(hi).enumerate() {
        assert_close(got, want, 1e-12, &format!("{what}: world max, axis {k}"));
    }
}

#[test]
fn real_openvdb_reads_our_synthetic_grid() {
    assert_openvdb_reads(&synthetic(), "synthetic");
}

#[test]
fn real_openvdb_reads_our_voxelized_hair() {
    assert_openvdb_reads(&curly(), "curly");
}

/// Writes, with real OpenVDB (its default blosc compression), grids of every kind we accept and
/// refuse, and prints the voxels of grid `density`.
const OPENVDB_WRITES: &str = r#"
import random, struct, sys
import pyopenvdb as vdb
s = 0.25
rng = random.Random(5)

def grid(name, translation=None, width=0.002):
    g = vdb.FloatGrid()
    g.name = name
    g.gridClass = vdb.GridClass.FOG_VOLUME
    t = vdb.createLinearTransform(voxelSize=s)
    if translation is not None:
        t.translate(translation)
    g.transform = t
    if width is not None:
        g['fiber_width'] = width
    return g

# Voxel centers on our lattice, shifted by 3 voxels: (i, j, k) s + 3.5 s = ((i + 3, ...) + 1/2) s.
density = grid('density', (3.5 * s, 3.5 * s, 3.5 * s))
acc = density.getAccessor()
for _ in range(3000):
    p = tuple(rng.randrange(-40, 40) for _ in range(3))
    v = struct.unpack('<f', struct.pack('<f', 10 ** rng.uniform(-3, 3)))[0]
    acc.setValueOn(p, v)
# A plain uniform scale: voxel centers at (i, j, k) s, half a voxel off our lattice.
plain = grid('plain')
plain.getAccessor().setValueOn((1, 2, 3), 0.5)
plain.getAccessor().setValueOn((10, -4, 7), 2.0)
half = density.deepCopy()
half.name = 'half'
half.saveFloatAsHalf = True
nowidth = grid('nowidth', width=None)
nowidth.getAccessor().setValueOn((0, 0, 0), 1.0)
levelset = grid('levelset')
levelset.gridClass = vdb.GridClass.LEVEL_SET
levelset.getAccessor().setValueOn((0, 0, 0), 1.0)
tiles = grid('tiles')
tiles.fill((0, 0, 0), (15, 15, 15), 1.0, True)
affine = grid('affine')
affine.transform = vdb.createLinearTransform([[s, 0, 0, 0], [0.1, s, 0, 0], [0, 0, s, 0], [0, 0, 0, 1]])
affine.getAccessor().setValueOn((0, 0, 0), 1.0)
stretched = grid('stretched')
stretched.transform = vdb.createLinearTransform([[s, 0, 0, 0], [0, 2 * s, 0, 0], [0, 0, s, 0], [1, 1, 1, 1]])
stretched.getAccessor().setValueOn((0, 0, 0), 1.0)
vector = vdb.Vec3SGrid()
vector.name = 'vector'
vector['fiber_width'] = 0.002
vector.getAccessor().setValueOn((0, 0, 0), (1.0, 2.0, 3.0))
vdb.write(sys.argv[1], grids=[density, plain, half, nowidth, levelset, tiles, affine, stretched, vector])
print('maps', affine.transform.typeName, stretched.transform.typeName)
print('tiles', tiles.activeVoxelCount(), sum(1 for it in tiles.citerOnValues() if it['count'] != 1))
for it in density.citerOnValues():
    i, j, k = it['min']
    print('voxel %d %d %d %d' % (i, j, k, struct.unpack('<I', struct.pack('<f', it['value']))[0]))
"#;

#[test]
fn we_read_grids_written_by_real_openvdb() {
    let dir = test_dir("openvdb-writes");
    let path = dir.join("openvdb.vdb");
    let out = python(OPENVDB_WRITES, &[path.to_str().unwrap()]);
    let (facts, file_voxels) = parse_summary(&out);
    assert!(file_voxels.len() > 2000);
    let bytes = std::fs::read(&path).unwrap();
    // OpenVDB wrote file format 224 with its default compression: the blosc path is tested.
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 224, "file format version");
    assert!(bytes.windows(21).any(|w| w == b"blosc + active values"), "OpenVDB should write blosc");
    assert_eq!(facts["maps"], "AffineMap ScaleTranslateMap", "the transforms refused below");

    // Exact lattice: every voxel shifted by 3, values bit for bit.
    let grid = read_vdb(&path, "density").unwrap();
    assert_eq!(grid.voxel_size, 0.25);
    assert_eq!(grid.fiber_width, 0.002);
    let want: Vec<_> = file_voxels.iter().map(|(p, v)| (p.map(|c| c + 3), *v)).collect();
    assert!(voxel_bits(&grid) == want, "voxels or values differ from what OpenVDB wrote");

    // Half a voxel off: each voxel spread evenly over the 8 of ours around its center.
    let plain = read_vdb(&path, "plain").unwrap();
    let mut want = Vec::new();
    for (p, v) in [([1, 2, 3], 0.5f32), ([10, -4, 7], 2.0)] {
        for corner in 0..8 {
            let q = [0, 1, 2].map(|k| p[k] - 1 + (corner >> k & 1));
            want.push((q, (v / 8.0).to_bits()));
        }
    }
    want.sort_unstable();
    assert!(voxel_bits(&plain) == want, "resampled plain grid: {:?}", voxel_bits(&plain));
    assert_eq!(plain.total_length(), 2.5 * 0.25f64.powi(3), "resampling keeps the total length");

    // What we refuse, each with a message that names the file and says why.
    assert!(facts["tiles"].split(' ').nth(1).unwrap() != "0", "the tiles grid should hold active tiles");
    for (name, expect) in [
        ("half", "half floats"),
        ("nowidth", "no fiber_width metadata"),
        ("levelset", "level set"),
        ("tiles", "active tile"),
        ("affine", "AffineMap"),
        ("stretched", "not cubes"),
        ("vector", "Tree_vec3s_5_4_3"),
    ] {
        let e = read_vdb(&path, name).err().unwrap_or_else(|| panic!("grid {name} was read"));
        let msg = e.to_string();
        println!("{name}: {msg}");
        assert!(matches!(e, VdbError::Grid { .. }), "{name}: {msg}");
        assert!(msg.contains(&path.display().to_string()) && msg.contains(expect), "{name}: {msg}");
    }
    let e = read_vdb(&path, "nope").unwrap_err();
    assert!(matches!(e, VdbError::NoSuchGrid { .. }), "{e}");
    assert!(e.to_string().contains("\"density\", \"plain\", \"half\""), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Bad files

#[test]
fn missing_empty_foreign_and_misversioned_files_give_errors() {
    let dir = test_dir("bad-basic");
    let missing = dir.join("missing.vdb");
    let e = assert_clean_error(&missing, read_vdb(&missing, "density"), "missing");
    assert!(matches!(e, VdbError::Io { .. }), "{e}");

    let (path, r, _) = read_bytes(&dir, "empty.vdb", &[]);
    assert!(matches!(assert_clean_error(&path, r, "empty"), VdbError::NotVdb { .. }));

    let mut rng = Pcg64::seed_from_u64(3);
    let random: Vec<u8> = (0..5000).map(|_| rng.random()).collect();
    let (path, r, _) = read_bytes(&dir, "random.vdb", &random);
    assert!(matches!(assert_clean_error(&path, r, "random"), VdbError::NotVdb { .. }));

    let good = vdb_bytes(&small());
    let mut magic = good.clone();
    magic[3] ^= 0x20; // "VDB " -> "vDB "
    let (path, r, _) = read_bytes(&dir, "magic.vdb", &magic);
    assert!(matches!(assert_clean_error(&path, r, "wrong magic"), VdbError::NotVdb { .. }));

    // The magic number, then random bytes.
    let mut after_magic = good[..8].to_vec();
    after_magic.extend_from_slice(&random);
    let (path, r, _) = read_bytes(&dir, "after-magic.vdb", &after_magic);
    assert_clean_error(&path, r, "random after the magic number");

    for version in [221u32, 225, u32::MAX] {
        let mut b = good.clone();
        b[8..12].copy_from_slice(&version.to_le_bytes());
        let (path, r, _) = read_bytes(&dir, &format!("version-{version}.vdb"), &b);
        let e = assert_clean_error(&path, r, "version");
        assert!(matches!(e, VdbError::Version { .. }) && e.to_string().contains(&version.to_string()), "{e}");
    }

    let path = dir.join("named.vdb");
    std::fs::write(&path, &good).unwrap();
    let e = assert_clean_error(&path, read_vdb(&path, "hair"), "wrong name");
    assert!(matches!(e, VdbError::NoSuchGrid { .. }) && e.to_string().contains("\"density\""), "{e}");
}

#[test]
fn every_truncation_gives_an_error() {
    let dir = test_dir("truncated");
    for (grid, what, step) in [(small(), "small", 1), (synthetic(), "synthetic", 997)] {
        let good = vdb_bytes(&grid);
        assert!(read_bytes(&dir, "whole.vdb", &good).1.is_ok());
        each_truncation(&good, 2000, step, |len, cut| {
            let (path, r, largest) = read_bytes(&dir, &format!("{what}-{len}.vdb"), cut);
            let what = format!("{what} cut at {len} of {}", good.len());
            assert_clean_error(&path, r, &what);
            assert!(largest <= 4 * good.len() + (256 << 10), "{what}: allocated {largest} bytes");
        });
    }
}

#[test]
fn flipped_bytes_give_an_error_or_a_grid_but_never_a_panic_or_a_large_allocation() {
    let dir = test_dir("flipped");
    let good = vdb_bytes(&small());
    let mut errors = 0;
    each_byte_flipped(&good, &mut Pcg64::seed_from_u64(11), |at, flip, b| {
        let (path, r, largest) = read_bytes(&dir, &format!("{at}-{flip}.vdb"), b);
        let bound = 4 * b.len() + (256 << 10);
        assert!(largest <= bound, "byte {at} ^ {flip:#x}: allocated {largest} bytes for a {}-byte file", b.len());
        if r.is_err() {
            errors += 1;
            assert_clean_error(&path, r, &format!("byte {at} ^ {flip:#x}"));
        }
    });
    println!("{errors} of {} flipped files refused", 2 * good.len());
    assert!(errors > good.len() / 4, "most flips should be caught");
}

#[test]
fn flipped_bytes_in_a_blosc_file_from_real_openvdb_give_an_error_or_a_grid_but_never_a_panic() {
    let dir = test_dir("flipped-blosc");
    let path = dir.join("openvdb.vdb");
    python(OPENVDB_WRITES, &[path.to_str().unwrap()]);
    let good = std::fs::read(&path).unwrap();
    assert!(read_vdb(&path, "density").is_ok());
    let (mut errors, mut blosc_errors) = (0, 0);
    each_bit_flip(&good, &mut Pcg64::seed_from_u64(13), 1000, 1..=1, None, |n, at, b| {
        let (path, r, largest) = read_bytes(&dir, &format!("{n}.vdb"), b);
        assert!(largest <= 4 * b.len() + (256 << 10), "byte {at}: allocated {largest} bytes");
        if let Err(e) = r {
            errors += 1;
            let msg = e.to_string();
            assert!(msg.contains(&path.display().to_string()) && !msg.contains("panicked"), "byte {at}: {msg}");
            // Validation checks blosc headers; only c-blosc itself finds a damaged payload.
            blosc_errors += matches!(e, VdbError::Reader { .. }) as usize;
        }
    });
    println!("{errors} of 1000 flipped files refused, {blosc_errors} by c-blosc");
}

/// Offset of `needle` in `haystack`.
fn find(haystack: &[u8], needle: &[u8]) -> usize {
    haystack.windows(needle.len()).position(|w| w == needle).unwrap()
}

#[test]
fn lying_sizes_and_counts_fail_fast_without_allocating() {
    let dir = test_dir("lying");
    let good = vdb_bytes(&small());
    // Fixed header: magic 8, version 4, library version 8, offsets flag 1, UUID 36, file metadata
    // count 4, then the grid count and the first descriptor's name length.
    let grid_count = 8 + 4 + 8 + 1 + 36 + 4;
    let name_len = grid_count + 4;
    // After the transform's type and six vectors: buffer count, background, tiles, children.
    let topology = find(&good, b"UniformScaleTranslateMap") + 24 + 6 * 24;
    let grid_metadata_count = find(&good, b"class") - 4 - 4;
    let class_len = grid_metadata_count + 4 + 4 + 5 + 4 + 6;
    let mut cases: Vec<(&str, usize, Vec<u8>)> = vec![
        ("file metadata count", grid_count - 4, u32::MAX.to_le_bytes().to_vec()),
        ("grid count", grid_count, u32::MAX.to_le_bytes().to_vec()),
        ("grid name length", name_len, 0x7fff_ffffu32.to_le_bytes().to_vec()),
        ("grid metadata count", grid_metadata_count, u32::MAX.to_le_bytes().to_vec()),
        ("metadata value length", class_len, 0xffff_fff0u32.to_le_bytes().to_vec()),
        ("buffer count", topology, 2u32.to_le_bytes().to_vec()),
        ("background", topology + 4, 1f32.to_le_bytes().to_vec()),
        ("tile count", topology + 8, u32::MAX.to_le_bytes().to_vec()),
        ("child count", topology + 12, u32::MAX.to_le_bytes().to_vec()),
        ("child origin", topology + 16, 5i32.to_le_bytes().to_vec()),
    ];
    // The descriptor's grid, data and end positions.
    let positions = name_len + 4 + 7 + 4 + 16 + 4;
    for (what, k, value) in [
        ("grid position", 0, i64::MAX),
        ("grid position", 0, -8),
        ("data position", 1, i64::MAX),
        ("end position", 2, i64::MAX),
        ("end position", 2, 0),
    ] {
        cases.push((what, positions + 8 * k, value.to_le_bytes().to_vec()));
    }
    // The first block of values (the root child's) has a metadata byte and an i64 chunk size.
    let first_block = topology + 16 + 12 + 2 * 4096;
    cases.push(("value block metadata", first_block, vec![9]));
    for size in [i64::MAX, i64::MIN, -4, 1 << 40] {
        cases.push(("chunk size", first_block + 1, size.to_le_bytes().to_vec()));
    }
    for (n, (what, at, value)) in cases.into_iter().enumerate() {
        let mut b = good.clone();
        b[at..at + value.len()].copy_from_slice(&value);
        let (path, r, largest) = read_bytes(&dir, &format!("lying-{n}.vdb"), &b);
        let e = assert_clean_error(&path, r, what);
        println!("{what}: {e}");
        assert!(largest <= 4 * b.len() + (256 << 10), "{what}: allocated {largest} bytes");
    }
}
