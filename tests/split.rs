//! Renders that stop and go on, or are split across processes: an interrupt (SIGINT) keeps the
//! finished passes, `--resume` and `merge` give the same bytes as one uninterrupted render, and
//! the parts of a `converge` run merge into the same measures.

use crate::common::ROOT;
use dualhair::film::partial;
use dualhair::film::{Film, read_exr_layer};
use exr::prelude::{AttributeValue, Text};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

/// `dualhair` with the tests' cache (the dual integrator's tables are computed once for all tests).
fn dualhair() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_dualhair"));
    c.env("DUALHAIR_CACHE", format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")));
    c
}

fn run(args: &[&str], dir: &Path) -> Output {
    dualhair().args(args).current_dir(dir).output().unwrap()
}

fn succeeds(args: &[&str], dir: &Path) -> String {
    let out = run(args, dir);
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn fails(args: &[&str], dir: &Path, expect: &str) {
    let out = run(args, dir);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains(expect), "{args:?}: {err}");
}

fn bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap()
}

/// The files in `dir`, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn sigint_writes_the_finished_passes_and_resume_matches_an_uninterrupted_render() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!("{ROOT}/scenes/brown.json");
    let base = ["render", scene.as_str(), "--integrator", "path", "--width", "16", "--height", "16"];
    // Far more samples than the test waits for: the render is still going when SIGINT comes.
    let mut child = dualhair()
        .args(base)
        .args(["--spp", "10000000", "-o", "cut.exr"])
        .current_dir(dir.path())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    while !line.starts_with("rendering samples") {
        line.clear();
        assert!(stderr.read_line(&mut line).unwrap() > 0, "the render ended before it started rendering");
    }
    // The first pass is one sample per pixel (about a millisecond here); wait for several.
    std::thread::sleep(Duration::from_millis(1500));
    let kill = Command::new("sh").arg("-c").arg(format!("kill -INT {}", child.id())).status().unwrap();
    assert!(kill.success());
    let status = child.wait().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut rest).unwrap();
    assert_eq!(status.code(), Some(130), "{rest}");
    assert!(rest.contains("interrupted: wrote cut.exr and cut.png"), "{rest}");

    // The image is whole, holds its spp in the header, and no temporary is left.
    assert_eq!(files(dir.path()), ["cut.exr", "cut.png"]);
    let film = Film::read_exr(&dir.path().join("cut.exr")).unwrap();
    let layer = read_exr_layer(&dir.path().join("cut.exr")).unwrap();
    let Some(AttributeValue::I32(spp)) = layer.attributes.other.get(&Text::from("spp")) else {
        panic!("no spp in the header")
    };
    let spp = *spp as u32;
    assert!(spp >= 1 && spp == film.spp && spp < 10_000_000);
    assert!(rest.contains(&format!("with the {spp} finished spp")), "{rest}");
    let cut = partial::read(&dir.path().join("cut.exr")).unwrap().unwrap();
    assert_eq!(cut.sums.samples, 0..spp);

    // Resumed to a few more samples, it is the render made in one go, byte for byte.
    let more = (spp + 3).to_string();
    let out = succeeds(&[&base[..], &["--spp", &more, "-o", "cut.exr", "--resume", "-q"]].concat(), dir.path());
    assert!(out.contains(&format!("{spp} of them resumed")), "{out}");
    succeeds(&[&base[..], &["--spp", &more, "-o", "whole.exr", "-q"]].concat(), dir.path());
    assert!(bytes(dir.path(), "cut.exr") == bytes(dir.path(), "whole.exr"), "resumed render differs");
    assert!(bytes(dir.path(), "cut.png") == bytes(dir.path(), "whole.png"));
    // A finished render without sums cannot be resumed, and says why.
    fails(&[&base[..], &["--spp", "99", "-o", "whole.exr", "--resume"]].concat(), dir.path(), "holds no sample sums");
}

#[test]
fn parts_rendered_by_separate_processes_merge_into_the_single_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = format!("{ROOT}/scenes/brown.json");
    let base = ["render", scene.as_str(), "--width", "24", "--height", "20", "--spp", "7", "--aovs", "-q"];
    succeeds(&[&base[..], &["-o", "single.exr"]].concat(), d);
    // Three processes at once, as a scheduler would start them.
    let children: Vec<_> = (1..=3)
        .map(|k| {
            let (part, out) = (format!("{k}/3"), format!("part{k}.exr"));
            dualhair().args(base).args(["--part", &part, "-o", &out]).current_dir(d).spawn().unwrap()
        })
        .collect();
    for mut child in children {
        assert!(child.wait().unwrap().success());
    }
    let samples: Vec<_> =
        (1..=3).map(|k| partial::read(&d.join(format!("part{k}.exr"))).unwrap().unwrap().sums.samples).collect();
    assert_eq!(samples, [0..2, 2..4, 4..7]);
    assert!(!d.join("part1.png").exists(), "parts write no PNG");
    succeeds(&["merge", "part3.exr", "part1.exr", "part2.exr", "-o", "merged.exr"], d);
    assert!(bytes(d, "merged.exr") == bytes(d, "single.exr"), "merged image differs from the single render");
    assert!(bytes(d, "merged.png") == bytes(d, "single.png"));

    // A merge kept with --sums can be resumed to more samples, again as one render would be.
    succeeds(&["merge", "part1.exr", "part2.exr", "part3.exr", "-o", "grow.exr", "--sums"], d);
    let grow = ["render", scene.as_str(), "--width", "24", "--height", "20", "--spp", "9", "--aovs", "-q"];
    succeeds(&[&grow[..], &["-o", "grow.exr", "--resume"]].concat(), d);
    succeeds(&[&grow[..], &["-o", "single9.exr"]].concat(), d);
    assert!(bytes(d, "grow.exr") == bytes(d, "single9.exr"));

    // Missing, overlapping and foreign parts are refused, and no output is written.
    fails(&["merge", "part1.exr", "part3.exr", "-o", "bad.exr"], d, "a gap: a part is missing");
    fails(&["merge", "part1.exr", "part2.exr", "-o", "bad.exr"], d, "a part is missing or unfinished");
    fails(&["merge", "part1.exr", "part1.exr", "part2.exr", "part3.exr", "-o", "bad.exr"], d, "an overlap");
    succeeds(&[&base[..], &["--seed", "5", "--part", "2/3", "-o", "other.exr"]].concat(), d);
    fails(&["merge", "part1.exr", "other.exr", "part3.exr", "-o", "bad.exr"], d, "parts of different renders");
    fails(&["merge", "single.exr", "-o", "bad.exr"], d, "not a partial render");
    fails(&[&base[..], &["--part", "4/3", "-o", "bad.exr"]].concat(), d, "is not K/N");
    assert!(!d.join("bad.exr").exists());
}

#[test]
fn converge_parts_merge_into_the_single_run() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = format!("{ROOT}/scenes/brown.json");
    let args = [
        "converge",
        &scene,
        "--width",
        "16",
        "--height",
        "16",
        "-q",
        "--methods",
        "dual-importance,path-uniform",
        "--spp",
        "1,2,4",
        "--seeds",
        "2",
        "--truth-spp",
        "16",
    ];
    for k in 1..=3 {
        let out = succeeds(&[&args[..], &["--part", &format!("{k}/3"), "-o", &format!("p{k}")]].concat(), d);
        assert!(out.contains(&format!("part {k}/3")), "{out}");
    }
    fails(&["merge", "p1", "p3", "-o", "bad"], d, "parts 2/3 are missing");
    let merged = succeeds(&["merge", "p2", "p1", "p3", "-o", "merged"], d);
    assert!(merged.contains("13 renders (13 reused)"), "{merged}");
    succeeds(&[&args[..], &["-o", "single"]].concat(), d);
    // The same renders, so the same measures; only the wall times differ.
    let measures = |run: &str| -> Vec<String> {
        let csv = std::fs::read_to_string(d.join(run).join("results.csv")).unwrap();
        csv.lines().map(|l| l.split(',').enumerate().filter(|(i, _)| *i != 3).map(|(_, v)| v).collect()).collect()
    };
    assert_eq!(measures("merged"), measures("single"));
    assert_eq!(measures("merged").len(), 13);
    for name in files(&d.join("single/renders")).iter().filter(|n| n.ends_with(".exr")) {
        let (a, b) = (bytes(&d.join("single/renders"), name), bytes(&d.join("merged/renders"), name));
        assert!(a == b, "{name} differs");
    }
}

#[test]
fn the_slurm_script_runs_each_array_task_as_a_part() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = format!("{ROOT}/scenes/brown.json");
    let flags = [scene.as_str(), "--width", "16", "--height", "16", "--spp", "5"];
    for k in ["1", "2"] {
        let status = Command::new("bash")
            .arg(format!("{ROOT}/tools/slurm_parts.sh"))
            .args(["render", "parts"])
            .args(flags)
            .env("SLURM_ARRAY_TASK_ID", k)
            .env("SLURM_ARRAY_TASK_COUNT", "2")
            .env("DUALHAIR", env!("CARGO_BIN_EXE_dualhair"))
            .env("DUALHAIR_CACHE", format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")))
            .current_dir(d)
            .status()
            .unwrap();
        assert!(status.success());
    }
    assert_eq!(files(&d.join("parts")), ["part-1-of-2.exr", "part-2-of-2.exr"]);
    succeeds(&["merge", "parts/part-1-of-2.exr", "parts/part-2-of-2.exr", "-o", "merged.exr"], d);
    succeeds(&[&["render"][..], &flags, &["-q", "-o", "single.exr"]].concat(), d);
    assert!(bytes(d, "merged.exr") == bytes(d, "single.exr"));
}

/// Renders started at once on one cold cache folder (as the parts of a split render on a shared
/// file system): each entry is built by one process while the others wait for it, every image is
/// what a render alone makes, and the cache ends whole.
#[test]
fn concurrent_renders_build_each_cache_entry_once() {
    let dir = tempfile::tempdir().unwrap();
    let (d, cache) = (dir.path(), dir.path().join("cache"));
    let scene = format!("{ROOT}/scenes/brown.json");
    let args = |out: &str| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_dualhair"));
        c.env("DUALHAIR_CACHE", &cache).current_dir(d);
        c.args(["render", &scene, "--width", "12", "--height", "12", "--spp", "2", "--shadows", "lookup", "-o", out]);
        c
    };
    let children: Vec<_> = (0..4)
        .map(|k| args(&format!("r{k}.exr")).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap())
        .collect();
    let mut said = String::new();
    for child in children {
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        said += &err;
    }
    for what in ["the dual-scattering tables", "the density grid", "the forward-transmittance maps of the sky"] {
        assert_eq!(said.matches(&format!("built {what} in")).count(), 1, "{what}:\n{said}");
    }
    let mut names: Vec<String> =
        std::fs::read_dir(&cache).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    let kinds: Vec<&str> = names.iter().map(|n| n.split('-').next().unwrap()).collect();
    assert_eq!(kinds, ["density", "density", "lookup", "lookup", "tables", "tables"], "{names:?}");
    assert_eq!(names.iter().filter(|n| n.ends_with(".lock")).count(), 3, "{names:?}");
    // The entries read back give the same image as the processes that built or waited for them.
    let alone = args("alone.exr").arg("-q").output().unwrap();
    assert!(alone.status.success() && alone.stderr.is_empty(), "{}", String::from_utf8_lossy(&alone.stderr));
    for k in 0..4 {
        assert!(bytes(d, &format!("r{k}.exr")) == bytes(d, "alone.exr"), "render {k} differs");
    }
}

/// Stops the one-node Slurm cluster in `.0` when dropped (also when the test fails).
struct Cluster(std::path::PathBuf);

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash").arg(format!("{ROOT}/tools/slurm_one_node.sh")).arg("stop").arg(&self.0).status();
    }
}

/// tools/slurm_parts.sh under Slurm itself (a one-node cluster, tools/slurm_one_node.sh): array
/// jobs for a render and a converge run, one render task requeued mid-way as a preemption would
/// (SIGTERM, then the same task again, resuming), merged by jobs that depend on the arrays, and
/// the results are those of single runs byte for byte. Skipped, saying so, where the daemons
/// cannot start (Slurm not installed, not root).
#[test]
fn the_slurm_script_meets_slurm() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let ports: Vec<u16> =
        (0..2).map(|_| std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()).collect();
    let started = Command::new("bash")
        .arg(format!("{ROOT}/tools/slurm_one_node.sh"))
        .arg("start")
        .arg(d.join("cluster"))
        .env("SLURM_PORTS", format!("{} {}", ports[0], ports[1]))
        .output();
    let _cluster = Cluster(d.join("cluster"));
    match started {
        Ok(out) if out.status.success() => {}
        Ok(out) => return eprintln!("skipped: no Slurm cluster here: {}", String::from_utf8_lossy(&out.stderr)),
        Err(e) => return eprintln!("skipped: no bash: {e}"),
    }
    let sh = |script: &str| -> String {
        let out = Command::new("bash")
            .args(["-c", script])
            .env("SLURM_CONF", d.join("cluster/slurm.conf"))
            .env("DUALHAIR", env!("CARGO_BIN_EXE_dualhair"))
            .env("DUALHAIR_CACHE", format!("{}/dualhair-cache", env!("CARGO_TARGET_TMPDIR")))
            .current_dir(d)
            .output()
            .unwrap();
        assert!(out.status.success(), "{script}: {}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stdout).trim().to_owned()
    };
    let scene = format!("{ROOT}/scenes/brown.json");
    let render = format!("{scene} --width 48 --height 48 --spp 1800");
    succeeds(&["render", &scene, "--width", "8", "--height", "8", "--spp", "1", "-q", "-o", "warm.exr"], d);
    // The script asks for 16 CPUs a task; the command line gives what this node has.
    let submit = |tasks: &str, args: &str| {
        let script = format!("{ROOT}/tools/slurm_parts.sh");
        sh(&format!("sbatch --parsable --array=1-{tasks} --cpus-per-task=1 --open-mode=append {script} {args}"))
    };
    let job = submit("3", &format!("render parts {render}"));
    let merge =
        |array: &str, what: &str| sh(&format!("sbatch --parsable --dependency=afterok:{array} --wrap '{what}'"));
    let merged =
        merge(&job, "$DUALHAIR merge parts/part-1-of-3.exr parts/part-2-of-3.exr parts/part-3-of-3.exr -o merged.exr");
    let converge = "converge SCENE --width 16 --height 16 --methods dual-importance,path-uniform --spp 1,2,4 --seeds 2 --truth-spp 16";
    let converge = converge.replace("SCENE", &scene);
    let runs = submit("2", &converge.replacen("converge", "converge runs", 1));
    let gathered = merge(&runs, "$DUALHAIR merge runs/part-1-of-2 runs/part-2-of-2 -o gathered");
    // Preempt task 2 once it has rendered for a while.
    let state = |task: &str| sh(&format!("squeue -h -j {task} -o %T"));
    let task = format!("{job}_2");
    let wait = |done: &dyn Fn() -> bool, what: &str| {
        let start = std::time::Instant::now();
        while !done() {
            assert!(start.elapsed() < Duration::from_secs(600), "waited 10 minutes for {what}");
            std::thread::sleep(Duration::from_millis(200));
        }
    };
    wait(&|| state(&task) == "RUNNING", "task 2 to start");
    std::thread::sleep(Duration::from_secs(2));
    sh(&format!("scontrol requeue {task}"));
    wait(&|| sh("squeue -h -o %i").is_empty(), "the jobs to finish");
    for id in [&job, &merged, &runs, &gathered] {
        let show = sh(&format!("scontrol show job {id}"));
        assert_eq!(show.matches("JobState=").count(), show.matches("JobState=COMPLETED").count(), "{show}");
    }
    assert!(sh(&format!("scontrol show job {task}")).contains("Restarts=1"));
    let log = std::fs::read_to_string(d.join(format!("dualhair-parts-{job}_2.log"))).unwrap();
    assert!(log.contains("interrupted: wrote") && log.contains("of them resumed"), "{log}");
    succeeds(&["render", &scene, "--width", "48", "--height", "48", "--spp", "1800", "-q", "-o", "single.exr"], d);
    assert!(bytes(d, "merged.exr") == bytes(d, "single.exr"), "the merged parts differ from one render");
    let args: Vec<&str> = converge.split(' ').collect();
    succeeds(&[&args[..], &["-q", "-o", "single"]].concat(), d);
    let measures = |run: &str| -> Vec<String> {
        let csv = std::fs::read_to_string(d.join(run).join("results.csv")).unwrap();
        csv.lines().map(|l| l.split(',').enumerate().filter(|(i, _)| *i != 3).map(|(_, v)| v).collect()).collect()
    };
    assert_eq!(measures("gathered"), measures("single"));
}
