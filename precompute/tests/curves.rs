//! Curve formats. pbrt-v4: hand-written files with known segment counts, lengths and widths,
//! the polyline's distance to the exact curve, transforms, includes (gzipped too), the layout of
//! a real pbrt-v4 hair scene, and bad input named by file and line. USD: hand-written stages with
//! known points, transforms and widths, each cubic basis against its own formula, and bad input
//! named by file and prim.

use glam::DVec3;
use precompute::strands::{PbrtError, Strands, read_pbrt_curves, read_strands};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A folder of its own under the system's temporary folder, removed when dropped.
struct Dir(PathBuf);

impl Dir {
    fn new(name: &str) -> Dir {
        let dir = std::env::temp_dir().join(format!("pbrt-curves-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Dir(dir)
    }

    fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.0.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        if name.ends_with(".gz") {
            let mut gz =
                flate2::write::GzEncoder::new(std::fs::File::create(&path).unwrap(), flate2::Compression::fast());
            gz.write_all(text.as_bytes()).unwrap();
            gz.finish().unwrap();
        } else {
            std::fs::write(&path, text).unwrap();
        }
        path
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn strand(s: &Strands, k: usize) -> (Vec<DVec3>, Vec<f64>) {
    let range = s.offsets[k] as usize..s.offsets[k + 1] as usize;
    (s.points[range.clone()].iter().map(|p| p.as_dvec3()).collect(), s.radii[range].iter().map(|&r| r as f64).collect())
}

fn length(p: &[DVec3]) -> f64 {
    p.windows(2).map(|w| w[0].distance(w[1])).sum()
}

/// The cubic Bezier through `p` at `u`, in Bernstein form (independent of the reader's de Casteljau).
fn bernstein(p: &[DVec3; 4], u: f64) -> DVec3 {
    let v = 1.0 - u;
    p[0] * (v * v * v) + p[1] * (3.0 * v * v * u) + p[2] * (3.0 * v * u * u) + p[3] * (u * u * u)
}

/// Distance from `q` to the polyline `p`.
fn to_polyline(q: DVec3, p: &[DVec3]) -> f64 {
    p.windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            let t = ((q - w[0]).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            q.distance(w[0] + t * d)
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn straight_curves_keep_their_segments_lengths_and_widths() {
    let dir = Dir::new("straight");
    let path = dir.write(
        "straight.pbrt",
        r#"# Three curves: one cubic segment, two cubic segments, a quadratic B-spline of three segments.
WorldBegin
Shape "curve" "point3 P" [0 0 0  1 0 0  2 0 0  3 0 0] "float width" 0.2 "string type" "cylinder"
Shape "curve" "point3 P" [ 0 1 0  0.5 1 0  1 1 0  1.5 1 0
                          2 1 0  2.5 1 0  3 1 0 ]
      "float width0" [ 0.4 ] "float width1" [ 0.1 ]
Shape "curve" "string basis" "bspline" "integer degree" 2
      "point3 P" [0 2 0  2 2 0  4 2 0  6 2 0  8 2 0]
"#,
    );
    let s = read_pbrt_curves(&path).unwrap();
    assert_eq!(s.strand_count(), 3);
    s.validate().unwrap();
    // Straight lines need one piece a segment: 1 + 1, 1 + 2 and 1 + 3 points.
    let (a, ra) = strand(&s, 0);
    let (b, rb) = strand(&s, 1);
    let (c, _) = strand(&s, 2);
    assert_eq!((a.len(), b.len(), c.len()), (2, 3, 4));
    assert!((length(&a) - 3.0).abs() < 1e-6 && (length(&b) - 3.0).abs() < 1e-6);
    // The quadratic B-spline's curve runs from the midpoint of its first two points to that of
    // its last two: x from 1 to 7.
    assert!((c[0] - DVec3::new(1.0, 2.0, 0.0)).length() < 1e-6 && (c[3] - DVec3::new(7.0, 2.0, 0.0)).length() < 1e-6);
    // Radii: half the width; width0 to width1 over the two segments.
    assert!(ra.iter().all(|r| (r - 0.1).abs() < 1e-7));
    for (r, w) in rb.iter().zip([0.4, 0.25, 0.1]) {
        assert!((r - 0.5 * w).abs() < 1e-7, "{rb:?}");
    }
    // The default width is 1.
    assert!(strand(&s, 2).1.iter().all(|r| (r - 0.5).abs() < 1e-7));
}

#[test]
fn bent_curves_are_cut_close_to_the_exact_curve() {
    let dir = Dir::new("bent");
    // A quarter circle's usual cubic: control points (1,0), (1,k), (k,1), (0,1), k = 0.5523.
    let k = 0.552_284_75;
    let cp = [DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, k, 0.0), DVec3::new(k, 1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
    let p: Vec<String> = cp.iter().map(|c| format!("{} {} {}", c.x, c.y, c.z)).collect();
    for width in [0.01, 0.001] {
        let path =
            dir.write("arc.pbrt", &format!("Shape \"curve\" \"point3 P\" [{}] \"float width\" {width}", p.join(" ")));
        let s = read_pbrt_curves(&path).unwrap();
        let (points, _) = strand(&s, 0);
        // Every point of the exact curve lies within a tenth of the radius of the polyline.
        let worst = (0..=2000).map(|i| to_polyline(bernstein(&cp, i as f64 / 2000.0), &points)).fold(0.0, f64::max);
        println!("width {width}: {} points, farthest {worst:.2e} from the curve", points.len());
        // As many pieces as the bound asks (|B''| <= 6 max |second difference|), at most 64; then
        // the bound for the pieces it has.
        let second = (cp[0] - 2.0 * cp[1] + cp[2]).length().max((cp[1] - 2.0 * cp[2] + cp[3]).length());
        let needed = (6.0 * second / (8.0 * 0.1 * 0.5 * width)).sqrt().ceil() as usize;
        let pieces = needed.min(64);
        assert_eq!(points.len(), pieces + 1);
        let bound = 6.0 * second / (8.0 * (pieces * pieces) as f64);
        assert!(worst <= bound * 1.0001, "{worst} vs {bound}");
        if needed <= 64 {
            assert!(worst <= 0.1 * 0.5 * width, "{worst}");
        }
        // Its length against the curve's by fine quadrature (the arc is within 0.03% of pi / 2).
        let exact = length(&(0..=20000).map(|i| bernstein(&cp, i as f64 / 20000.0)).collect::<Vec<_>>());
        assert!((length(&points) / exact - 1.0).abs() < 1e-3, "{} vs {exact}", length(&points));
        assert!((exact / std::f64::consts::FRAC_PI_2 - 1.0).abs() < 3e-4);
    }
}

#[test]
fn transforms_and_gzipped_includes_apply() {
    let dir = Dir::new("include");
    // The layout of a pbrt-v4 hair scene (mmp/pbrt-v4-scenes, hair/hair-eumel-2.pbrt): options and
    // a camera, a world with a light in its own attribute block, a hair material, the curves
    // in a gzipped file included from a folder, and a sphere placed in camera space.
    dir.write(
        "geometry/hair.pbrt.gz",
        "AttributeBegin\n  Translate 1 2 3\n  Scale 2 2 2\n  Shape \"curve\" \"point3 P\" [0 0 0 0 0 1 0 0 2 0 0 3] \"float width\" 0.1\nAttributeEnd\n\
         Shape \"curve\" \"point3 P\" [0 0 0 0 0 1 0 0 2 0 0 3] \"float width\" 0.1\n",
    );
    let path = dir.write(
        "scene.pbrt",
        r#"Integrator "volpath" "integer maxdepth" [ 32 ]
Transform [ 1 0 0 0  0 1 0 0  0 0 1 0  5 5 5 1 ]
Sampler "halton" "integer pixelsamples" [ 16 ]
Film "rgb" "string filename" [ "hair.exr" ] "integer xresolution" [ 64 ] "integer yresolution" [ 64 ]
Camera "perspective" "float fov" [ 32 ]
WorldBegin
AttributeBegin
    Rotate -120 1 0 0
    LightSource "infinite" "rgb L" [ 1 1 1 ]
AttributeEnd
Material "hair" "float beta_m" 0.25 "float eumelanin" 2 "bool placeholder" true
Include "geometry/hair.pbrt.gz"
AttributeBegin
    CoordSysTransform "camera"
    Translate 0 2 25
    Shape "sphere" "float radius" 3
AttributeEnd
"#,
    );
    let s = read_strands(&path).unwrap();
    assert_eq!(s.strand_count(), 2);
    let (moved, radii) = strand(&s, 0);
    // Scaled by 2 then moved by (1, 2, 3); widths scale too. WorldBegin dropped the camera's
    // Transform.
    assert_eq!((moved[0], moved[1]), (DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.0, 2.0, 9.0)));
    assert!(radii.iter().all(|r| (r - 0.1).abs() < 1e-7));
    let (plain, radii) = strand(&s, 1);
    assert_eq!((plain[0], plain[1]), (DVec3::ZERO, DVec3::new(0.0, 0.0, 3.0)));
    assert!(radii.iter().all(|r| (r - 0.05).abs() < 1e-7));
}

#[test]
fn bad_files_name_their_file_and_line() {
    let dir = Dir::new("bad");
    let curve = r#"Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0]"#;
    for (text, line, expect) in [
        (r#"Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0 4 0 0]"#, 1, "5 control points"),
        ("WorldBegin\n\nShape \"curve\" \"point3 P\" [0 0 0 1 0 0\n 2 0 0 3 0", 3, "not closed"),
        (r#"Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0] "string basis" "catmull""#, 1, "unknown basis"),
        (r#"Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0] "integer degree" 4"#, 1, "must be 2 or 3"),
        (r#"Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 0] "float width" -1"#, 1, "widths must be > 0"),
        (r#"Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0 3 0 nan]"#, 1, "not a finite number"),
        (r#"Shape "curve" "point3 P" [0 0 0 1 0 0 2 0 0 3 0]"#, 1, "not a multiple of 3"),
        (r#"Shape "curve" "float width" 1"#, 1, "needs \"point3 P\""),
        (r#"Shape "curve" "point3 P" [0 0 0 0 0 0 0 0 0 0 0 0]"#, 1, "coincide"),
        (
            "# header\nObjectBegin \"tuft\"\nShape \"curve\" \"point3 P\" [0 0 0 1 0 0 2 0 0 3 0 0]\nObjectEnd",
            3,
            "instanced",
        ),
        ("AttributeEnd", 1, "without a matching begin"),
        ("Translate 1 2", 1, "takes 3 numbers"),
        ("\"curve\"", 1, "expected a directive"),
        ("Shape \"curve\" \"point3 P\" [0 0 0 1 0 0 2 0 0 3 0 0] \"float width [1]", 1, "not closed"),
        ("\n\nInclude \"missing.pbrt\"", 3, "missing.pbrt: No such file"),
        ("Camera \"perspective\"", 0, "holds no `Shape \"curve\"`"),
    ] {
        let path = dir.write("bad.pbrt", text);
        let err = read_pbrt_curves(&path).unwrap_err();
        let message = err.to_string();
        let place = if line > 0 { format!("bad.pbrt:{line}: ") } else { "bad.pbrt".into() };
        assert!(message.contains(&place) && message.contains(expect), "{text:?}: {message}");
        assert!(message.contains(&path.parent().unwrap().display().to_string()) || matches!(err, PbrtError::Io { .. }));
    }
    // An error inside an included file names that file and its line.
    dir.write("inner.pbrt", &format!("{curve}\nShape \"curve\" \"point3 P\" [0 0 0]"));
    let outer = dir.write("outer.pbrt", "WorldBegin\nInclude \"inner.pbrt\"\n");
    let message = read_pbrt_curves(&outer).unwrap_err().to_string();
    assert!(message.contains("inner.pbrt:2: 1 control points"), "{message}");
    // A file that includes itself, even twice over (2^31 reads before the nesting limit), is a
    // cycle; a chain of distinct files stops at the nesting limit.
    let selfish = dir.write("self.pbrt", "Include \"self.pbrt\"\nInclude \"self.pbrt\"\n");
    let message = read_pbrt_curves(&selfish).unwrap_err().to_string();
    assert!(message.contains("self.pbrt:1: ") && message.contains("self.pbrt includes itself"), "{message}");
    for k in 0..40 {
        dir.write(&format!("chain{k}.pbrt"), &format!("Include \"chain{}.pbrt\"\n", k + 1));
    }
    let message = read_pbrt_curves(&dir.0.join("chain0.pbrt")).unwrap_err().to_string();
    assert!(message.contains("nest more than 32"), "{message}");
    assert!(read_strands(Path::new("x.obj")).unwrap_err().to_string().contains("not a hair file"));
}

// USD (BasisCurves): hand-written stages with known counts, transforms and widths.

const USD_LINEAR: &str = r#"#usda 1.0
(
    upAxis = "Z"
)

def Xform "Groom"
{
    double3 xformOp:translate = (10, 20, 30)
    float xformOp:rotateZ = 90
    float3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateZ", "xformOp:scale"]

    def BasisCurves "Strands"
    {
        uniform token type = "linear"
        int[] curveVertexCounts = [3, 2]
        point3f[] points = [(1, 0, 0), (1, 0, 1), (1, 0, 2), (0, 1, 0), (0, 1, 4)]
        float[] widths = [0.1, 0.2, 0.3, 0.4, 0.5] (
            interpolation = "vertex"
        )
        double3 xformOp:translate = (0, 0, 5)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}

def Scope "Other"
{
    def BasisCurves "Bezier"
    {
        uniform token type = "cubic"
        uniform token basis = "bezier"
        int[] curveVertexCounts = [7]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0), (3, 1, 0), (3, 2, 0), (3, 3, 0)]
        float[] widths = [0.2] (
            interpolation = "constant"
        )
    }
}
"#;

#[test]
fn usd_linear_and_bezier_curves_come_out_in_world_space() {
    let dir = Dir::new("usd");
    let s = read_strands(&dir.write("groom.usda", USD_LINEAR)).unwrap();
    assert_eq!(s.offsets, [0, 3, 5, 8]);
    // The prim's translate, then its parent's scale, rotation by 90 degrees about z and
    // translate, worked by hand; widths halved and scaled by 2.
    let want = [[10.0, 22.0, 40.0], [10.0, 22.0, 42.0], [10.0, 22.0, 44.0], [8.0, 20.0, 40.0], [8.0, 20.0, 48.0]];
    for (k, (p, q)) in s.points.iter().zip(want).enumerate() {
        assert!(p.as_dvec3().distance(DVec3::from_array(q)) < 1e-5, "point {k}: {p} vs {q:?}");
    }
    for (r, w) in s.radii.iter().zip([0.1, 0.2, 0.3, 0.4, 0.5]) {
        assert!((*r as f64 - w).abs() < 1e-6, "{r} vs {w}");
    }
    // Two straight cubic Bezier segments: one piece each, through their end points.
    let (bezier, radii) = strand(&s, 2);
    assert_eq!(bezier, [DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), DVec3::new(3.0, 3.0, 0.0)]);
    assert!(radii.iter().all(|&r| (r - 0.1).abs() < 1e-7), "{radii:?}");
}

#[test]
fn usd_catmull_rom_and_bspline_curves_follow_their_basis() {
    let dir = Dir::new("usd-cubic");
    // A quarter circle's worth of points; pinned curves reach both end points, Catmull-Rom
    // passes through every point, and every piece stays within a tenth of the radius of the
    // exact curve (checked on the uniform B-spline's and Catmull-Rom's own formulas).
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 1.0, 0.0], [2.0, 2.0, 1.0], [1.0, 3.0, 1.0]];
    let points = p.iter().map(|q| format!("({}, {}, {})", q[0], q[1], q[2])).collect::<Vec<_>>().join(", ");
    let p: Vec<DVec3> = p.iter().map(|q| DVec3::from_array(*q)).collect();
    for (basis, wrap, segments) in
        [("catmullRom", "pinned", 4), ("catmullRom", "nonperiodic", 2), ("bspline", "pinned", 4)]
    {
        let text = format!(
            "#usda 1.0\ndef BasisCurves \"C\"\n{{\n    uniform token type = \"cubic\"\n    uniform token basis = \"{basis}\"\n    \
             uniform token wrap = \"{wrap}\"\n    int[] curveVertexCounts = [5]\n    point3f[] points = [{points}]\n    \
             float[] widths = [0.02]\n    (interpolation = \"constant\")\n}}\n"
        );
        let s = read_strands(&dir.write(&format!("{basis}-{wrap}.usda"), &text)).unwrap();
        let (line, _) = strand(&s, 0);
        // Phantom end points where pinned: 2 P0 - P1 and 2 P4 - P3.
        let at = |i: isize| match i {
            -1 => 2.0 * p[0] - p[1],
            5 => 2.0 * p[4] - p[3],
            i => p[i as usize],
        };
        let first = if wrap == "pinned" { -1 } else { 0 };
        for k in 0..segments {
            let q = [at(first + k), at(first + k + 1), at(first + k + 2), at(first + k + 3)];
            for i in 0..=100 {
                let u = i as f64 / 100.0;
                let exact = if basis == "bspline" { bspline(&q, u) } else { catmull_rom(&q, u) };
                let d = to_polyline(exact, &line);
                assert!(d <= 0.1 * 0.01 + 1e-9, "{basis} {wrap} segment {k} u {u}: {d}");
            }
        }
        let ends = if wrap == "pinned" { (p[0], p[4]) } else { (p[1], p[3]) };
        assert!(line[0].distance(ends.0) < 1e-6 && line.last().unwrap().distance(ends.1) < 1e-6, "{basis} {wrap}");
        if basis == "catmullRom" {
            let inner = if wrap == "pinned" { &p[..] } else { &p[1..4] };
            for q in inner {
                assert!(line.iter().any(|x| x.distance(*q) < 1e-6), "{basis} {wrap} misses {q}");
            }
        }
    }
}

/// A uniform cubic B-spline segment at u (its basis functions).
fn bspline(q: &[DVec3; 4], u: f64) -> DVec3 {
    let v = 1.0 - u;
    (v * v * v * q[0]
        + (3.0 * u * u * u - 6.0 * u * u + 4.0) * q[1]
        + (-3.0 * u * u * u + 3.0 * u * u + 3.0 * u + 1.0) * q[2]
        + u * u * u * q[3])
        / 6.0
}

/// A uniform Catmull-Rom segment from q1 to q2 at u (its polynomial form).
fn catmull_rom(q: &[DVec3; 4], u: f64) -> DVec3 {
    0.5 * (2.0 * q[1]
        + (q[2] - q[0]) * u
        + (2.0 * q[0] - 5.0 * q[1] + 4.0 * q[2] - q[3]) * u * u
        + (3.0 * q[1] - q[0] - 3.0 * q[2] + q[3]) * u * u * u)
}

#[test]
fn bad_usd_files_name_their_file_and_prim() {
    let dir = Dir::new("usd-bad");
    let prim = |body: &str| {
        format!("#usda 1.0\ndef Xform \"G\"\n{{\n    def BasisCurves \"Bad\"\n    {{\n{body}\n    }}\n}}\n")
    };
    let linear = "uniform token type = \"linear\"\n";
    for (name, text, expect) in [
        (
            "counts.usda",
            prim(&format!("{linear}int[] curveVertexCounts = [3]\npoint3f[] points = [(0, 0, 0), (0, 0, 1)]")),
            "/G/Bad: curveVertexCounts add up to 3, but there are 2 points",
        ),
        (
            "periodic.usda",
            prim(
                "uniform token wrap = \"periodic\"\nint[] curveVertexCounts = [4]\npoint3f[] points = [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)]",
            ),
            "periodic",
        ),
        (
            "bezier.usda",
            prim(
                "int[] curveVertexCounts = [5]\npoint3f[] points = [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0), (1, 1, 0)]",
            ),
            "curve 0: 5 vertices: a cubic Bezier curve takes 4 + 3 k",
        ),
        (
            "widths.usda",
            prim(&format!(
                "{linear}int[] curveVertexCounts = [2]\npoint3f[] points = [(0, 0, 0), (0, 0, 1)]\nfloat[] widths = [1, 2, 3]"
            )),
            "3 widths, where vertex interpolation takes 2",
        ),
        (
            "zero.usda",
            prim(&format!(
                "{linear}int[] curveVertexCounts = [2]\npoint3f[] points = [(0, 0, 0), (0, 0, 1)]\nfloat[] widths = [0, 0]"
            )),
            "radius is 0",
        ),
        (
            "same.usda",
            prim(&format!("{linear}int[] curveVertexCounts = [2]\npoint3f[] points = [(0, 0, 0), (0, 0, 0)]")),
            "all coincide",
        ),
        ("none.usda", "#usda 1.0\ndef Xform \"G\"\n{\n}\n".into(), "holds no BasisCurves prim"),
        (
            "arc.usda",
            "#usda 1.0\ndef Xform \"G\" (\n    references = </G}x>\n)\n{\n}\n".into(),
            "/G's references \"/G}x\" is not a prim path",
        ),
        (
            "empty.usda",
            "#usda 1.0\ndef Xform \"\"\n{\n    float x = 1\n}\n".into(),
            "/'s child \"\" is not a prim path",
        ),
        ("brace.usda", "#usda 1.0\ndef Xform \"G}\"\n{\n}\n".into(), "/'s child \"G}\" is not a prim path"),
        (
            "op.usda",
            prim(&format!(
                "{linear}int[] curveVertexCounts = [2]\npoint3f[] points = [(0, 0, 0), (0, 0, 1)]\nuniform token[] xformOpOrder = [\"xformOp:scale}}\"]"
            )),
            "xformOpOrder holds \"xformOp:scale}\"",
        ),
        ("broken.usda", "#usda 1.0\ndef Xform \"G\"\n{\n".into(), "cannot read"),
    ] {
        let path = dir.write(name, &text);
        let message = read_strands(&path).unwrap_err().to_string();
        assert!(message.contains(&path.display().to_string()) && message.contains(expect), "{name}: {message}");
    }
    let message = read_strands(&dir.0.join("missing.usdc")).unwrap_err().to_string();
    assert!(message.contains("missing.usdc"), "{message}");
}
