//! `dualhair converge` end to end on a tiny scene: the files, the per-doubling measure against an
//! independent computation from the written images, resumability, bad arguments.

use dualhair::film::Film;
use std::path::Path;
use std::process::{Command, Output};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn converge(out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dualhair"))
        .env("DUALHAIR_CACHE", format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")))
        .args(["converge", &format!("{ROOT}/scenes/brown.json"), "--width", "16", "--height", "16", "-q"])
        .args(["--methods", "dual-importance,path-uniform", "--spp", "1,2,4", "--seeds", "2", "--truth-spp", "16"])
        .args(extra)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

#[test]
fn writes_results_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let out = converge(dir.path(), &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stdout).contains("13 renders (0 reused)"));
    for f in ["results.csv", "results.json", "summary.md", "error_vs_spp.png", "error_vs_spp.svg", "error_vs_time.png"]
    {
        assert!(dir.path().join(f).exists(), "{f} missing");
    }
    let csv = std::fs::read_to_string(dir.path().join("results.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("method,spp,seed,seconds,mse,rel_variance"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * 3 * 2);

    // The per-doubling measure of dual-importance at 4 spp, seed 0, recomputed here from the
    // images: mean over fully covered truth pixels and channels of the squared difference.
    let truth = Film::read_exr(&dir.path().join("truth-path-importance-16spp.exr")).unwrap();
    let read =
        |spp: u32| Film::read_exr(&dir.path().join(format!("renders/dual-importance-{spp}spp-seed0.exr"))).unwrap();
    let (a, b) = (read(4), read(2));
    let (mut sum, mut n) = (0.0, 0);
    for i in 0..truth.alpha.len() {
        if truth.alpha[i] >= 1.0 {
            for c in 0..3 {
                sum += (a.mean[i].0[c] - b.mean[i].0[c]).powi(2);
                n += 1;
            }
        }
    }
    assert!(n > 0);
    let row = rows.iter().find(|r| r[0] == "dual-importance" && r[1] == "4" && r[2] == "0").unwrap();
    let rel_variance: f64 = row[5].parse().unwrap();
    assert!((rel_variance / (sum / n as f64) - 1.0).abs() < 1e-9, "{rel_variance} vs {}", sum / n as f64);
    assert!(rows.iter().filter(|r| r[1] == "1").all(|r| r[5].is_empty()), "1 spp has no previous doubling");
    assert!(rows.iter().all(|r| r[4].parse::<f64>().unwrap() > 0.0 && r[3].parse::<f64>().unwrap() > 0.0));

    // Rerun: everything reused, nothing rewritten; remove one render and only it is redone.
    let render = dir.path().join("renders/path-uniform-2spp-seed1.exr");
    let modified =
        || std::fs::metadata(dir.path().join("renders/dual-importance-4spp-seed0.exr")).unwrap().modified().unwrap();
    let before = modified();
    let again = converge(dir.path(), &[]);
    assert!(String::from_utf8_lossy(&again.stdout).contains("13 renders (13 reused)"));
    assert_eq!(modified(), before);
    std::fs::remove_file(&render).unwrap();
    let third = converge(dir.path(), &[]);
    assert!(String::from_utf8_lossy(&third.stdout).contains("13 renders (12 reused)"));
    assert!(render.exists());
    assert_eq!(std::fs::read_to_string(dir.path().join("results.csv")).unwrap().lines().count(), 13);

    // A rectangle instead of the hair mask.
    let rect = converge(dir.path(), &["--rect", "4,4,12,12"]);
    assert!(String::from_utf8_lossy(&rect.stdout).contains("64 pixels measured"));
}

#[test]
fn bad_arguments_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = converge(dir.path(), &["--methods", "path-light"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("light sampling alone is for dual only"));
    let out = converge(dir.path(), &["--methods", "dual-fast"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("no such sampling"));
    // Another model's flawed sampler is named, not silently replaced by this model's exact one.
    let out = converge(dir.path(), &["--methods", "path-box_muller"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("`box_muller` is the Sadeghi model's"));
}
