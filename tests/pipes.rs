//! A closed stdout (`dualhair ... | head`) ends every command quietly: exit 0, no message, no
//! panic, and every file it writes still complete.

use std::path::Path;
use std::process::{Command, Stdio};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn dualhair(dir: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_dualhair"));
    c.env("DUALHAIR_CACHE", format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR"))).current_dir(dir);
    c
}

/// Runs `args` with stdout a pipe whose reader has already gone, then checks the command ended
/// as if it had a reader, and that the same command does print (so the pipe was written to).
fn quiet_on_closed_pipe(dir: &Path, args: &[&str], outputs: &[&str]) {
    let mut child = dualhair(dir).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    drop(child.stdout.take()); // the reader closes before the command writes a byte
    let run = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{args:?}: {:?}\n{stderr}", run.status);
    let said = stderr.to_lowercase();
    assert!(!["panic", "error", "pipe"].iter().any(|w| said.contains(w)), "{args:?}:\n{stderr}");
    for name in outputs {
        let path = dir.join(name);
        match path.extension().and_then(|e| e.to_str()) {
            Some("png" | "exr") => drop(image::open(&path).unwrap_or_else(|e| panic!("{args:?}: {name}: {e}"))),
            Some("json") => drop(serde_json::from_slice::<serde_json::Value>(&std::fs::read(&path).unwrap()).unwrap()),
            _ => assert!(path.metadata().unwrap().len() > 0 || path.is_dir(), "{args:?}: {name} is empty"),
        }
    }
    let printed = dualhair(dir).args(args).output().unwrap();
    assert!(printed.status.success() && !printed.stdout.is_empty(), "{args:?} prints nothing to test with");
}

#[test]
fn every_printing_command_ends_quietly_on_a_closed_stdout() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let brown = format!("{ROOT}/scenes/brown.json");
    let hair = format!("{ROOT}/scenes/groom/wavy_short.hair.gz");
    let small = ["--width", "8", "--height", "8", "--spp", "2"];
    let render = |extra: &[&'static str]| -> Vec<&str> { [&["render", brown.as_str()][..], &small, extra].concat() };
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (render(&["-o", "a.exr"]), vec!["a.exr", "a.png"]),
        (render(&["--seed", "2", "-o", "b.exr"]), vec!["b.exr"]),
        (render(&["--part", "1/2", "-o", "p1.exr"]), vec!["p1.exr"]),
        (render(&["--part", "2/2", "-o", "p2.exr"]), vec!["p2.exr"]),
        (vec!["merge", "p1.exr", "p2.exr", "-o", "m.exr"], vec!["m.exr", "m.png"]),
        (vec!["compare", "a.exr", "b.exr"], vec![]),
        (vec!["precompute", "tables", "--theta-count", "5", "-o", "t.json"], vec!["t.json"]),
        (vec!["precompute", "density", &hair, "-o", "g.vdb"], vec!["g.vdb"]),
        (vec!["lobe", "--width", "16", "--height", "8", "-o", "l.png"], vec!["l.png"]),
        (vec!["fibersim", "--rays", "20000", "--width", "16", "--height", "8", "-o", "f.png"], vec!["f.png"]),
        (vec!["convert", &hair, "c.hair"], vec!["c.hair"]),
        (vec!["calibrate", &brown, "--size", "12", "--reference-spp", "16", "--spp", "4", "-q"], vec![]),
    ];
    for (args, outputs) in &cases {
        quiet_on_closed_pipe(d, args, outputs);
    }
    let converge = [&brown, "--width", "8", "--height", "8", "--methods", "dual-importance,path-uniform", "-q"];
    let converge = [&["converge"][..], &converge, &["--spp", "1,2", "--seeds", "2", "--truth-spp", "8", "-o", "cv"]];
    quiet_on_closed_pipe(d, &converge.concat(), &["cv/error_vs_spp.svg"]);
    // Few samples: what is tested here is the pipe, not the estimates (tests/stability_cli.rs).
    let stability = ["stability", "--quick", "--samples", "300", "--rays", "400", "--hits", "2", "-q", "-o", "st"];
    quiet_on_closed_pipe(d, &stability, &["st"]);
}
