//! Renderer-level checks: energy conservation (furnace), single = path at depth 1, importance and
//! uniform fiber sampling converging to the same image, thread-count independence, bad scenes.

use dualhair::analysis::compare::hair_pixels;
use dualhair::film::Film;
use dualhair::integrators::Term;
use dualhair::integrators::dual::cache::Cache;
use dualhair::integrators::{IntegratorKind, Sampling};
use dualhair::job::render_scene;
use dualhair::progress::Silent;
use dualhair::scene::{EnvSpec, LightsSpec, SceneFile};
use precompute::spectrum::Rgb;
use std::path::Path;
use std::process::Command;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn scene_from(json: &str) -> SceneFile {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.json");
    std::fs::write(&path, json.replace("@HDRI", &format!("{ROOT}/scenes/hdri"))).unwrap();
    SceneFile::load(&path).unwrap()
}

/// The dual integrator's tables and grids, shared by every test and kept between runs.
fn cache_dir() -> String {
    format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR"))
}

fn render(file: &SceneFile) -> Film {
    render_scene(&file.build().unwrap(), &Cache::at(cache_dir()), &Silent).unwrap()
}

/// Mean luminance over pixels that hair fully covers, and its standard error.
fn hair_mean(film: &Film) -> (f64, f64, usize) {
    let idx: Vec<usize> = (0..film.alpha.len()).filter(|&i| film.alpha[i] >= 1.0).collect();
    let n = idx.len() as f64;
    let mean = idx.iter().map(|&i| film.mean[i].luminance()).sum::<f64>() / n;
    let var = idx.iter().map(|&i| film.variance[i].luminance()).sum::<f64>() / (n * n);
    (mean, var.sqrt(), idx.len())
}

#[test]
fn furnace_conserves_energy_through_every_bounce() {
    let film = render(&SceneFile::load(Path::new(&format!("{ROOT}/scenes/furnace.json"))).unwrap());
    let (mean, se, n) = hair_mean(&film);
    println!("furnace: mean radiance {mean:.4} +- {se:.4} over {n} fully covered hair pixels");
    assert!(n > 1000, "too few covered pixels: {n}");
    assert!((mean - 1.0).abs() < 0.02, "furnace mean {mean}");
    // Per channel too, and no pixel far off.
    for c in 0..3 {
        let m: f64 =
            film.mean.iter().zip(&film.alpha).filter(|(_, a)| **a >= 1.0).map(|(p, _)| p.0[c]).sum::<f64>() / n as f64;
        assert!((m - 1.0).abs() < 0.02, "channel {c}: {m}");
    }
}

const BROWN_CURLS: &str = r#"{
  "hair": {"generate": {"kind": "curly", "strands": 800, "points": 64}},
  "fiber": {"absorption": {"melanin": {"eumelanin": 1.3}}},
  "camera": {"width": 48, "height": 48},
  "lights": {"environment": {"file": "@HDRI/courtyard.exr"}, "sun": {"direction": [-0.5, -1, 0.6], "irradiance": 1.5}},
  "render": {"spp": 8}
}"#;

#[test]
fn single_is_path_at_depth_one() {
    let mut single = scene_from(BROWN_CURLS);
    single.render.integrator = IntegratorKind::Single;
    let mut path = scene_from(BROWN_CURLS);
    path.render.integrator = IntegratorKind::Path;
    path.render.max_depth = 1;
    let (a, b) = (render(&single), render(&path));
    assert!(a.mean == b.mean && a.alpha == b.alpha, "single and path at depth 1 must be the same estimator");
    // And multiple scattering adds light.
    path.render.max_depth = 512;
    let full = render(&path);
    assert!(hair_mean(&full).0 > 1.05 * hair_mean(&a).0);
}

#[test]
fn every_integrator_renders_every_fiber_model() {
    // The other models behind the same interface: single is path at depth 1 for each too,
    // multiple scattering adds light, and dual (its own tables) lands between single and path.
    for model in ["marschner", "sadeghi", "deon2014"] {
        every_integrator_renders(model);
    }
}

fn every_integrator_renders(model: &str) {
    let json = BROWN_CURLS.replacen(r#""fiber": {"#, &format!(r#""fiber": {{"model": "{model}", "#), 1);
    assert!(json.contains(model), "the scene has a fiber section to extend");
    let mut file = scene_from(&json);
    file.render.integrator = IntegratorKind::Single;
    let single = render(&file);
    file.render.integrator = IntegratorKind::Path;
    file.render.max_depth = 1;
    assert!(render(&file).mean == single.mean, "single and path at depth 1 must be the same estimator");
    file.render.max_depth = 512;
    let path = hair_mean(&render(&file)).0;
    file.render.integrator = IntegratorKind::Dual;
    let dual = render(&file);
    assert!(dual.mean.iter().all(|p| p.is_finite()));
    let (s, d) = (hair_mean(&single).0, hair_mean(&dual).0);
    println!("{model} brown curls: single {s:.4}, dual {d:.4}, path {path:.4}");
    assert!(s < d && d < 1.2 * path && path > 1.05 * s, "{model}: single {s}, dual {d}, path {path}");
}

#[test]
fn a_lone_straight_fiber_scatters_light_once() {
    // A straight fiber is convex: light leaving it never meets it again, so path tracing finds
    // exactly single scattering (bit for bit: the same estimator, whose later vertices find
    // nothing). Before rays ignored the overlap of consecutive segments at their joints, this
    // image was 26% brighter with `path` (docs/cycles.md).
    let json = r#"{"hair": {"generate": {"kind": "straight", "strands": 1, "points": 16}, "radius": 0.02,
        "rotate": [0, 30, 0]}, "camera": {"width": 48, "height": 48},
        "lights": {"sun": {"direction": [0.3, -1.0, 0.5], "irradiance": 3.0}},
        "render": {"integrator": "path", "spp": 16}}"#;
    let path = scene_from(json);
    let mut single = scene_from(json);
    single.render.max_depth = 1;
    let (a, b) = (render(&path), render(&single));
    assert!(hair_mean(&b).0 > 0.0 && hair_mean(&b).2 > 20, "the fiber must cover pixels");
    assert!(a.mean == b.mean, "path found light scattered twice on a lone straight fiber");
}

#[test]
fn radiance_splits_into_terms_the_way_dual_scattering_does() {
    let sum = |t: &[Rgb; 4]| t.iter().fold(Rgb::ZERO, |a, b| a + *b);
    let close = |a: Rgb, b: Rgb| (0..3).all(|c| (a.0[c] - b.0[c]).abs() <= 1e-9 * b.0[c].abs() + 1e-12);
    let total = |f: &Film, t: Term| f.terms.iter().map(|p| p[t as usize].luminance()).sum::<f64>();
    let mut file = scene_from(BROWN_CURLS);
    file.render.terms = true;
    for integrator in [IntegratorKind::Path, IntegratorKind::Dual] {
        file.render.integrator = integrator;
        let film = render(&file);
        // Where every sample hit hair (the background seen directly is in no term).
        let hair = hair_pixels(&film);
        assert!(hair.len() > 500 && hair.iter().all(|&i| close(sum(&film.terms[i]), film.mean[i])), "{integrator:?}");
        let shares = Term::ALL.map(|t| total(&film, t));
        println!("{integrator:?}: luminance per term {shares:?}");
        assert!(shares[..3].iter().all(|&s| s > 0.0), "{integrator:?}: a term is empty");
        // dual's backscatter is one term.
        assert_eq!(shares[3] == 0.0, integrator == IntegratorKind::Dual);
        // The term channels survive the EXR (as 32-bit floats).
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        film.write_exr(&path, true).unwrap();
        let back = Film::read_exr(&path).unwrap();
        for (a, b) in back.terms.iter().flatten().zip(film.terms.iter().flatten()) {
            assert!((0..3).all(|c| (a.0[c] - b.0[c]).abs() <= 1e-6 * b.0[c].abs()));
        }
    }
    // Single scattering is all `single`.
    file.render.integrator = IntegratorKind::Single;
    let film = render(&file);
    let t = &film.terms;
    assert!(hair_pixels(&film).iter().all(|&i| t[i][0] == film.mean[i] && t[i][1..] == [Rgb::ZERO; 3]));
}

#[test]
fn importance_and_uniform_sampling_agree() {
    // Direct lighting and full path tracing of a rough fiber (beta 0.6), where uniform sampling's
    // variance stays affordable: at beta 0.3 the uniform estimate needs ~10x the samples to judge 1%.
    // A constant environment: a sun's or a bright HDRI spot's binary shadow-ray visibility adds
    // noise that has nothing to do with the fiber sampler under test.
    for (integrator, beta, spp) in [(IntegratorKind::Single, 0.6, 512), (IntegratorKind::Path, 0.6, 1024)] {
        let mut imp = scene_from(BROWN_CURLS);
        imp.lights =
            LightsSpec { environment: Some(EnvSpec { color: Some([1.0, 0.9, 0.8]), ..Default::default() }), sun: None };
        imp.render.integrator = integrator;
        imp.render.spp = spp;
        (imp.camera.width, imp.camera.height) = (96, 96);
        imp.fiber.beta_m = beta;
        imp.fiber.beta_n = beta;
        let mut uni = imp.clone();
        uni.render.sampling = Some(Sampling::Uniform);
        uni.render.seed = 1;
        let (a, b) = (hair_mean(&render(&imp)), hair_mean(&render(&uni)));
        println!("{integrator:?} beta {beta}: importance {:.5} +- {:.5}, uniform {:.5} +- {:.5}", a.0, a.1, b.0, b.1);
        let se = (a.1 * a.1 + b.1 * b.1).sqrt();
        assert!(se < 0.003 * a.0, "too noisy to judge 1%: {se}");
        assert!((a.0 - b.0).abs() < 0.01 * a.0, "importance {a:?} vs uniform {b:?}");
    }
}

#[test]
fn output_is_bit_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let run = |threads: &str| {
        let out = dir.path().join(format!("t{threads}.exr"));
        let status = Command::new(env!("CARGO_BIN_EXE_dualhair"))
            .env("DUALHAIR_CACHE", cache_dir())
            .args(["render", &format!("{ROOT}/scenes/furnace.json"), "--spp", "4", "--width", "40", "--height", "30"])
            .args(["--threads", threads, "--seed", "7", "--aovs", "-q", "-o", out.to_str().unwrap()])
            .status()
            .unwrap();
        assert!(status.success());
        std::fs::read(out).unwrap()
    };
    assert!(run("1") == run("2"), "EXR differs between 1 and 2 threads");
}

#[test]
fn bad_scenes_name_the_problem() {
    let cases = [
        (r#"{"hair": {"generate": {"kind": "ball"}}, "colour": 1}"#, "unknown field `colour`"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "render": {"spp": 0}}"#, "render.spp"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "camera": {"fov": 190}}"#, "camera.fov"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "camera": {"position": [0, 0, 1]}}"#, "look_at"),
        (r#"{"hair": {"generate": {"kind": "ball"}, "radius": -0.1}}"#, "hair.radius"),
        (r#"{"hair": {"generate": {"kind": "ball"}, "scale": 0}}"#, "hair.scale"),
        (r#"{"hair": {}}"#, "exactly one of `file` and `generate`"),
        (r#"{"hair": {"file": "missing.hair"}}"#, "missing.hair"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "fiber": {"beta_m": 2}}"#, "beta_m"),
        (
            r#"{"hair": {"generate": {"kind": "ball"}}, "lights": {"sun": {"direction": [0, 0, 0], "irradiance": 1}}}"#,
            "lights.sun.direction",
        ),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "lights": {"environment": {"file": "nope.exr"}}}"#, "nope.exr"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "render": {"spp": NaN}}"#, "scene.json"),
        (r#"{"hair": {"generate": {"kind": "ball", "strands": 0}}}"#, "strands"),
        (
            r#"{"hair": {"generate": {"kind": "ball"}}, "dual": {"model": "fibers", "shadows": "lookup"}}"#,
            "needs dual.shadows",
        ),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "dual": {"lookup": {"env_grid": 1}}}"#, "dual.lookup.env_grid"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "dual": {"lookup": {"sun_texel": 0}}}"#, "dual.lookup.sun_texel"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "dual": {"shadows": "maps"}}"#, "unknown variant `maps`"),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "render": {"sampling": "thesis"}}"#, "Marschner model's"),
        (
            r#"{"hair": {"generate": {"kind": "ball"}}, "fiber": {"model": "marschner", "marschner": {"beta_r": 0}}}"#,
            "marschner.beta_r",
        ),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "render": {"sampling": "box_muller"}}"#, "Sadeghi model's"),
        (
            r#"{"hair": {"generate": {"kind": "ball"}}, "fiber": {"model": "sadeghi", "sadeghi": {"gamma_tt": -1}}}"#,
            "gamma_tt",
        ),
        (r#"{"hair": {"generate": {"kind": "ball"}}, "fiber": {"model": "deon2015"}}"#, "deon2014"),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (json, expect) in cases {
        let path = dir.path().join("scene.json");
        std::fs::write(&path, json).unwrap();
        let err = SceneFile::load(&path).and_then(|f| f.build().map(|_| ())).expect_err(json);
        let msg = format!("{err:#}");
        assert!(msg.contains(expect), "{json}: {msg}");
    }
}

#[test]
fn render_command_writes_exr_and_png_or_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let ok = Command::new(env!("CARGO_BIN_EXE_dualhair"))
        .env("DUALHAIR_CACHE", cache_dir())
        .args([
            "render",
            &format!("{ROOT}/scenes/default.json"),
            "--spp",
            "1",
            "--width",
            "32",
            "--height",
            "32",
            "-q",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    assert!(out.exists() && out.with_extension("exr").exists());
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o644, "outputs are ordinary files, not private temporaries");
    }
    let bad = dir.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    let fail = Command::new(env!("CARGO_BIN_EXE_dualhair"))
        .env("DUALHAIR_CACHE", cache_dir())
        .args(["render", &format!("{ROOT}/scenes/default.json"), "--spp", "0", "-q", "-o"])
        .arg(bad.join("y.exr"))
        .output()
        .unwrap();
    assert!(!fail.status.success() && String::from_utf8_lossy(&fail.stderr).contains("render.spp"));
    assert_eq!(std::fs::read_dir(&bad).unwrap().count(), 0, "a failed render left a file");
}

/// What cannot fit or be written is refused before the work, naming the field and the memory;
/// a radiance beyond what the sums hold is refused, and a clipped pixel is reported.
#[test]
fn what_cannot_fit_or_be_written_is_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let (d, out) = (dir.path(), dir.path().join("out"));
    std::fs::create_dir(&out).unwrap();
    let run = |memory: Option<&str>, args: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_dualhair"));
        c.env("DUALHAIR_CACHE", cache_dir()).current_dir(&out).args(args);
        if let Some(m) = memory {
            c.env("DUALHAIR_MEMORY", m);
        }
        let run = c.output().unwrap();
        (run.status.success(), String::from_utf8_lossy(&run.stderr).into_owned())
    };
    let brown = format!("{ROOT}/scenes/brown.json");
    let hair = format!("{ROOT}/scenes/groom/wavy_short.hair.gz");
    let render = |extra: &[&'static str]| -> Vec<&str> {
        [&["render", brown.as_str(), "--width", "8", "--height", "8", "--spp", "1"][..], extra].concat()
    };
    let big = |w: &'static str| -> Vec<&str> { vec!["render", &brown, "--width", w, "--height", w, "-o", "a.exr"] };
    let cases: Vec<(Option<&str>, Vec<&str>, &str)> = vec![
        // 2000 x 2000 pixels of 188 bytes are 752 MB.
        (
            Some("100000000"),
            big("2000"),
            "camera.width x camera.height = 2000 x 2000 pixels (188 bytes each) would need 752.0 MB of memory; 100.0 MB is available",
        ),
        (None, big("200000"), "camera.width must be in 1..=16384"),
        // The swatch's 152,400 segments at 270 bytes are 41 MB.
        (
            Some("10000000"),
            render(&["-o", "a.exr"]),
            "hair: the BVH over the hair's 152400 segments (270 bytes each) would need 41.1 MB",
        ),
        (
            Some("100000000"),
            vec!["precompute", "density", &hair, "--voxel-size", "0.00001", "-o", "g.vdb"],
            "the density grid at --voxel-size 0.00001",
        ),
        (
            None,
            render(&["-o", "missing/folder/x.exr"]),
            "missing/folder/x.exr: the folder missing/folder does not exist",
        ),
        (None, vec!["lobe", "-o", "missing/l.png"], "the folder missing does not exist"),
        (None, vec!["precompute", "tables", "-o", "missing/t.json"], "the folder missing does not exist"),
    ];
    for (memory, args, expect) in &cases {
        let (ok, err) = run(*memory, args);
        assert!(!ok && err.contains(expect), "{args:?}: {err}");
        assert!(!err.contains("rendering samples"), "{args:?} rendered before refusing");
    }
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "a refused run left a file");

    // A light past the sums' range is refused; one whose squares fill them renders, reported.
    let bright = d.join("bright.json");
    let bright_scene = |strength: f64| {
        let mut scene: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&brown).unwrap()).unwrap();
        scene["lights"]["environment"]["strength"] = serde_json::json!(strength);
        scene["lights"]["environment"]["file"] = serde_json::json!(format!("{ROOT}/scenes/hdri/courtyard.exr"));
        std::fs::write(&bright, scene.to_string()).unwrap();
        run(
            None,
            &["render", bright.to_str().unwrap(), "--width", "8", "--height", "8", "--spp", "4", "-q", "-o", "b.exr"],
        )
    };
    for (strength, refused) in [(1e300, "beyond f32's range"), (1e19, "beyond the 1.5e20 a pixel's sums hold")] {
        let (ok, err) = bright_scene(strength);
        assert!(!ok && err.contains("lights.environment.strength: ") && err.contains(refused), "{err}");
    }
    let (ok, err) = bright_scene(1e12);
    assert!(ok && err.contains("pixels reached the ceiling of their sums"), "{err}");
    assert!(out.join("b.exr").exists());
}
