//! OpenVDB files for the density grid: our own writer of one float fog volume, and a reader that
//! checks a file completely before it lets the `vdb-rs` crate parse it.
//!
//! The layout relied on (OpenVDB 10, file format version 224; io/Archive.cc `writeHeader`,
//! `writeGrid`, `setGridCompression`; io/GridDescriptor.cc; tree/RootNode.h, InternalNode.h,
//! LeafNode.h `writeTopology`/`writeBuffers`; io/Compression.h `writeCompressedValues`;
//! math/Maps.h), all little-endian, strings as a u32 length and the bytes:
//!
//! - header: i64 magic 0x56444220, u32 file version, u32 x2 library version, u8 "has grid offsets",
//!   36-byte ASCII UUID, file metadata, u32 grid count;
//! - per grid a descriptor: unique name, type (`Tree_float_5_4_3`, `_HalfFloat` appended for half
//!   grids), instance parent, i64 positions of the grid, its data blocks and its end; at the grid's
//!   position: u32 compression flags, grid metadata, transform (map type name and its f64 vectors),
//!   topology, and at the block position the leaf buffers;
//! - metadata: u32 count, then name, type name, u32 value size and the value, per entry;
//! - topology: i32 buffer count (1), f32 background, u32 root tiles, u32 root children, the tiles
//!   (i32 x3 origin, f32 value, u8 active), then per child its i32 x3 origin and the 32^3 internal
//!   node: child mask, value mask (bit n of a mask is bit n % 64 of u64 word n / 64), its values,
//!   then its 16^3 children likewise, then their leaves' value masks; children in ascending offset
//!   order and root children in ascending (x, y, z) order, which is the order buffers are read in;
//! - buffers: per leaf, its value mask again and its 8^3 values;
//! - node offsets are x-major: x << 2L | y << L | z for a node of 2^L children per axis (a leaf's
//!   voxels too, z fastest, where our bricks are x fastest);
//! - a block of values: a u8 saying which inactive values follow, then (with active-mask
//!   compression) only the active values, else all of them, each block a chunk: with zip an i64
//!   size and a zlib stream, or a negative size and the raw bytes; with blosc likewise.

use super::{BRICK, DensityGrid};
use flate2::Compression;
use flate2::read::ZlibDecoder;
use flate2::write::ZlibEncoder;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

/// `OPENVDB_MAGIC`, written as an i64.
const MAGIC: i64 = 0x5644_4220;
/// `OPENVDB_FILE_VERSION` of OpenVDB 6 to 12 (multi-pass I/O), which we write.
const FILE_VERSION: u32 = 224;
/// `OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION` (OpenVDB 3.0): per-grid compression flags and a
/// metadata byte before every block of values. The oldest version read.
const OLDEST_VERSION: u32 = 222;
/// The grid type of a float grid with OpenVDB's standard 5-4-3 tree.
const GRID_TYPE: &[u8] = b"Tree_float_5_4_3";
/// Appended to the grid type of a grid saved as 16-bit floats (`HALF_FLOAT_TYPENAME_SUFFIX`).
const HALF_SUFFIX: &[u8] = b"_HalfFloat";
/// Separates a grid name from the index OpenVDB appends to make it unique in a file.
const NAME_SEPARATOR: char = '\u{1e}';

// Compression flags (io/Compression.h).
const COMPRESS_ZIP: u32 = 0x1;
const COMPRESS_ACTIVE_MASK: u32 = 0x2;
const COMPRESS_BLOSC: u32 = 0x4;

// The metadata byte of a block of values (io/Compression.h); 0 means every inactive value is the
// background, 6 that all values are stored.
const NO_MASK_OR_INACTIVE_VALS: u8 = 0;
const NO_MASK_AND_ONE_INACTIVE_VAL: u8 = 2;
const MASK_AND_NO_INACTIVE_VALS: u8 = 3;
const MASK_AND_ONE_INACTIVE_VAL: u8 = 4;
const MASK_AND_TWO_INACTIVE_VALS: u8 = 5;
const NO_MASK_AND_ALL_VALS: u8 = 6;

/// Values per node: leaf 8^3, lower internal 16^3, upper internal 32^3.
const LEAF_VALUES: usize = 512;
const LOWER_VALUES: usize = 4096;
const UPPER_VALUES: usize = 32768;
/// Voxels along the edge of a root child (32 * 16 * 8).
const ROOT_CHILD_EDGE: i32 = 4096;
/// vdb-rs returns voxel positions as f32: indices stay within +-2^24 to be exact.
const MAX_INDEX: i32 = 1 << 24;

/// Reasons a .vdb file cannot be loaded as a density grid; every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum VdbError {
    // Not named `source`: the message says the cause, and as a source it would print twice.
    #[error("cannot read {}: {error}", path.display())]
    Io { path: PathBuf, error: io::Error },
    #[error("{} is not an OpenVDB file: it does not start with the VDB magic number 0x56444220", path.display())]
    NotVdb { path: PathBuf },
    #[error(
        "{}: OpenVDB file format version {version} is not supported; this reader takes versions {OLDEST_VERSION} to \
         {FILE_VERSION} (OpenVDB 3 and newer): re-save the file with a current OpenVDB",
        path.display()
    )]
    Version { path: PathBuf, version: u32 },
    #[error("{} is corrupt or truncated: at byte {offset}, {problem}", path.display())]
    Corrupt { path: PathBuf, offset: usize, problem: String },
    #[error("{}: {problem}", path.display())]
    Unsupported { path: PathBuf, problem: String },
    #[error("{}: there is no grid named {name:?}; the file has {}", path.display(), list_names(available))]
    NoSuchGrid { path: PathBuf, name: String, available: Vec<String> },
    #[error("{}: grid {grid:?} cannot be used as a hair density grid: {problem}", path.display())]
    Grid { path: PathBuf, grid: String, problem: String },
    #[error("{}: the vdb-rs reader failed on grid {grid:?} that passed validation: {message}", path.display())]
    Reader { path: PathBuf, grid: String, message: String },
}

fn list_names(names: &[String]) -> String {
    match names {
        [] => "no grids".to_owned(),
        _ => format!("grids {}", names.iter().map(|n| format!("{n:?}")).collect::<Vec<_>>().join(", ")),
    }
}

// ---------------------------------------------------------------------------------------------
// Writing

/// Writes `grid` as an OpenVDB file holding one float fog volume named `name`: file format 224,
/// zip and active-mask compression, background 0, the non-zero voxels active. Its transform is a
/// `UniformScaleTranslateMap` with scale s and translation s/2: OpenVDB puts voxel centers at
/// integer indices, and our voxel (i, j, k) is centered at ((i, j, k) + 1/2) s, so indices are
/// the same in both. `fiber_width` and `voxel_size` are stored as double metadata. The file is
/// built in memory first, so an invalid grid writes nothing; the same grid gives the same bytes.
pub fn write_vdb<W: Write>(mut w: W, grid: &DensityGrid, name: &str) -> io::Result<()> {
    // Refuse what `read_vdb` would refuse.
    let invalid = |problem: String| Err(io::Error::new(io::ErrorKind::InvalidInput, problem));
    let (s, width) = (grid.voxel_size, grid.fiber_width);
    if !(s > 0.0 && s.is_finite() && width > 0.0 && width.is_finite()) {
        return invalid(format!("voxel size {s} and fiber width {width} must be finite and > 0"));
    }
    if let Some((p, v)) = grid.voxels().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
        return invalid(format!("voxel {p:?} holds {v}; densities must be finite and >= 0"));
    }
    if name.contains(NAME_SEPARATOR) {
        return invalid(format!("grid name {name:?} contains U+001E, which OpenVDB reserves for its own use"));
    }
    let leaves = leaves_in_file_order(grid);
    let voxel_count = grid.voxels().count() as i64;
    let (bbox_min, bbox_max) = active_bounds(grid);

    let mut body = Vec::new();
    put_u32(&mut body, COMPRESS_ZIP | COMPRESS_ACTIVE_MASK);
    // Grid metadata, in name order as OpenVDB's MetaMap keeps it.
    put_u32(&mut body, 7);
    put_meta(&mut body, "class", "string", b"fog volume");
    put_meta(&mut body, "fiber_width", "double", &width.to_le_bytes());
    put_meta(&mut body, "file_bbox_max", "vec3i", &vec3i(bbox_max));
    put_meta(&mut body, "file_bbox_min", "vec3i", &vec3i(bbox_min));
    put_meta(&mut body, "file_voxel_count", "int64", &voxel_count.to_le_bytes());
    put_meta(&mut body, "name", "string", name.as_bytes());
    put_meta(&mut body, "voxel_size", "double", &s.to_le_bytes());
    // ScaleTranslateMap::write: translation, scale, voxel size, 1/scale, 1/scale^2, 1/(2 scale).
    put_str(&mut body, b"UniformScaleTranslateMap");
    for v in [s / 2.0, s, s, 1.0 / s, 1.0 / (s * s), 0.5 / s] {
        (0..3).for_each(|_| body.extend_from_slice(&v.to_le_bytes()));
    }
    // Tree::writeTopology and RootNode::writeTopology: one buffer, background 0, no tiles.
    put_u32(&mut body, 1);
    body.extend_from_slice(&0f32.to_le_bytes());
    put_u32(&mut body, 0);
    put_u32(&mut body, leaves.len() as u32);
    for (origin, uppers) in &leaves {
        body.extend_from_slice(&vec3i(*origin));
        put_mask(&mut body, uppers.keys().copied(), UPPER_VALUES);
        put_mask(&mut body, [], UPPER_VALUES);
        put_values(&mut body, &[])?;
        for lowers in uppers.values() {
            put_mask(&mut body, lowers.keys().copied(), LOWER_VALUES);
            put_mask(&mut body, [], LOWER_VALUES);
            put_values(&mut body, &[])?;
            for leaf in lowers.values() {
                body.extend(leaf.mask.iter().flat_map(|w| w.to_le_bytes()));
            }
        }
    }
    let block_start = body.len();
    for leaf in leaves.values().flat_map(|n| n.values()).flat_map(|n| n.values()) {
        body.extend(leaf.mask.iter().flat_map(|w| w.to_le_bytes()));
        put_values(&mut body, &leaf.values)?;
    }

    let mut file = Vec::new();
    file.extend_from_slice(&MAGIC.to_le_bytes());
    put_u32(&mut file, FILE_VERSION);
    put_u32(&mut file, 10);
    put_u32(&mut file, 0);
    file.push(1); // grid offsets follow: the file can be read grid by grid
    file.extend_from_slice(uuid(&body).as_bytes());
    put_u32(&mut file, 0); // no file metadata
    put_u32(&mut file, 1); // one grid
    put_str(&mut file, name.as_bytes());
    put_str(&mut file, GRID_TYPE);
    put_str(&mut file, b""); // not an instance of another grid
    let grid_pos = (file.len() + 24) as i64;
    for pos in [grid_pos, grid_pos + block_start as i64, grid_pos + body.len() as i64] {
        file.extend_from_slice(&pos.to_le_bytes());
    }
    w.write_all(&file)?;
    w.write_all(&body)
}

/// The non-zero voxels of one brick, as an OpenVDB leaf: value mask and active values in offset order.
struct Leaf {
    mask: [u64; LEAF_VALUES / 64],
    values: Vec<f32>,
}

/// Root child origin -> offset in the 32^3 node -> offset in the 16^3 node -> leaf.
type Leaves = BTreeMap<[i32; 3], BTreeMap<usize, BTreeMap<usize, Leaf>>>;

fn leaves_in_file_order(grid: &DensityGrid) -> Leaves {
    let mut leaves = Leaves::new();
    for (origin, brick) in grid.bricks() {
        let mut leaf = Leaf { mask: [0; LEAF_VALUES / 64], values: Vec::new() };
        for n in 0..LEAF_VALUES {
            // LeafNode::coordToOffset: x << 6 | y << 3 | z; our brick index is (z * 8 + y) * 8 + x.
            let (x, y, z) = (n >> 6, (n >> 3) & 7, n & 7);
            let v = brick[(z * BRICK as usize + y) * BRICK as usize + x];
            if v != 0.0 {
                leaf.mask[n / 64] |= 1 << (n % 64);
                leaf.values.push(v);
            }
        }
        if !leaf.values.is_empty() {
            let root = origin.map(|c| c & !(ROOT_CHILD_EDGE - 1));
            // InternalNode::coordToOffset, for the 32^3 node (children 128 wide) and the 16^3 node
            // (children 8 wide).
            let offset = |edge: i32, child: i32, log2: u32| {
                let l = origin.map(|c| ((c & (edge - 1)) / child) as usize);
                (l[0] << (2 * log2)) | (l[1] << log2) | l[2]
            };
            let (upper, lower) = (offset(ROOT_CHILD_EDGE, 128, 5), offset(128, 8, 4));
            leaves.entry(root).or_default().entry(upper).or_default().insert(lower, leaf);
        }
    }
    leaves
}

/// Index bounds of the non-zero (active) voxels, inverted (OpenVDB's empty `CoordBBox`) when
/// there are none.
fn active_bounds(grid: &DensityGrid) -> ([i32; 3], [i32; 3]) {
    let mut bounds = ([i32::MAX; 3], [i32::MIN; 3]);
    for (p, _) in grid.voxels() {
        for ((lo, hi), c) in bounds.0.iter_mut().zip(&mut bounds.1).zip(p) {
            (*lo, *hi) = ((*lo).min(c), (*hi).max(c));
        }
    }
    bounds
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_str(out: &mut Vec<u8>, s: &[u8]) {
    put_u32(out, s.len() as u32);
    out.extend_from_slice(s);
}

fn put_meta(out: &mut Vec<u8>, name: &str, type_name: &str, value: &[u8]) {
    put_str(out, name.as_bytes());
    put_str(out, type_name.as_bytes());
    put_str(out, value);
}

fn vec3i(v: [i32; 3]) -> Vec<u8> {
    v.iter().flat_map(|c| c.to_le_bytes()).collect()
}

/// A node mask of `size` bits with the bits `on` set (util/NodeMasks.h `save`: the raw u64 words).
fn put_mask(out: &mut Vec<u8>, on: impl IntoIterator<Item = usize>, size: usize) {
    let mut words = vec![0u64; size / 64];
    on.into_iter().for_each(|n| words[n / 64] |= 1 << (n % 64));
    out.extend(words.iter().flat_map(|w| w.to_le_bytes()));
}

/// A block of values whose inactive values are all the background (metadata byte 0), so only the
/// active `values` are stored; zipped as io::zipToStream does (raw when zlib does not shrink them).
fn put_values(out: &mut Vec<u8>, values: &[f32]) -> io::Result<()> {
    out.push(NO_MASK_OR_INACTIVE_VALS);
    let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let zipped = if raw.is_empty() {
        Vec::new()
    } else {
        let mut z = ZlibEncoder::new(Vec::new(), Compression::default());
        z.write_all(&raw)?;
        z.finish()?
    };
    if !zipped.is_empty() && zipped.len() < raw.len() {
        out.extend_from_slice(&(zipped.len() as i64).to_le_bytes());
        out.extend_from_slice(&zipped);
    } else {
        out.extend_from_slice(&(-(raw.len() as i64)).to_le_bytes());
        out.extend_from_slice(&raw);
    }
    Ok(())
}

/// A UUID in OpenVDB's 36-character text form, from a hash of the grid, so that the same grid
/// always gives the same file.
fn uuid(body: &[u8]) -> String {
    let half = |salt: u8| {
        let mut h = DefaultHasher::new();
        (salt, body).hash(&mut h);
        h.finish()
    };
    let hex = format!("{:016x}{:016x}", half(0), half(1));
    format!("{}-{}-{}-{}-{}", &hex[..8], &hex[8..12], &hex[12..16], &hex[16..20], &hex[20..])
}

// ---------------------------------------------------------------------------------------------
// Reading

/// Reads the float grid `name` of the OpenVDB file at `path` as a density grid.
///
/// The file is read into memory and checked completely first: header, every grid descriptor and
/// its metadata, and the requested grid's transform, tree and value blocks, each size against the
/// bytes that are really there, and zip chunks unpacked to check their size, so a bad file gives a
/// [`VdbError`] naming it and its problem, and no size read from it is trusted before it is checked.
/// Only then does `vdb-rs` parse it (inside `catch_unwind`, as a last defense); a damaged blosc
/// payload is the one fault left for it (c-blosc) to find.
///
/// Accepted: file versions 222-224; float grids (`Tree_float_5_4_3`, not saved as half floats, not
/// instanced), zip, blosc or no compression; a transform that is a uniform scale s with any
/// translation (`UniformScaleMap`, `UniformScaleTranslateMap`, or `ScaleTranslateMap` with equal
/// scales); background 0 and no active tiles; finite non-negative values. Only active voxels are
/// read (an active zero is dropped). `fiber_width` must be in the grid metadata (float or double,
/// positive): there is no default, as a wrong width would silently scale every fiber count. A
/// `voxel_size` entry, if present, must agree with the transform, which gives the voxel size.
///
/// OpenVDB puts voxel (i, j, k)'s center at (i, j, k) s + t for translation t; ours is at
/// ((i, j, k) + 1/2) s. When t is s/2 plus a whole number of voxels on every axis (as in our own
/// files) the voxels map one to one, values bit for bit. Otherwise (e.g. a plain uniform scale,
/// t = 0) the grid is resampled to our voxel centers by trilinear interpolation: each voxel's value
/// is spread over the up to 8 of our voxels around its center with tent weights, which keeps the
/// total hair length and blurs by up to one voxel.
pub fn read_vdb(path: &Path, name: &str) -> Result<DensityGrid, VdbError> {
    let data = std::fs::read(path).map_err(|error| VdbError::Io { path: path.to_owned(), error })?;
    parse_vdb(&data, path, name)
}

/// [`read_vdb`] for a file already in memory: `data` are its bytes, `path` is what errors name.
pub fn parse_vdb(data: &[u8], path: &Path, name: &str) -> Result<DensityGrid, VdbError> {
    let info = validate(data, path, name)?;
    let grid_error = |problem: String| VdbError::Grid { path: path.to_owned(), grid: name.to_owned(), problem };
    let reader_error = |message: String| VdbError::Reader { path: path.to_owned(), grid: name.to_owned(), message };

    let voxels = read_with_vdb_rs(data, &info.key).map_err(reader_error)?;
    if voxels.len() as u64 != info.active_voxels {
        return Err(reader_error(format!(
            "it returned {} active voxels but the file has {}",
            voxels.len(),
            info.active_voxels
        )));
    }
    if let Some((p, v)) = voxels.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
        return Err(grid_error(format!("voxel {p:?} holds {v}; densities must be finite and >= 0")));
    }

    // Our continuous index of the file's voxel i: i + t / s - 1/2 = i + base + frac per axis.
    let s = info.voxel_size;
    let mut base = [0i32; 3];
    let mut frac = [0f64; 3];
    for k in 0..3 {
        let d = info.translation[k] / s - 0.5;
        if d.is_nan() || d.abs() > MAX_INDEX as f64 {
            return Err(grid_error(format!(
                "its translation {:?} is more than 2^24 voxels from the origin",
                info.translation
            )));
        }
        // Snap float noise in the translation (a millionth of a voxel) to the exact lattice.
        let (r, f) = if (d - d.round()).abs() <= 1e-6 { (d.round(), 0.0) } else { (d.floor(), d - d.floor()) };
        base[k] = r as i32;
        frac[k] = f;
    }
    let mut sums: HashMap<[i32; 3], f64> = HashMap::with_capacity(voxels.len());
    for (p, v) in voxels {
        for corner in 0..8 {
            let mut w = 1.0;
            let mut q = [0; 3];
            for k in 0..3 {
                let upper = corner >> k & 1 == 1;
                w *= if upper { frac[k] } else { 1.0 - frac[k] };
                q[k] = p[k] + base[k] + upper as i32;
            }
            if w > 0.0 {
                *sums.entry(q).or_default() += w * v as f64;
            }
        }
    }
    Ok(DensityGrid::from_voxels(s, info.fiber_width, sums.into_iter().map(|(q, v)| (q, v as f32))))
}

/// Runs vdb-rs on a validated file: the active voxels of grid `key` (vdb-rs's name for it).
fn read_with_vdb_rs(data: &[u8], key: &str) -> Result<Vec<([i32; 3], f32)>, String> {
    // vdb-rs says only "IoError" for I/O errors.
    let message = |e: vdb_rs::ParseError| match e {
        vdb_rs::ParseError::IoError(e) => e.to_string(),
        e => e.to_string(),
    };
    let read = || -> Result<Vec<([i32; 3], f32)>, String> {
        let mut reader = vdb_rs::VdbReader::new(io::Cursor::new(data)).map_err(message)?;
        let grid = reader.read_grid::<f32>(key).map_err(message)?;
        grid.iter()
            .map(|(p, v, level)| match level {
                // vdb-rs gives glam 0.24 positions in index space, whole numbers within +-2^24.
                vdb_rs::VdbLevel::Voxel => Ok((p.to_array().map(|c| c as i32), v)),
                _ => Err("it returned a tile where validation found none".to_owned()),
            })
            .collect()
    };
    std::panic::catch_unwind(read).unwrap_or_else(|panic| {
        let message = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(format!("vdb-rs panicked: {message}"))
    })
}

/// What validation learned about the requested grid.
struct GridInfo {
    /// The grid's name as vdb-rs keys it (each byte as a char).
    key: String,
    voxel_size: f64,
    translation: [f64; 3],
    fiber_width: f64,
    active_voxels: u64,
}

/// A position in the file's bytes; every read is checked against the bytes that are left.
struct Cursor<'a> {
    data: &'a [u8],
    pos: usize,
    path: &'a Path,
    /// For unpacking zip chunks (at most a node's values).
    scratch: Vec<u8>,
}

impl<'a> Cursor<'a> {
    fn corrupt(&self, offset: usize, problem: String) -> VdbError {
        VdbError::Corrupt { path: self.path.to_owned(), offset, problem }
    }

    fn bytes(&mut self, n: u64, what: &str) -> Result<&'a [u8], VdbError> {
        let left = self.data.len() - self.pos;
        if n > left as u64 {
            return Err(self.corrupt(self.pos, format!("{what} needs {n} bytes but the file has {left} left")));
        }
        let b = &self.data[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(b)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], VdbError> {
        Ok(self.bytes(N as u64, what)?.try_into().expect("N bytes"))
    }

    fn u8(&mut self, what: &str) -> Result<u8, VdbError> {
        Ok(self.array::<1>(what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, VdbError> {
        self.array(what).map(u32::from_le_bytes)
    }

    fn i64(&mut self, what: &str) -> Result<i64, VdbError> {
        self.array(what).map(i64::from_le_bytes)
    }

    fn f32(&mut self, what: &str) -> Result<f32, VdbError> {
        self.array(what).map(f32::from_le_bytes)
    }

    fn vec3i(&mut self, what: &str) -> Result<[i32; 3], VdbError> {
        let b: [u8; 12] = self.array(what)?;
        Ok([0, 1, 2].map(|k| i32::from_le_bytes(b[4 * k..4 * k + 4].try_into().expect("4 bytes"))))
    }

    fn vec3d(&mut self, what: &str) -> Result<[f64; 3], VdbError> {
        let b: [u8; 24] = self.array(what)?;
        Ok([0, 1, 2].map(|k| f64::from_le_bytes(b[8 * k..8 * k + 8].try_into().expect("8 bytes"))))
    }

    /// A u32 length and that many bytes.
    fn string(&mut self, what: &str) -> Result<&'a [u8], VdbError> {
        let n = self.u32(what)?;
        self.bytes(n as u64, what)
    }

    /// A node mask of `size` bits as u64 words.
    fn mask(&mut self, size: usize, what: &str) -> Result<Vec<u64>, VdbError> {
        let b = self.bytes(size as u64 / 8, what)?;
        Ok(b.chunks_exact(8).map(|w| u64::from_le_bytes(w.try_into().expect("8 bytes"))).collect())
    }

    fn seek(&mut self, pos: i64, what: &str) -> Result<(), VdbError> {
        if pos < 0 || pos as u64 > self.data.len() as u64 {
            return Err(self.corrupt(self.pos, format!("{what} {pos} is outside the file ({} bytes)", self.data.len())));
        }
        self.pos = pos as usize;
        Ok(())
    }
}

/// One metadata entry: name, type name, value bytes.
type Meta<'a> = (&'a [u8], &'a [u8], &'a [u8]);

/// MetaMap::readMeta; checks what vdb-rs relies on: the sizes of the types it reads itself.
fn metadata<'a>(c: &mut Cursor<'a>, what: &str) -> Result<Vec<Meta<'a>>, VdbError> {
    let count = c.u32(&format!("{what} count"))?;
    let mut entries = Vec::new();
    for _ in 0..count {
        let at = c.pos;
        let name = c.string(&format!("{what} name"))?;
        let type_name = c.string(&format!("{what} type"))?;
        let value = c.string(&format!("{what} value"))?;
        let size = match type_name {
            b"bool" => Some(1),
            b"int32" | b"float" => Some(4),
            b"int64" => Some(8),
            b"vec3i" => Some(12),
            _ => None,
        };
        match size {
            Some(n) if n != value.len() => {
                let (name, type_name) = (latin1(name), latin1(type_name));
                let problem = format!("{what} {name:?} of type {type_name} has {} bytes, not {n}", value.len());
                return Err(c.corrupt(at, problem));
            }
            _ => entries.push((name, type_name, value)),
        }
    }
    Ok(entries)
}

fn find_meta<'a>(entries: &[Meta<'a>], name: &str) -> Option<(&'a [u8], &'a [u8])> {
    entries.iter().find(|e| e.0 == name.as_bytes()).map(|e| (e.1, e.2))
}

/// A float or double metadata value.
fn meta_real(entries: &[Meta], name: &str) -> Result<Option<f64>, String> {
    match find_meta(entries, name) {
        None => Ok(None),
        Some((b"float", v)) => Ok(Some(f32::from_le_bytes(v.try_into().expect("checked size")) as f64)),
        Some((b"double", v)) => match <[u8; 8]>::try_from(v) {
            Ok(b) => Ok(Some(f64::from_le_bytes(b))),
            Err(_) => Err(format!("its {name} metadata is a double of {} bytes", v.len())),
        },
        Some((t, _)) => Err(format!("its {name} metadata has type {}; it must be float or double", latin1(t))),
    }
}

/// Bytes as vdb-rs turns them into a `String`: each byte one char.
fn latin1(b: &[u8]) -> String {
    b.iter().map(|&c| c as char).collect()
}

/// A grid descriptor (GridDescriptor::read) and what is at its grid position.
struct Descriptor<'a> {
    type_name: &'a [u8],
    instance_parent: &'a [u8],
    block_pos: i64,
    compression: u32,
    metadata: Vec<Meta<'a>>,
    /// Where the transform starts.
    transform_pos: usize,
}

/// Checks the whole file as far as reading grid `name` with vdb-rs goes.
fn validate(data: &[u8], path: &Path, name: &str) -> Result<GridInfo, VdbError> {
    let mut c = Cursor { data, pos: 0, path, scratch: Vec::new() };
    // Archive::readHeader.
    if data.get(..8).is_none_or(|m| m != MAGIC.to_le_bytes()) {
        return Err(VdbError::NotVdb { path: path.to_owned() });
    }
    c.pos = 8;
    let version = c.u32("the file format version")?;
    if !(OLDEST_VERSION..=FILE_VERSION).contains(&version) {
        return Err(VdbError::Version { path: path.to_owned(), version });
    }
    c.bytes(8, "the library version")?;
    if c.u8("the grid offsets flag")? != 1 {
        return Err(VdbError::Unsupported {
            path: path.to_owned(),
            problem: "it was written as a stream, without grid offsets; re-save it as a file".to_owned(),
        });
    }
    c.bytes(36, "the UUID")?;
    metadata(&mut c, "file metadata")?;

    // File::readGridDescriptors: each descriptor, its grid's compression and metadata, then on to
    // the next descriptor at the grid's end. Positions must move forward, so this is linear.
    let count = c.u32("the grid count")?;
    let mut names = Vec::new();
    let mut found = None;
    for _ in 0..count {
        let start = c.pos;
        let unique_name = c.string("a grid name")?;
        let type_name = c.string("a grid type")?;
        let instance_parent = c.string("a grid's instance parent")?;
        let grid_pos = c.i64("a grid position")?;
        let block_pos = c.i64("a grid's data position")?;
        let end_pos = c.i64("a grid's end position")?;
        let key = latin1(unique_name);
        if !(c.pos as i64 <= grid_pos && grid_pos <= block_pos && block_pos <= end_pos) {
            return Err(c.corrupt(
                start,
                format!("grid {key:?} has positions {grid_pos}, {block_pos}, {end_pos}, out of order"),
            ));
        }
        if names.contains(&key) {
            return Err(c.corrupt(start, format!("there are two grids named {key:?}")));
        }
        if end_pos > data.len() as i64 {
            return Err(c.corrupt(start, format!("grid {key:?} ends at byte {end_pos}, past the end of the file")));
        }
        c.seek(grid_pos, &format!("the position of grid {key:?}"))?;
        let compression = c.u32("a grid's compression flags")?;
        if compression & !(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC) != 0 {
            return Err(c.corrupt(c.pos - 4, format!("grid {key:?} has unknown compression flags {compression:#x}")));
        }
        let metadata = metadata(&mut c, "grid metadata")?;
        // Its metadata must end before its data, so no byte is parsed twice.
        if c.pos as i64 > block_pos {
            return Err(c.corrupt(c.pos, format!("the metadata of grid {key:?} runs past its data position")));
        }
        if unique_name == name.as_bytes() {
            found =
                Some(Descriptor { type_name, instance_parent, block_pos, compression, metadata, transform_pos: c.pos });
        }
        names.push(key);
        c.seek(end_pos, "the end of a grid")?;
    }
    let Some(d) = found else {
        return Err(VdbError::NoSuchGrid { path: path.to_owned(), name: name.to_owned(), available: names });
    };
    let grid_error = |problem: String| VdbError::Grid { path: path.to_owned(), grid: name.to_owned(), problem };

    // What the grid is.
    let half = find_meta(&d.metadata, "is_saved_as_half_float") == Some((b"bool", &[1]));
    if d.type_name.ends_with(HALF_SUFFIX) || half {
        return Err(grid_error(
            "it is saved as 16-bit half floats, which vdb-rs cannot read; re-save it with full floats \
             (OpenVDB: grid.setSaveFloatAsHalf(false))"
                .to_owned(),
        ));
    }
    if d.type_name != GRID_TYPE {
        return Err(grid_error(format!(
            "its type is {}; only float grids with OpenVDB's standard tree ({}) are read",
            latin1(d.type_name),
            latin1(GRID_TYPE)
        )));
    }
    if !d.instance_parent.is_empty() {
        return Err(grid_error(format!(
            "it is an instance of grid {:?} (shares its tree); re-save it without instancing",
            latin1(d.instance_parent)
        )));
    }
    if find_meta(&d.metadata, "class") == Some((b"string", b"level set")) {
        return Err(grid_error("it is a level set (signed distances), not a density".to_owned()));
    }
    let fiber_width = meta_real(&d.metadata, "fiber_width").map_err(grid_error)?.ok_or_else(|| {
        grid_error(
            "it has no fiber_width metadata (the mean fiber diameter in world units, float or double); add it, \
             e.g. in Python: grid['fiber_width'] = 0.0001"
                .to_owned(),
        )
    })?;
    if !(fiber_width > 0.0 && fiber_width.is_finite()) {
        return Err(grid_error(format!("its fiber_width metadata is {fiber_width}; it must be finite and > 0")));
    }

    // Transform::read and the map's read (math/Maps.h).
    c.pos = d.transform_pos;
    let map = c.string("the transform type")?;
    let translation = match map {
        b"UniformScaleMap" => [0.0; 3],
        b"UniformScaleTranslateMap" | b"ScaleTranslateMap" => c.vec3d("the transform's translation")?,
        other => {
            return Err(grid_error(format!(
                "its transform is a {}; supported are a uniform scale with or without a translation \
                 (UniformScaleMap, UniformScaleTranslateMap, or ScaleTranslateMap with equal scales)",
                latin1(other)
            )));
        }
    };
    let scale = c.vec3d("the transform's scale")?;
    c.bytes(4 * 24, "the transform's derived vectors")?;
    let s = scale[0];
    if !(s > 0.0 && s.is_finite() && scale.iter().all(|&x| (x - s).abs() <= 1e-9 * s)) {
        return Err(grid_error(format!("its voxels are not cubes of positive finite size: scale {scale:?}")));
    }
    if !translation.iter().all(|t| t.is_finite()) {
        return Err(grid_error(format!("its translation {translation:?} is not finite")));
    }
    let stored_size = meta_real(&d.metadata, "voxel_size").map_err(grid_error)?;
    if let Some(v) = stored_size.filter(|v| v.is_nan() || (v - s).abs() > 1e-6 * s) {
        return Err(grid_error(format!(
            "its voxel_size metadata ({v}) disagrees with its transform's voxel size ({s}): the grid was rescaled \
             after it was written, so fiber_width ({fiber_width}) may be stale too; fix or remove the metadata"
        )));
    }

    // Tree::readTopology, RootNode::readTopology.
    let at = c.pos;
    let buffers = c.u32("the tree's buffer count")?;
    if buffers != 1 {
        return Err(c.corrupt(at, format!("the tree has {buffers} buffers; OpenVDB trees have 1")));
    }
    let background = c.f32("the background value")?;
    if background != 0.0 {
        return Err(grid_error(format!("its background is {background}; a density grid's must be 0")));
    }
    let tiles = c.u32("the root tile count")?;
    let children = c.u32("the root child count")?;
    for _ in 0..tiles {
        let origin = c.vec3i("a root tile")?;
        c.f32("a root tile")?;
        if c.u8("a root tile")? != 0 {
            return Err(grid_error(format!(
                "it has an active tile (a constant region) at {origin:?}; densify it first \
                 (OpenVDB: tree.voxelizeActiveTiles())"
            )));
        }
    }
    let mut origins = HashSet::new();
    let mut leaf_masks = Vec::new();
    for _ in 0..children {
        let at = c.pos;
        let origin = c.vec3i("a root child's origin")?;
        if origin.iter().any(|&o| o % ROOT_CHILD_EDGE != 0) || !origins.insert(origin) {
            return Err(c.corrupt(at, format!("root child origin {origin:?} is misaligned or repeated")));
        }
        if origin.iter().any(|&o| !(-MAX_INDEX..=MAX_INDEX - ROOT_CHILD_EDGE).contains(&o)) {
            return Err(grid_error(format!("it has voxels near {origin:?}, more than 2^24 from the index origin")));
        }
        let upper = internal_node(&mut c, &d, UPPER_VALUES, &grid_error)?;
        for _ in 0..upper {
            let lower = internal_node(&mut c, &d, LOWER_VALUES, &grid_error)?;
            for _ in 0..lower {
                leaf_masks.push(c.mask(LEAF_VALUES, "a leaf's value mask")?);
            }
        }
    }

    // Tree::readBuffers, LeafNode::readBuffers: the mask again (vdb-rs expands the values with this
    // copy but iterates with the first), then the values.
    c.seek(d.block_pos, "the grid's data position")?;
    for topology_mask in &leaf_masks {
        let at = c.pos;
        if c.mask(LEAF_VALUES, "a leaf's value mask")? != *topology_mask {
            return Err(c.corrupt(at, "a leaf's value mask differs from the one in the tree topology".to_owned()));
        }
        values(&mut c, &d, LEAF_VALUES, count_ones(topology_mask))?;
    }
    let active_voxels = leaf_masks.iter().map(|m| count_ones(m) as u64).sum();
    Ok(GridInfo { key: latin1(name.as_bytes()), voxel_size: s, translation, fiber_width, active_voxels })
}

fn count_ones(mask: &[u64]) -> usize {
    mask.iter().map(|w| w.count_ones() as usize).sum()
}

/// InternalNode::readTopology up to its children: child mask, value mask, values. Returns the
/// number of children. Active tiles are refused: vdb-rs would return them as single voxels.
fn internal_node(
    c: &mut Cursor,
    d: &Descriptor,
    size: usize,
    grid_error: &impl Fn(String) -> VdbError,
) -> Result<usize, VdbError> {
    let child_mask = c.mask(size, "an internal node's child mask")?;
    let value_mask = c.mask(size, "an internal node's value mask")?;
    if count_ones(&value_mask) > 0 {
        return Err(grid_error(
            "it has active tiles (constant regions); densify it first (OpenVDB: tree.voxelizeActiveTiles())".to_owned(),
        ));
    }
    values(c, d, size, 0)?;
    Ok(count_ones(&child_mask))
}

/// io::readCompressedValues for a node of `size` values, `active` of them active: checks that the
/// chunk is complete and its sizes agree, as vdb-rs relies on (it asserts or allocates by them).
fn values(c: &mut Cursor, d: &Descriptor, size: usize, active: usize) -> Result<(), VdbError> {
    let at = c.pos;
    let meta = c.u8("a value block's metadata byte")?;
    if meta > NO_MASK_AND_ALL_VALS {
        return Err(c.corrupt(at, format!("value block metadata {meta} is not 0 to 6")));
    }
    if matches!(meta, NO_MASK_AND_ONE_INACTIVE_VAL | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS) {
        c.bytes(4, "an inactive value")?;
    }
    if meta == MASK_AND_TWO_INACTIVE_VALS {
        c.bytes(4, "an inactive value")?;
    }
    if matches!(meta, MASK_AND_NO_INACTIVE_VALS | MASK_AND_ONE_INACTIVE_VAL | MASK_AND_TWO_INACTIVE_VALS) {
        c.bytes(size as u64 / 8, "a selection mask")?;
    }
    let count = if d.compression & COMPRESS_ACTIVE_MASK != 0 && meta != NO_MASK_AND_ALL_VALS { active } else { size };
    let bytes = 4 * count as i64;
    if d.compression & (COMPRESS_BLOSC | COMPRESS_ZIP) == 0 {
        c.bytes(bytes as u64, "a block of values")?;
        return Ok(());
    }
    let at = c.pos;
    let n = c.i64("a compressed chunk's size")?;
    if n <= 0 {
        // Stored raw: the size must be exact (vdb-rs asserts it for blosc).
        if n != -bytes {
            return Err(c.corrupt(at, format!("a raw chunk of {} bytes where {bytes} were expected", n.unsigned_abs())));
        }
        c.bytes(bytes as u64, "a raw chunk")?;
    } else {
        let chunk = c.bytes(n as u64, "a compressed chunk")?;
        if d.compression & COMPRESS_BLOSC == 0 {
            // io::unzipFromStream: the zlib stream must unpack to exactly the values' size.
            c.scratch.clear();
            let unpacked = ZlibDecoder::new(chunk).take(bytes as u64 + 1).read_to_end(&mut c.scratch);
            match unpacked {
                Ok(len) if len == bytes as usize => {}
                Ok(len) => return Err(c.corrupt(at, format!("a zip chunk unpacks to {len} bytes, not {bytes}"))),
                Err(e) => return Err(c.corrupt(at, format!("a zip chunk does not unpack: {e}"))),
            }
        }
        // io::bloscFromStream; vdb-rs sizes its output by the header's uncompressed size, and
        // c-blosc bounds its reads by the header's compressed size: both must be right.
        else {
            let word = |i: usize| chunk.get(i..i + 4).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")));
            let (raw, stored) = (word(4), word(12));
            if raw != Some(bytes as u32) || stored != Some(n as u32) {
                return Err(c.corrupt(
                    at,
                    format!(
                        "a blosc chunk of {n} bytes whose header says {} bytes unpacked from {} (expected \
                         {bytes} from {n})",
                        raw.unwrap_or_default(),
                        stored.unwrap_or_default()
                    ),
                ));
            }
        }
    }
    Ok(())
}
