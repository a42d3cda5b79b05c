//! End-to-end checks of `dualhair fibersim`: the written EXR integrates to the albedo it prints,
//! the PNG is a picture, and bad input fails with a message and no file.

use crate::common::{assert_each_fails_naming, assert_picture, dualhair};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::Path;

/// sum(pixel cos(theta) dtheta dphi) per channel of a lat-long EXR, with its size.
fn exr_albedo(path: &Path) -> ((usize, usize), [f64; 3]) {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![[0f32; 3]; res.width() * res.height()]),
        |(w, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| px[pos.y() * *w + pos.x()] = [r, g, b],
    )
    .unwrap();
    let (w, px) = image.layer_data.channel_data.pixels;
    let h = px.len() / w;
    let mut albedo = [0.0f64; 3];
    for y in 0..h {
        let theta = FRAC_PI_2 - (y as f64 + 0.5) * PI / h as f64;
        let cell = theta.cos() * (PI / h as f64) * (TAU / w as f64);
        for x in 0..w {
            for c in 0..3 {
                albedo[c] += px[y * w + x][c] as f64 * cell;
            }
        }
    }
    ((w, h), albedo)
}

/// The three channel values printed on the line starting with `label`.
fn printed(stdout: &str, label: &str) -> [f64; 3] {
    let line = stdout.lines().find(|l| l.trim_start().starts_with(label)).unwrap_or_else(|| panic!("{stdout}"));
    let v: Vec<f64> = line.trim_start()[label.len()..].split_whitespace().take(3).map(|v| v.parse().unwrap()).collect();
    [v[0], v[1], v[2]]
}

#[test]
fn exr_integrates_to_the_printed_albedo() {
    let dir = tempfile::tempdir().unwrap();
    for (lobe, label) in [("all", "total albedo"), ("tt", "TT")] {
        let path = dir.path().join(format!("{lobe}.exr"));
        let out = dualhair(&[
            "fibersim",
            "--theta=-0.3",
            "--sigma-a",
            "0.1,0.5,2",
            "--beta-m",
            "0.1",
            "--rays",
            "50000",
            "--width",
            "96",
            "--height",
            "48",
            "--lobe",
            lobe,
            "-o",
            path.to_str().unwrap(),
        ]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let (size, albedo) = exr_albedo(&path);
        assert_eq!(size, (96, 48));
        let want = printed(&stdout, label);
        for c in 0..3 {
            // The EXR holds f32 and the printout 6 decimals.
            assert!((albedo[c] - want[c]).abs() < 1e-5 + 1e-5 * want[c], "{lobe}: EXR {albedo:?} vs printed {want:?}");
        }
        // Absorption is stronger in blue: the colors must differ.
        assert!(albedo[0] > albedo[1] && albedo[1] > albedo[2], "{albedo:?}");
    }
}

#[test]
fn png_is_a_picture() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.png");
    let out = dualhair(&["fibersim", "--rays", "20000", "--beta-m", "0.2", "-o", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_picture(&path);
}

#[test]
fn bad_input_is_an_error_naming_the_problem_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sim.exr");
    let p = path.to_str().unwrap();
    let cases = [
        (vec!["fibersim", "--theta", "3", "-o", p], "--theta"),
        (vec!["fibersim", "--rays", "0", "-o", p], "--rays"),
        (vec!["fibersim", "--rays", "2000000000", "-o", p], "--rays"),
        (vec!["fibersim", "--eta", "0.5", "-o", p], "eta"),
        (vec!["fibersim", "--beta-m", "0", "-o", p], "beta_m"),
        (vec!["fibersim", "--width", "0", "-o", p], "--width"),
        (vec!["fibersim", "--height", "100000", "-o", p], "--height"),
        (vec!["fibersim", "--lobe", "trrt", "-o", p], "trrt"),
        (vec!["fibersim", "-o", "sim.tiff"], "unsupported output"),
    ];
    assert_each_fails_naming(&cases, dir.path());
}
