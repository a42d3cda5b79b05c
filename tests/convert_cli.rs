//! `dualhair convert` end to end: pbrt-v4 curves to .hair and .hair.gz with a transform, back to
//! the same strands; a pbrt file rendered as a scene; bad arguments named, nothing written.

use crate::common::{assert_each_fails_naming, dualhair};
use glam::Vec3;
use precompute::strands::{read_hair, read_pbrt_curves};

#[test]
fn pbrt_curves_convert_to_hair_and_gzipped_hair_with_a_transform() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let pbrt = d.join("two.pbrt");
    std::fs::write(
        &pbrt,
        "WorldBegin\nShape \"curve\" \"point3 P\" [0 0 0 0 0 1 0 0 2 0 0 3] \"float width\" 0.02\n\
         Shape \"curve\" \"point3 P\" [1 0 0 1 0 1 1 0 2 1 0 3 1 0 4 1 0 5 1 0 6] \"float width0\" 0.02 \"float width1\" 0.01\n",
    )
    .unwrap();
    let original = read_pbrt_curves(&pbrt).unwrap();
    for out in ["two.hair", "two.hair.gz"] {
        let path = d.join(out);
        let run = dualhair(&[
            "convert",
            &pbrt.to_string_lossy(),
            &path.to_string_lossy(),
            "--scale",
            "2",
            "--translate",
            "0",
            "-1",
            "0.5",
        ]);
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        assert!(String::from_utf8_lossy(&run.stdout).contains("2 strands, 5 points"));
        let converted = read_hair(&path).unwrap();
        assert_eq!(converted.offsets, original.offsets);
        for (a, b) in converted.points.iter().zip(&original.points) {
            assert_eq!(*a, *b * 2.0 + Vec3::new(0.0, -1.0, 0.5));
        }
        // Thickness is stored as a diameter: radii come back scaled, to f32's last bit.
        for (a, b) in converted.radii.iter().zip(&original.radii) {
            assert!((a / (2.0 * b) - 1.0).abs() < 1e-6, "{a} vs {b}");
        }
    }
    // .hair.gz in, plain .hair out, no transform: the same strands bit for bit.
    let back = d.join("back.hair");
    let run = dualhair(&["convert", &d.join("two.hair.gz").to_string_lossy(), &back.to_string_lossy()]);
    assert!(run.status.success());
    assert_eq!(read_hair(&back).unwrap(), read_hair(&d.join("two.hair.gz")).unwrap());

    // A pbrt file renders as a scene of its own.
    let image = d.join("two.png");
    let run = dualhair(&[
        "render",
        &pbrt.to_string_lossy(),
        "--spp",
        "1",
        "--width",
        "16",
        "--height",
        "16",
        "--integrator",
        "single",
        "-q",
        "-o",
        &image.to_string_lossy(),
    ]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(image.exists());
}

#[test]
fn convert_names_what_is_wrong_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.hair").to_string_lossy().into_owned();
    let empty = tempfile::tempdir().unwrap();
    let bad_pbrt = empty.path().join("bad.pbrt");
    std::fs::write(&bad_pbrt, "Shape \"curve\" \"point3 P\" [0 0 0 1 0 0]\n").unwrap();
    let bad = bad_pbrt.to_string_lossy().into_owned();
    let good_pbrt = empty.path().join("good.pbrt");
    std::fs::write(&good_pbrt, "Shape \"curve\" \"point3 P\" [0 0 0 1 0 0 2 0 0 3 0 0]\n").unwrap();
    let good = good_pbrt.to_string_lossy().into_owned();
    assert_each_fails_naming(
        &[
            (vec!["convert", "/nonexistent/x.hair", &out], "/nonexistent/x.hair"),
            (vec!["convert", "scene.json", &out], "not a hair file"),
            (vec!["convert", &bad, &out], "bad.pbrt:1: 2 control points"),
            (vec!["convert", &bad, "/tmp/x.obj"], "convert writes .hair or .hair.gz"),
            (vec!["convert", &good, &out, "--scale", "0"], "hair.scale must be finite and > 0"),
            (vec!["convert", &good, &out, "--radius=-1"], "hair.radius must be finite and > 0"),
        ],
        dir.path(),
    );
}
