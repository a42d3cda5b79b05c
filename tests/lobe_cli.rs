//! End-to-end checks of `dualhair lobe`: the written EXR integrates to the albedo, the PNG is a
//! picture, and bad input fails with a message and no file.

use crate::common::{assert_each_fails_naming, assert_picture, dualhair};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

#[test]
fn exr_lobe_integrates_to_one_without_absorption() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lobe.exr");
    let out = dualhair(&[
        "lobe",
        "--theta=-1.0",
        "--sigma-a",
        "0,0,0",
        "--alpha",
        "-2",
        "--width",
        "128",
        "--height",
        "64",
        "-o",
        path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let image = exr::prelude::read_first_rgba_layer_from_file(
        &path,
        |res, _| (res.width(), vec![[0f32; 3]; res.width() * res.height()]),
        |(w, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| px[pos.y() * *w + pos.x()] = [r, g, b],
    )
    .unwrap();
    let (w, px) = image.layer_data.channel_data.pixels;
    let h = px.len() / w;
    assert_eq!((w, h), (128, 64));
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
    for a in albedo {
        assert!((a - 1.0).abs() < 0.005, "albedo {albedo:?}");
    }
}

#[test]
fn png_lobe_is_a_picture() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lobe.png");
    let out =
        dualhair(&["lobe", "--eumelanin", "1.3", "--width", "64", "--height", "32", "-o", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_picture(&path);
}

#[test]
fn bad_input_is_an_error_naming_the_problem_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lobe.exr");
    let p = path.to_str().unwrap();
    let cases = [
        (vec!["lobe", "--beta-m", "0", "-o", p], "beta_m"),
        (vec!["lobe", "--beta-n", "nan", "-o", p], "beta_n"),
        (vec!["lobe", "--theta", "2", "-o", p], "--theta"),
        (vec!["lobe", "--sigma-a", "-1", "-o", p], "sigma_a"),
        (vec!["lobe", "--color", "0,0.5,0.5", "-o", p], "color"),
        (vec!["lobe", "--sigma-a", "1,2", "-o", p], "R,G,B"),
        (vec!["lobe", "--eta", "0.5", "-o", p], "eta"),
        (vec!["lobe", "--width", "0", "-o", p], "--width"),
        (vec!["lobe", "-o", "lobe.tiff"], "unsupported output"),
    ];
    assert_each_fails_naming(&cases, dir.path());
}
