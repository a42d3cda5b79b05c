//! End-to-end checks of `dualhair precompute tables` and `dualhair precompute density`.

use precompute::density::read_vdb;
use std::path::Path;
use std::process::{Command, Output};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn dualhair(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dualhair")).args(args).output().unwrap()
}

fn ok(out: &Output) {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn tables_export_json_csv_and_charts() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    // A white fiber: every entry must split all light between the two halves.
    ok(&dualhair(&["precompute", "tables", "--sigma-a", "0", "--theta-count", "9", "-o", &path("t.json")]));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(path("t.json")).unwrap()).unwrap();
    let theta = json["theta"].as_array().unwrap();
    assert_eq!(theta.len(), 9);
    assert!((theta[0].as_f64().unwrap() + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    for key in ["a_f", "a_b", "alpha_f", "beta_f", "alpha_b", "beta_b", "A_b", "delta_b", "sigma_b"] {
        for c in ["r", "g", "b"] {
            assert_eq!(json[key][c].as_array().map(Vec::len), Some(9), "{key}.{c}");
        }
    }
    for k in 0..9 {
        let sum = json["a_f"]["g"][k].as_f64().unwrap() + json["a_b"]["g"][k].as_f64().unwrap();
        assert!((sum - 1.0).abs() < 2e-3, "entry {k}: a_f + a_b = {sum}");
    }
    assert_eq!(json["d_b"], 1.0);
    assert_eq!(json["fiber"]["absorption"]["sigma_a"][0], 0.0);

    ok(&dualhair(&[
        "precompute",
        "tables",
        "--eumelanin",
        "1.3",
        "--theta-count",
        "5",
        "--d-b",
        "0.5",
        "-o",
        &path("t.csv"),
    ]));
    let csv = std::fs::read_to_string(path("t.csv")).unwrap();
    assert_eq!(csv.lines().count(), 6);
    assert!(csv.starts_with("theta,a_f_r,a_f_g,a_f_b,"));

    for chart in ["t.png", "t.svg"] {
        ok(&dualhair(&["precompute", "tables", "--theta-count", "5", "-o", &path(chart)]));
        assert!(std::fs::metadata(path(chart)).unwrap().len() > 1000, "{chart} is too small to be a chart");
    }
    let svg = std::fs::read_to_string(path("t.svg")).unwrap();
    assert!(svg.contains("a_f") && svg.contains("sigma_b"), "the chart must label its curves");
}

#[test]
fn density_grid_of_a_hair_file_and_of_a_scene() {
    let dir = tempfile::tempdir().unwrap();
    let vdb = dir.path().join("d.vdb");
    let hair = format!("{ROOT}/precompute/tests/data/wavy_short_200.hair");
    for input in [hair.as_str(), &format!("{ROOT}/scenes/backlit_swatch.json")] {
        ok(&dualhair(&["precompute", "density", input, "-o", vdb.to_str().unwrap()]));
        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(vdb.with_extension("json")).unwrap()).unwrap();
        let (total, strands) = (summary["total_length"].as_f64().unwrap(), summary["strand_length"].as_f64().unwrap());
        assert!((total / strands - 1.0).abs() < 1e-3, "{input}: {total} vs {strands}");
        let grid = read_vdb(&vdb, "density").unwrap();
        assert_eq!(grid.voxel_size, summary["voxel_size"].as_f64().unwrap());
        assert_eq!(grid.voxels().count() as u64, summary["active_voxels"].as_u64().unwrap());
        assert!((grid.total_length() / strands - 1.0).abs() < 1e-3);
    }
    ok(&dualhair(&["precompute", "density", &hair, "--voxel-size", "0.05", "-o", vdb.to_str().unwrap()]));
    assert_eq!(read_vdb(&vdb, "density").unwrap().voxel_size, 0.05);
}

#[test]
fn bad_precompute_input_names_the_problem_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let hair = format!("{ROOT}/precompute/tests/data/wavy_short_200.hair");
    for (args, expect) in [
        (vec!["precompute", "tables", "--beta-m", "0", "-o", &out("a.json")], "beta_m"),
        (vec!["precompute", "tables", "-o", &out("a.txt")], ".json, .csv, .png or .svg"),
        (vec!["precompute", "tables", "--theta-count", "1", "-o", &out("a.json")], "--theta-count"),
        (vec!["precompute", "tables", "--d-b", "-1", "-o", &out("a.json")], "--d-b"),
        (vec!["precompute", "density", "missing.hair", "-o", &out("a.vdb")], "missing.hair"),
        (vec!["precompute", "density", &hair, "--voxel-size", "-0.1", "-o", &out("a.vdb")], "--voxel-size"),
        (vec!["precompute", "density", &hair, "-o", &out("a.exr")], ".vdb"),
    ] {
        let o = dualhair(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(expect), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "a failed run left a file");
    assert!(!Path::new(&out("a.json")).exists());
}
