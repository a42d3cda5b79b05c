//! Cem Yuksel's .hair format (cemyuksel.com/research/hairmodels), read and written.
//!
//! Layout, all little-endian: a 128-byte header ("HAIR", u32 strand count, u32 point count, u32 flags,
//! u32 default segments, f32 default thickness, f32 default transparency, f32[3] default color,
//! char[88] info), then the arrays the flags name, in flag order: u16 segments per strand, f32 xyz
//! points, f32 thickness per point (a diameter), f32 transparency per point, f32 rgb color per point.
//! A strand with s segments has s + 1 points. Transparency and colors are checked for size and skipped:
//! the renderer takes its material from the scene. A `.hair.gz` file is a gzip of one (the bundled
//! groom is stored so), decoded as it is read.

use super::{StrandError, Strands};
use glam::Vec3;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 4] = b"HAIR";
const HEADER_LEN: usize = 128;
const INFO_LEN: usize = 88;

// Array flags (cyHairFile.h, _CY_HAIR_FILE_*_BIT).
const SEGMENTS: u32 = 1;
const POINTS: u32 = 2;
const THICKNESS: u32 = 4;
const TRANSPARENCY: u32 = 8;
const COLORS: u32 = 16;
const KNOWN_FLAGS: u32 = SEGMENTS | POINTS | THICKNESS | TRANSPARENCY | COLORS;

/// A .hair file that cannot be loaded; the message says what is wrong in terms of the file.
#[derive(Debug, thiserror::Error)]
pub enum HairError {
    // Not named `source`: the message says the cause, and as a source it would print twice.
    #[error("cannot read {}: {error}", path.display())]
    Io { path: PathBuf, error: io::Error },
    /// Any other error, for the file at `path` (what [`read_hair`] returns).
    #[error("{}: {error}", path.display())]
    InFile { path: PathBuf, error: Box<HairError> },
    #[error("the file is {len} bytes, shorter than the {HEADER_LEN}-byte .hair header")]
    TruncatedHeader { len: usize },
    #[error("the file starts with \"{}\", not \"HAIR\": it is not a .hair file", found.escape_ascii())]
    BadMagic { found: [u8; 4] },
    #[error(
        "header flags {flags:#x} set bits this reader does not know ({:#x}); known are 1 segments, 2 points, \
         4 thickness, 8 transparency, 16 colors",
        flags & !KNOWN_FLAGS
    )]
    UnknownFlags { flags: u32 },
    #[error("header flags {flags:#x} have no points array (flag 2): the file holds no geometry")]
    NoPoints { flags: u32 },
    #[error(
        "header says {strands} strands and {points} points ({} of arrays) but the file has {actual} bytes after \
         its header",
        human_bytes(*expected)
    )]
    Truncated { strands: u32, points: u32, expected: u64, actual: u64 },
    #[error(
        "{extra} bytes follow the arrays that the header describes ({strands} strands, {points} points, flags \
         {flags:#x}); the counts or flags are wrong"
    )]
    TrailingBytes { strands: u32, points: u32, flags: u32, extra: u64 },
    #[error(
        "the {strands} strands' segment counts need {needed} points (segments + 1 per strand) but the header \
         says {points}"
    )]
    PointCountMismatch { strands: u32, needed: u64, points: u32 },
    #[error("there is no thickness array and the header's default thickness is {0}; it must be finite and > 0")]
    BadDefaultThickness(f32),
    #[error(transparent)]
    Geometry(#[from] StrandError),
}

/// Deflate expands at most 1032:1, so a gzip stream that decodes to more than that many times its
/// file's size is not one; reading stops there (a lying stream cannot fill memory).
const GZIP_MAX_EXPANSION: u64 = 1032;

/// Whether `path` names a gzip-compressed .hair file (`.hair.gz`, or any `.gz`).
fn is_gzip(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz"))
}

/// Reads a .hair file, or a gzip-compressed one (`.gz`, decoded as it is read); every error names
/// `path`.
pub fn read_hair(path: &Path) -> Result<Strands, HairError> {
    let io = |error| HairError::Io { path: path.to_owned(), error };
    let bytes = if is_gzip(path) {
        let file = std::fs::File::open(path).map_err(io)?;
        let limit = file.metadata().map_err(io)?.len().saturating_mul(GZIP_MAX_EXPANSION);
        let mut bytes = Vec::new();
        let decoder = flate2::read::MultiGzDecoder::new(io::BufReader::new(file));
        decoder.take(limit).read_to_end(&mut bytes).map_err(io)?;
        bytes
    } else {
        std::fs::read(path).map_err(io)?
    };
    parse_hair(&bytes).map_err(|error| HairError::InFile { path: path.to_owned(), error: Box::new(error) })
}

/// Parses the bytes of a .hair file. Every count in the header is checked against the real size of
/// `bytes` before anything sized by it is allocated, so a corrupt header costs no memory; the
/// geometry is then checked by [`Strands::validate`].
pub fn parse_hair(bytes: &[u8]) -> Result<Strands, HairError> {
    let Some((header, body)) = bytes.split_first_chunk::<HEADER_LEN>() else {
        return Err(HairError::TruncatedHeader { len: bytes.len() });
    };
    let word = |i: usize| [header[4 * i], header[4 * i + 1], header[4 * i + 2], header[4 * i + 3]];
    if word(0) != *MAGIC {
        return Err(HairError::BadMagic { found: word(0) });
    }
    let [strands, points, flags, default_segments] = [1, 2, 3, 4].map(|i| u32::from_le_bytes(word(i)));
    let default_thickness = f32_at(header, 20);
    if flags & !KNOWN_FLAGS != 0 {
        return Err(HairError::UnknownFlags { flags });
    }
    if flags & POINTS == 0 {
        return Err(HairError::NoPoints { flags });
    }

    // Bytes per strand and per point of each array present; u64 cannot overflow (< 2^38).
    let has = |flag: u32| flags & flag != 0;
    let segment_bytes = if has(SEGMENTS) { 2 * u64::from(strands) } else { 0 };
    let per_point: u64 = [(POINTS, 12), (THICKNESS, 4), (TRANSPARENCY, 4), (COLORS, 12)]
        .iter()
        .filter(|&&(flag, _)| has(flag))
        .map(|&(_, size)| size)
        .sum();
    let expected = segment_bytes + per_point * u64::from(points);
    let actual = body.len() as u64;
    if actual < expected {
        return Err(HairError::Truncated { strands, points, expected, actual });
    }
    if actual > expected {
        return Err(HairError::TrailingBytes { strands, points, flags, extra: actual - expected });
    }

    let (segments, body) = body.split_at(segment_bytes as usize);
    let segments = segments.chunks_exact(2).map(|c| u32::from(u16::from_le_bytes([c[0], c[1]])));
    // (segments + 1) summed over strands; the default case stays below 2^64 as both factors are <= 2^32.
    let needed = if has(SEGMENTS) {
        segments.clone().map(|s| u64::from(s) + 1).sum()
    } else {
        u64::from(strands) * (u64::from(default_segments) + 1)
    };
    if needed != u64::from(points) {
        return Err(HairError::PointCountMismatch { strands, needed, points });
    }

    // From here on every size is bounded by the file's: points <= body.len() / 12.
    let (xyz, thickness) = body.split_at(12 * points as usize);
    let points_xyz = xyz.chunks_exact(12).map(|c| Vec3::from_array(std::array::from_fn(|k| f32_at(c, 4 * k))));
    let radii = if has(THICKNESS) {
        thickness.chunks_exact(4).take(points as usize).map(|c| 0.5 * f32_at(c, 0)).collect()
    } else if default_thickness.is_finite() && default_thickness > 0.0 {
        vec![0.5 * default_thickness; points as usize]
    } else {
        return Err(HairError::BadDefaultThickness(default_thickness));
    };
    let mut offsets = Vec::with_capacity(strands as usize + 1);
    offsets.push(0);
    let mut end = 0u32;
    let mut push = |s: u32| {
        end += s + 1; // cannot overflow: the sum equals `points`
        offsets.push(end);
    };
    if has(SEGMENTS) {
        segments.for_each(&mut push);
    } else {
        (0..strands).for_each(|_| push(default_segments));
    }
    let strands = Strands { points: points_xyz.collect(), radii, offsets };
    strands.validate()?;
    Ok(strands)
}

/// Writes `strands` as a .hair file with segments, points and thickness arrays (flags 7) and
/// `info` (cut to 87 bytes at a character boundary, leaving room for the terminating NUL).
/// Fails with `InvalidInput`, writing nothing, if the strands do not pass [`Strands::validate`]
/// (the file would not load) or a strand has more than 65536 points (the u16 segment count).
pub fn write_hair<W: Write>(mut w: W, strands: &Strands, info: &str) -> io::Result<()> {
    let invalid = |message: String| io::Error::new(io::ErrorKind::InvalidInput, message);
    strands.validate().map_err(|e| invalid(format!("cannot write .hair: {e}")))?;
    let segments = strands
        .offsets
        .windows(2)
        .enumerate()
        .map(|(s, o)| {
            u16::try_from(o[1] - o[0] - 1).map_err(|_| {
                invalid(format!("strand {s} has {} points; a .hair strand holds at most 65536", o[1] - o[0]))
            })
        })
        .collect::<io::Result<Vec<u16>>>()?;

    let mut bytes = Vec::with_capacity(HEADER_LEN + 2 * segments.len() + 16 * strands.points.len());
    bytes.extend_from_slice(MAGIC);
    // validate() checked that the last offset is the point count, so both counts fit in a u32.
    let (strand_count, point_count) = (segments.len() as u32, strands.points.len() as u32);
    for word in [strand_count, point_count, SEGMENTS | POINTS | THICKNESS, 0] {
        bytes.extend_from_slice(&word.to_le_bytes());
    }
    // Defaults for thickness, transparency and color as cyHairFile.h's Initialize() sets them.
    for value in [1.0f32, 0.0, 1.0, 1.0, 1.0] {
        bytes.extend_from_slice(&value.to_le_bytes());
    }
    let mut end = info.len().min(INFO_LEN - 1);
    while !info.is_char_boundary(end) {
        end -= 1;
    }
    bytes.extend_from_slice(&info.as_bytes()[..end]);
    bytes.resize(HEADER_LEN, 0);
    bytes.extend(segments.iter().flat_map(|s| s.to_le_bytes()));
    bytes.extend(strands.points.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes));
    bytes.extend(strands.radii.iter().flat_map(|r| (2.0 * r).to_le_bytes()));
    w.write_all(&bytes)
}

/// The little-endian f32 at byte `i` of `b`.
fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

/// A byte count for people: "812 bytes", "51.5 GB".
fn human_bytes(n: u64) -> String {
    let (mut value, mut unit) = (n as f64, "bytes");
    for larger in ["kB", "MB", "GB", "TB"] {
        if value < 1000.0 {
            break;
        }
        (value, unit) = (value / 1000.0, larger);
    }
    if n < 1000 { format!("{n} bytes") } else { format!("{value:.1} {unit}") }
}
