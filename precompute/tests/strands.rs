//! Strand geometry: the .hair reader and writer against hand-built files, an independent reader and a
//! real groom, and the generators against the closed forms of their shapes.

use glam::Vec3;
use precompute::strands::{
    Ball, Curly, GenerateError, Generator, HairError, Scalp, Straight, StrandError, Strands, Wavy, parse_hair,
    read_hair, write_hair,
};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::Deserialize;
use serde::de::value::{Error as DeError, MapDeserializer};
use std::f64::consts::TAU;
use std::path::Path;

use crate::common::alloc::largest_allocation;
use crate::common::damage::{each_bit_flip, each_truncation};

// ---------------------------------------------------------------------------------------------
// Hand-built files and an independent reader, written from the format's description
// (cemyuksel.com/research/hairmodels) with std only, sharing no code with the crate.

/// A .hair file: header fields and raw arrays, serialized byte by byte.
struct RawHair {
    strands: u32,
    points: u32,
    flags: u32,
    default_segments: u32,
    default_thickness: f32,
    segments: Vec<u16>,
    xyz: Vec<f32>,
    thickness: Vec<f32>,
    /// Transparency and color floats, appended after the thickness.
    extra: Vec<f32>,
}

/// A change to [`RawHair::valid`] that makes it a bad file.
type Edit = fn(&mut RawHair);

impl RawHair {
    /// Two strands (3 and 2 points) with segments, points and thickness arrays (flags 7).
    fn valid() -> Self {
        RawHair {
            strands: 2,
            points: 5,
            flags: 7,
            default_segments: 0,
            default_thickness: 1.0,
            segments: vec![2, 1],
            xyz: vec![0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 2.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0],
            thickness: vec![0.004, 0.004, 0.002, 0.006, 0.002],
            extra: vec![],
        }
    }

    /// The bytes of [`RawHair::valid`] after `edit`.
    fn valid_with(edit: Edit) -> Vec<u8> {
        let mut raw = RawHair::valid();
        edit(&mut raw);
        raw.bytes()
    }

    fn bytes(&self) -> Vec<u8> {
        let mut b = b"HAIR".to_vec();
        for w in [self.strands, self.points, self.flags, self.default_segments] {
            b.extend_from_slice(&w.to_le_bytes());
        }
        for f in [self.default_thickness, 0.0, 1.0, 1.0, 1.0] {
            b.extend_from_slice(&f.to_le_bytes());
        }
        b.resize(128, 0);
        b.extend(self.segments.iter().flat_map(|s| s.to_le_bytes()));
        b.extend(self.xyz.iter().chain(&self.thickness).chain(&self.extra).flat_map(|f| f.to_le_bytes()));
        b
    }
}

/// What the independent reader finds in a file with segments, points and thickness arrays.
struct Independent {
    segments: Vec<u16>,
    xyz: Vec<f32>,
    thickness: Vec<f32>,
}

fn independent_read(bytes: &[u8]) -> Independent {
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
    assert_eq!(&bytes[0..4], b"HAIR");
    let (strands, points, flags) = (u32_at(4) as usize, u32_at(8) as usize, u32_at(12));
    assert_eq!(flags, 7, "the independent reader handles flags 7 only");
    let (seg_end, xyz_end) = (128 + 2 * strands, 128 + 2 * strands + 12 * points);
    assert_eq!(bytes.len(), xyz_end + 4 * points);
    let f32s = |b: &[u8]| b.chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    Independent {
        segments: bytes[128..seg_end].chunks(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect(),
        xyz: f32s(&bytes[seg_end..xyz_end]),
        thickness: f32s(&bytes[xyz_end..]),
    }
}

/// Asserts that `strands` holds exactly (bit for bit) what the independent reader found.
fn assert_same_as_independent(strands: &Strands, raw: &Independent) {
    let lengths: Vec<u32> = strands.offsets.windows(2).map(|w| w[1] - w[0]).collect();
    let expected: Vec<u32> = raw.segments.iter().map(|&s| u32::from(s) + 1).collect();
    assert_eq!(lengths, expected);
    let xyz: Vec<u32> = strands.points.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect();
    assert_eq!(xyz, raw.xyz.iter().map(|f| f.to_bits()).collect::<Vec<_>>());
    let radii: Vec<u32> = strands.radii.iter().map(|r| r.to_bits()).collect();
    assert_eq!(radii, raw.thickness.iter().map(|t| (t / 2.0).to_bits()).collect::<Vec<_>>());
}

fn bits(s: &Strands) -> (Vec<[u32; 3]>, Vec<u32>, Vec<u32>) {
    (
        s.points.iter().map(|p| p.to_array().map(f32::to_bits)).collect(),
        s.radii.iter().map(|r| r.to_bits()).collect(),
        s.offsets.clone(),
    )
}

fn write_to_vec(strands: &Strands, info: &str) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    write_hair(&mut out, strands, info).map(|()| out)
}

fn default_generators() -> Vec<Generator> {
    vec![
        Generator::Straight(Straight::default()),
        Generator::Wavy(Wavy::default()),
        Generator::Curly(Curly::default()),
        Generator::Ball(Ball::default()),
        Generator::Scalp(Scalp::default()),
    ]
}

// ---------------------------------------------------------------------------------------------
// Reading and writing

#[test]
fn write_then_read_is_bit_exact_for_generated_hair() {
    for generator in default_generators() {
        let strands = generator.generate().unwrap();
        let bytes = write_to_vec(&strands, "round trip").unwrap();
        assert_eq!(bits(&parse_hair(&bytes).unwrap()), bits(&strands), "{generator:?}");
        // The writer's bytes mean the same to a reader that shares no code with it.
        assert_same_as_independent(&strands, &independent_read(&bytes));
    }
}

#[test]
fn hand_built_file_reads_as_written() {
    let raw = RawHair::valid();
    let s = parse_hair(&raw.bytes()).unwrap();
    assert_eq!(s.offsets, [0, 3, 5]);
    assert_eq!(s.points[2], Vec3::new(0.5, 0.0, 2.0));
    assert_eq!(s.radii, [0.002, 0.002, 0.001, 0.003, 0.001]);
}

#[test]
fn defaults_stand_in_for_missing_arrays_and_extra_arrays_are_skipped() {
    // No segments and no thickness array: every strand has the default 2 segments and every point
    // the default thickness 0.01. Transparency (5 floats) and colors (15) are present and skipped.
    let mut raw = RawHair::valid();
    raw.strands = 2;
    raw.points = 6;
    raw.flags = 2 | 8 | 16;
    raw.default_segments = 2;
    raw.default_thickness = 0.01;
    raw.segments.clear();
    raw.thickness.clear();
    raw.xyz.extend([3.0, 3.0, 3.0]);
    raw.extra = vec![0.5; 6 * 4];
    let s = parse_hair(&raw.bytes()).unwrap();
    assert_eq!(s.offsets, [0, 3, 6]);
    assert_eq!(s.radii, [0.005; 6]);
    assert_eq!(s.points[5], Vec3::splat(3.0));
}

#[test]
fn bad_headers_give_their_errors() {
    let bytes = RawHair::valid().bytes();
    assert!(matches!(parse_hair(&bytes[..100]), Err(HairError::TruncatedHeader { len: 100 })));
    assert!(matches!(parse_hair(&[]), Err(HairError::TruncatedHeader { len: 0 })));

    let mut magic = bytes.clone();
    magic[3] = b'X';
    let err = parse_hair(&magic).unwrap_err();
    assert!(matches!(err, HairError::BadMagic { found } if found == *b"HAIX"), "{err}");

    let parse = |edit: Edit| parse_hair(&RawHair::valid_with(edit));
    assert!(matches!(parse(|r| r.flags = 7 | 32), Err(HairError::UnknownFlags { flags: 39 })));
    assert!(matches!(parse(|r| r.flags = 5), Err(HairError::NoPoints { flags: 5 })));
    let err = parse(|r| {
        r.flags = 3;
        r.thickness.clear();
        r.default_thickness = 0.0;
    });
    assert!(matches!(err, Err(HairError::BadDefaultThickness(0.0))));
}

#[test]
fn lying_counts_fail_fast_without_allocating() {
    let size = RawHair::valid().bytes().len();
    let cases: [(&str, Edit); 4] = [
        ("u32::MAX points", |r| r.points = u32::MAX),
        ("u32::MAX strands with a segments array", |r| r.strands = u32::MAX),
        // No segments array: u32::MAX strands of the default count, matching no point count.
        ("u32::MAX strands without a segments array", |r| {
            r.flags = 6;
            r.strands = u32::MAX;
            r.segments.clear();
        }),
        ("u32::MAX default segments", |r| {
            r.flags = 6;
            r.default_segments = u32::MAX;
            r.segments.clear();
        }),
    ];
    for (name, lie) in cases {
        let bytes = RawHair::valid_with(lie);
        let (result, largest) = largest_allocation(|| parse_hair(&bytes));
        let err = result.unwrap_err();
        assert!(matches!(err, HairError::Truncated { .. } | HairError::PointCountMismatch { .. }), "{name}: {err}");
        assert!(largest <= 4 * size, "{name}: allocated {largest} bytes for a {size}-byte file");
    }
    let message = parse_hair(&RawHair::valid_with(|r| r.points = u32::MAX)).unwrap_err().to_string();
    assert!(message.contains("4294967295 points") && message.contains("GB of arrays"), "{message}");
    assert!(message.contains(&format!("{} bytes after its header", size - 128)), "{message}");
}

#[test]
fn segment_counts_must_add_up_to_the_point_count() {
    let err = parse_hair(&RawHair::valid_with(|r| r.segments = vec![1, 1])).unwrap_err(); // 4 points, not 5
    assert!(matches!(err, HairError::PointCountMismatch { strands: 2, needed: 4, points: 5 }), "{err}");
}

#[test]
fn trailing_bytes_are_an_error() {
    let mut bytes = RawHair::valid().bytes();
    bytes.push(0);
    let err = parse_hair(&bytes).unwrap_err();
    assert!(matches!(err, HairError::TrailingBytes { extra: 1, .. }), "{err}");
}

#[test]
fn unrenderable_geometry_gives_the_strand_error() {
    let geometry = |edit: Edit| match parse_hair(&RawHair::valid_with(edit)) {
        Err(HairError::Geometry(g)) => g,
        other => panic!("expected a geometry error, got {other:?}"),
    };
    assert!(matches!(geometry(|r| r.xyz[4] = f32::NAN), StrandError::NonFinitePoint { strand: 0, point: 1, .. }));
    assert!(matches!(geometry(|r| r.thickness[3] = 0.0), StrandError::BadRadius { strand: 1, point: 3, radius: 0.0 }));
    assert!(matches!(
        geometry(|r| r.thickness[0] = -0.002),
        StrandError::BadRadius { strand: 0, point: 0, radius: -0.001 }
    ));
    assert_eq!(
        geometry(|r| r.xyz[3..6].copy_from_slice(&[0.0; 3])),
        StrandError::ZeroLengthSegment { strand: 0, point: 0, next: 1 }
    );
    // Strands of 1 and 4 points: same point count, but the first strand is a single point.
    assert_eq!(geometry(|r| r.segments = vec![0, 3]), StrandError::TooShort { strand: 0, points: 1 });
}

#[test]
fn file_errors_name_the_path() {
    let missing = Path::new("/nonexistent/dir/missing.hair");
    let err = read_hair(missing).unwrap_err();
    assert!(matches!(err, HairError::Io { .. }));
    assert!(err.to_string().contains("/nonexistent/dir/missing.hair"), "{err}");

    let dir = std::env::temp_dir().join(format!("strands-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("short.hair");
    std::fs::write(&path, b"HAIR").unwrap();
    let err = read_hair(&path).unwrap_err();
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        matches!(&err, HairError::InFile { error, .. } if matches!(**error, HairError::TruncatedHeader { len: 4 }))
    );
    let message = err.to_string();
    assert!(message.starts_with(&format!("{}: ", path.display())) && message.contains("4 bytes"), "{message}");
}

#[test]
fn parse_never_panics_on_truncated_or_corrupted_files() {
    let generated = Generator::Wavy(Wavy { strands: 20, points: 8, ..Wavy::default() }).generate().unwrap();
    let bytes = write_to_vec(&generated, "fuzz").unwrap();
    // Every allocation is bounded by the file: points (12 bytes each) and radii fit in the arrays,
    // offsets take 4 bytes per strand against its 2-byte segment count.
    // Whatever loads passes validation, and every error can be displayed.
    let check = |b: &[u8]| {
        let (result, largest) = largest_allocation(|| parse_hair(b).map_err(|e| e.to_string()));
        assert!(largest <= 2 * b.len() + 256, "allocated {largest} bytes for a {}-byte file", b.len());
        if let Ok(s) = &result {
            assert_eq!(s.validate(), Ok(()));
        }
        result
    };
    each_truncation(&bytes, bytes.len(), 1, |len, b| {
        assert!(check(b).is_err(), "a file cut to {len} bytes parsed");
    });
    // One to four flips each, half of them in the 24 bytes of the header's counts and flags.
    each_bit_flip(&bytes, &mut Pcg64::seed_from_u64(3), 20_000, 1..=4, Some(24), |_, _, b| {
        let _ = check(b);
    });
}

#[test]
fn writer_rejects_what_the_format_cannot_hold() {
    let long = |points: u32| Strands {
        points: (0..points).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect(),
        radii: vec![0.001; points as usize],
        offsets: vec![0, points],
    };
    let s = long(65_536);
    assert_eq!(bits(&parse_hair(&write_to_vec(&s, "").unwrap()).unwrap()), bits(&s));
    let mut out = Vec::new();
    let err = write_hair(&mut out, &long(65_537), "").unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
    assert!(err.to_string().contains("65537 points"), "{err}");
    assert!(out.is_empty());

    let mut bad = long(3);
    bad.radii[1] = 0.0;
    assert_eq!(write_hair(&mut out, &bad, "").unwrap_err().kind(), std::io::ErrorKind::InvalidInput);
    assert!(out.is_empty());
}

#[test]
fn writer_cuts_info_to_87_bytes_at_a_character_boundary() {
    let s = Strands { points: vec![Vec3::ZERO, Vec3::X], radii: vec![1.0; 2], offsets: vec![0, 2] };
    let info = "é".repeat(60); // 120 bytes of 2-byte characters
    let bytes = write_to_vec(&s, &info).unwrap();
    let field = &bytes[40..128];
    let end = field.iter().position(|&b| b == 0).unwrap();
    assert_eq!(end, 86);
    assert_eq!(std::str::from_utf8(&field[..end]).unwrap(), "é".repeat(43));
    assert!(field[end..].iter().all(|&b| b == 0));

    let bytes = write_to_vec(&s, &"a".repeat(100)).unwrap();
    assert_eq!(&bytes[40..127], "a".repeat(87).as_bytes());
    assert_eq!(bytes[127], 0);
}

// ---------------------------------------------------------------------------------------------
// The real groom fixture: the first 200 strands of wavy_short.hair (see tests/data/README.md).

#[test]
fn real_groom_fixture_matches_an_independent_reader() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/wavy_short_200.hair");
    let strands = read_hair(&path).unwrap();
    // 200 strands of 23 points (the groom's README).
    assert_eq!(strands.strand_count(), 200);
    assert_eq!(strands.points.len(), 200 * 23);
    assert_same_as_independent(&strands, &independent_read(&std::fs::read(&path).unwrap()));
    // Thickness 0.002 tapering to 0.001 at the tip: radii from 0.001 down to 0.0005.
    for s in 0..200 {
        let r = &strands.radii[strands.offsets[s] as usize..strands.offsets[s + 1] as usize];
        assert!((r[0] - 0.001).abs() < 1e-9 && (r[22] - 0.0005).abs() < 1e-9, "strand {s}: {r:?}");
        assert!(r.windows(2).all(|w| w[1] <= w[0]), "strand {s} thickens toward the tip: {r:?}");
    }
}

#[test]
fn bundled_groom_reads_through_gzip_as_an_independent_decoder_and_its_readme_say() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/groom/wavy_short.hair.gz");
    let strands = read_hair(&path).unwrap();
    // The groom's README (measured there with an independent reader).
    assert_eq!((strands.strand_count(), strands.points.len()), (30_033, 690_759));
    assert!((strands.total_length() - 27_937.0).abs() < 0.5, "{}", strands.total_length());
    // The system's gzip decodes the same bytes.
    let out = std::process::Command::new("gzip").arg("-dc").arg(&path).output().expect("gzip runs");
    assert!(out.status.success());
    assert_same_as_independent(&strands, &independent_read(&out.stdout));

    // A truncated stream and a file that is no gzip are errors naming the file.
    let dir = std::env::temp_dir().join(format!("strands-gzip-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let compressed = std::fs::read(&path).unwrap();
    for (name, bytes) in [("cut.hair.gz", &compressed[..compressed.len() / 2]), ("plain.hair.gz", &out.stdout[..])] {
        let bad = dir.join(name);
        std::fs::write(&bad, bytes).unwrap();
        let err = read_hair(&bad).unwrap_err().to_string();
        assert!(err.contains(name), "{err}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

// ---------------------------------------------------------------------------------------------
// Generators

/// A generator from a scene-file-like map of string values, as serde sees JSON.
fn from_map(entries: &[(&str, &str)]) -> Result<Generator, DeError> {
    Generator::deserialize(MapDeserializer::<_, DeError>::new(entries.iter().copied()))
}

#[test]
fn the_kind_alone_is_a_complete_description() {
    let kinds = ["straight", "wavy", "curly", "ball", "scalp"];
    for (kind, expected) in kinds.into_iter().zip(default_generators()) {
        assert_eq!(from_map(&[("kind", kind)]).unwrap(), expected);
    }
    let err = from_map(&[("kind", "curly"), ("curliness", "3")]).unwrap_err().to_string();
    assert!(err.contains("curliness"), "{err}");
    assert!(from_map(&[("kind", "spiky")]).is_err());
    assert!(from_map(&[]).is_err());
}

#[test]
fn generators_are_deterministic_and_valid() {
    for generator in default_generators() {
        let a = generator.generate().unwrap();
        assert_eq!(a.validate(), Ok(()), "{generator:?}");
        assert_eq!(bits(&a), bits(&generator.generate().unwrap()), "{generator:?}");
        let reseeded = match generator.clone() {
            Generator::Straight(g) => Generator::Straight(Straight { seed: 2, ..g }),
            Generator::Wavy(g) => Generator::Wavy(Wavy { seed: 2, ..g }),
            Generator::Curly(g) => Generator::Curly(Curly { seed: 2, ..g }),
            Generator::Ball(g) => Generator::Ball(Ball { seed: 2, ..g }),
            Generator::Scalp(g) => Generator::Scalp(Scalp { seed: 2, ..g }),
        };
        let b = reseeded.generate().unwrap();
        assert_eq!(a.offsets, b.offsets);
        assert_ne!(a.points, b.points, "{generator:?}");
    }
}

/// Each strand's points, in f64.
fn strands_f64(s: &Strands) -> Vec<Vec<glam::DVec3>> {
    (0..s.strand_count()).map(|i| s.strand(i).iter().map(|p| p.as_dvec3()).collect()).collect()
}

fn polyline_length(p: &[glam::DVec3]) -> f64 {
    p.windows(2).map(|w| w[0].distance(w[1])).sum()
}

#[test]
fn straight_strands_have_the_requested_length() {
    let g = Straight { strands: 500, points: 7, length: 0.8, ..Straight::default() };
    let s = Generator::Straight(g.clone()).generate().unwrap();
    let expected = 500.0 * 0.8;
    assert!((s.total_length() - expected).abs() <= 1e-4 * expected, "{} vs {expected}", s.total_length());
    assert!(s.radii.iter().all(|&r| r == 0.0025));
}

#[test]
fn wavy_strands_fall_the_requested_length_within_the_amplitude() {
    let g = Wavy { strands: 200, points: 201, amplitude: 0.05, wavelength: 0.25, ..Wavy::default() };
    for p in strands_f64(&Generator::Wavy(g.clone()).generate().unwrap()) {
        assert!((p[0].z - p[200].z - g.length).abs() < 1e-6, "fall {}", p[0].z - p[200].z);
        assert!(p.iter().all(|q| q.y == p[0].y));
        // 4 full waves sampled 50 times each: the sampled peaks lie within cos(pi/50) of the true ones.
        let (lo, hi) = p.iter().fold((f64::MAX, f64::MIN), |(lo, hi), q| (lo.min(q.x), hi.max(q.x)));
        let swing = hi - lo;
        let min_swing = 2.0 * g.amplitude * (std::f64::consts::PI / 50.0).cos();
        assert!(swing <= 2.0 * g.amplitude + 1e-6 && swing >= min_swing - 1e-6, "swing {swing}");
    }
}

#[test]
fn curly_strands_are_helices_of_the_requested_radius_and_length() {
    let (r, n, h) = (0.05, 4.0, 0.9);
    let g = Curly { strands: 100, points: 161, curl_radius: r, turns: n, length: h, ..Curly::default() };
    // Arc length of a helix of radius r, n turns and height h: sqrt((2 pi r n)^2 + h^2).
    let arc = ((TAU * r * n).powi(2) + h * h).sqrt();
    for p in strands_f64(&Generator::Curly(g).generate().unwrap()) {
        // 160 points cover 4 whole turns evenly, so their mean in xy is the axis.
        let axis = p[..160].iter().map(|q| q.truncate()).sum::<glam::DVec2>() / 160.0;
        for q in &p {
            assert!(
                (q.truncate().distance(axis) - r).abs() < 1e-6,
                "distance from axis {}",
                q.truncate().distance(axis)
            );
        }
        let length = polyline_length(&p);
        assert!((length - arc).abs() < 0.01 * arc, "length {length} vs helix {arc}");
    }
}

#[test]
fn ball_strands_are_arcs_within_the_ball() {
    let g = Ball { strands: 300, points: 21, ball_radius: 0.5, length: 0.4, curvature: 5.0, ..Ball::default() };
    // A circular arc of curvature k cut into m equal pieces of arc ds has chords 2 sin(k ds / 2) / k.
    let ds = g.length / 20.0;
    let chords = 20.0 * 2.0 * (g.curvature * ds / 2.0).sin() / g.curvature;
    for p in strands_f64(&Generator::Ball(g.clone()).generate().unwrap()) {
        assert!(p[0].length() <= g.ball_radius + 1e-6, "root at {}", p[0].length());
        assert!(p.iter().all(|q| q.length() <= g.ball_radius + g.length + 1e-6));
        // f32 points (rounded by at most 6e-8 per coordinate) move the 20 chords by < 4e-6 in all.
        let length = polyline_length(&p);
        assert!((length - chords).abs() < 4e-6, "length {length} vs {chords}");
    }
}

#[test]
fn scalp_roots_lie_on_the_cap_and_hair_stays_outside_the_head() {
    let g = Scalp::default();
    let cos_cap = g.cap_angle.cos();
    for p in strands_f64(&Generator::Scalp(g.clone()).generate().unwrap()) {
        let root = p[0];
        assert!((root.length() - g.scalp_radius).abs() < 1e-6, "root at distance {}", root.length());
        assert!(root.z / root.length() >= cos_cap - 1e-6, "root below the cap: z = {}", root.z);
        assert!(p.iter().all(|q| q.length() >= g.scalp_radius - 1e-6), "a strand enters the head");
        // The tip hangs straight below the equator unless the strand is too short to get there.
        assert!(p[p.len() - 1].z < 0.0);
    }
}

#[test]
fn bad_generator_parameters_name_the_field() {
    let field = |g: Generator| match g.generate() {
        Err(GenerateError::Param { field, .. }) => field,
        other => panic!("expected a parameter error, got {other:?}"),
    };
    assert_eq!(field(Generator::Straight(Straight { strands: 0, ..Straight::default() })), "strands");
    assert_eq!(field(Generator::Straight(Straight { points: 1, ..Straight::default() })), "points");
    assert_eq!(field(Generator::Straight(Straight { strands: 1_000_000, ..Straight::default() })), "strands");
    assert_eq!(field(Generator::Wavy(Wavy { length: f64::NAN, ..Wavy::default() })), "length");
    assert_eq!(field(Generator::Wavy(Wavy { wavelength: 0.0, ..Wavy::default() })), "wavelength");
    assert_eq!(field(Generator::Curly(Curly { curl_radius: -1.0, ..Curly::default() })), "curl_radius");
    assert_eq!(field(Generator::Curly(Curly { depth: -0.1, ..Curly::default() })), "depth");
    assert_eq!(field(Generator::Ball(Ball { radius: f64::INFINITY, ..Ball::default() })), "radius");
    assert_eq!(field(Generator::Scalp(Scalp { cap_angle: 2.0, ..Scalp::default() })), "cap_angle");
    let message = Generator::Curly(Curly { turns: -2.0, ..Curly::default() }).generate().unwrap_err().to_string();
    assert!(message.contains("`turns`") && message.contains("-2"), "{message}");
    // Valid numbers whose points coincide in f32: steps of 1e-12 / 15 on coordinates near 0.5.
    let tiny = Generator::Ball(Ball { length: 1e-12, ..Ball::default() }).generate();
    assert!(matches!(tiny, Err(GenerateError::Geometry(StrandError::ZeroLengthSegment { .. }))), "{tiny:?}");
}
