//! A CAVE on an MPI cluster for real: `mpirun -np 3 vlf cave` on this machine (lavapipe),
//! headless and in windows under Xvfb: every rank presents the same frame numbers with the same
//! (scripted, moving) poses; a wand ray crossing from the front wall (rank 1) to the left wall
//! (rank 2) meets itself at the seam within 1 px; a killed rank and a hung rank end the run
//! naming the lost rank within the timeout; the state rank 0 broadcasts carries the wand and the
//! left hand through its bytes. Needs Open MPI's mpirun and a build with
//! `--features mpi` (tools/test.sh passes it); without either the tests fail saying so, they
//! never skip.

use crate::common;

#[cfg(feature = "mpi")]
use common::{control_address, script_replies};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The tests take turns: each runs three ranks on 2 cores.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Lost-rank timeout in the test configuration, seconds.
const TIMEOUT_S: f64 = 5.0;

struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn require(tool: &str, install: &str) {
    let found = Command::new("sh")
        .arg("-c")
        .arg(format!("command -v {tool}"))
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        found,
        "{tool} is missing: install it ({install}; tools/setup.sh does)"
    );
}

/// `mpirun -np 3 vlf cave <config> ...`: oversubscribed (3 ranks on 2 cores), allowed as root.
fn mpirun(config: &Path, scene: &Path, args: &[&str], env: &[(&str, &str)]) -> Command {
    require("mpirun", "sudo apt-get install openmpi-bin libopenmpi-dev");
    let mut c = Command::new("mpirun");
    c.args(["--oversubscribe", "-np", "3"]);
    for (k, v) in env {
        c.args(["-x", k]).env(k, v);
    }
    c.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .arg(env!("CARGO_BIN_EXE_vlf"))
        .args(["cave", config.to_str().unwrap(), "--scene"])
        .arg(scene)
        .args(args);
    c
}

#[cfg_attr(not(feature = "mpi"), allow(dead_code))]
const LIGHT: [&str; 6] = [
    "--directions",
    "126",
    "--grid",
    "48",
    "--texel-density",
    "16",
];

/// Three mono walls (front on rank 1, left on rank 2, floor on rank 0) and a scripted head and
/// wand moving over 2 s; the wand ray blue, aimed past the front-left seam.
fn write_config(dir: &Path, pixels: u32) -> PathBuf {
    std::fs::write(
        dir.join("path.toml"),
        r#"
[[keyframe]]
t = 0.0
head = [0.0, 1.2, 0.3]
position = [0.0, 0.0, 2.2]
wand_position = [0.0, 1.2, 0.0]
wand_yaw_deg = 45.0
wand_pitch_deg = 10.0
[[keyframe]]
t = 2.0
head = [0.1, 1.25, 0.2]
head_yaw_deg = 8.0
position = [0.0, 0.0, 2.0]
yaw_deg = 3.0
wand_position = [0.0, 1.25, 0.0]
wand_yaw_deg = 44.0
wand_pitch_deg = 6.0
"#,
    )
    .unwrap();
    let wall = |name: &str, ll: &str, lr: &str, ul: &str, x: u32| {
        format!("[[wall]]\nname = \"{name}\"\nlower_left = {ll}\nlower_right = {lr}\nupper_left = {ul}\npixels = [{pixels}, {pixels}]\noutput = {{ window = [{x}, 0] }}\n")
    };
    let text = format!(
        r#"name = "three"
[tracking]
source = "scripted"
path = "path.toml"
[wand_ray]
length = 5.0
colour = [0.0, 0.0, 1.0]
[cluster]
timeout_s = {TIMEOUT_S}
[[cluster.node]]
rank = 0
walls = ["floor"]
[[cluster.node]]
rank = 1
walls = ["front"]
[[cluster.node]]
rank = 2
walls = ["left"]
{}{}{}"#,
        wall(
            "front",
            "[-1.5, 0.0, -1.5]",
            "[1.5, 0.0, -1.5]",
            "[-1.5, 3.0, -1.5]",
            0
        ),
        wall(
            "left",
            "[-1.5, 0.0, 1.5]",
            "[-1.5, 0.0, -1.5]",
            "[-1.5, 3.0, 1.5]",
            pixels + 10
        ),
        wall(
            "floor",
            "[-1.5, 0.0, 1.5]",
            "[1.5, 0.0, 1.5]",
            "[-1.5, 0.0, -1.5]",
            2 * pixels + 20
        ),
    );
    let path = dir.join("three.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell/scene.toml")
}

/// Run to the end; (success, stdout + stderr).
fn finish(mut c: Command, limit: Duration) -> (bool, String) {
    let mut child = KillOnDrop(
        c.stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("mpirun starts"),
    );
    let (mut out, mut err) = (String::new(), String::new());
    let mut so = child.0.stdout.take().unwrap();
    let mut se = child.0.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut e = String::new();
        let _ = se.read_to_string(&mut e);
        e
    });
    let started = Instant::now();
    let _ = so.read_to_string(&mut out);
    let status = loop {
        if let Some(s) = child.0.try_wait().unwrap() {
            break s;
        }
        assert!(
            started.elapsed() < limit,
            "mpirun still running after {limit:?}:\n{out}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    err.push_str(&reader.join().unwrap());
    (status.success(), format!("{out}\n{err}"))
}

#[cfg_attr(not(feature = "mpi"), allow(dead_code))]
/// The cluster report's JSON: every rank presented frames 0..frames with the same poses, and
/// the poses moved (the check is not trivially true).
fn check_report(json: &Path, frames: u64) -> serde_json::Value {
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    assert_eq!(report["same_frames_and_poses"], true, "{report:#}");
    let ranks = report["per_rank"].as_array().unwrap();
    assert_eq!(ranks.len(), 3, "{report:#}");
    let shown = |r: &serde_json::Value| -> Vec<(u64, u64)> {
        (r["shown"].as_array().unwrap().iter())
            .map(|p| (p[0].as_u64().unwrap(), p[1].as_u64().unwrap()))
            .collect()
    };
    let reference = shown(&ranks[0]);
    assert!(reference.len() as u64 >= frames, "{report:#}");
    assert!(reference.iter().enumerate().all(|(i, p)| p.0 == i as u64));
    let poses: std::collections::HashSet<u64> = reference.iter().map(|p| p.1).collect();
    assert!(
        poses.len() > 1,
        "the scripted poses must differ between frames"
    );
    for r in ranks {
        assert_eq!(shown(r), reference, "rank {} differs", r["rank"]);
        assert!(r["swap_wait_ms"]["p50"].as_f64().is_some(), "{r:#}");
        assert!(!r["views"].as_array().unwrap().is_empty(), "{r:#}");
    }
    report
}

#[cfg_attr(not(feature = "mpi"), allow(dead_code))]
/// Mean row of the blue ray's pixels in column `x` of an 8-bit image.
fn ray_row(path: &Path, x: u32) -> f32 {
    let img = image::open(path).unwrap().to_rgb8();
    let rows: Vec<u32> = (0..img.height())
        .filter(|&y| {
            let p = img.get_pixel(x, y);
            p[2] > 150 && p[0] < 90 && p[1] < 90
        })
        .collect();
    assert!(
        !rows.is_empty(),
        "no ray in column {x} of {}",
        path.display()
    );
    rows.iter().sum::<u32>() as f32 / rows.len() as f32
}

#[cfg(feature = "mpi")]
#[test]
fn three_ranks_headless_present_the_same_frames_and_meet_at_the_seam() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), 160);
    let (out, json) = (dir.path().join("out"), dir.path().join("r.json"));
    let mut args = vec!["--headless", "--frames", "6", "--out"];
    args.push(out.to_str().unwrap());
    args.extend(["--json", json.to_str().unwrap()]);
    args.extend(LIGHT);
    // a scene.toml: rank 0 propagates and sends the light field to ranks 1 and 2
    let (ok, log) = finish(
        mpirun(&config, &cornell(), &args, &[]),
        Duration::from_secs(600),
    );
    assert!(ok, "{log}");
    assert!(
        log.contains("sends the light field") && log.contains("frame lock: ok"),
        "{log}"
    );
    let report = check_report(&json, 6);
    // frame times present to present, one per frame after the first, the last frame (read back
    // for the images) not counted: 4 of 6, as a series and as its statistics
    for r in report["per_rank"].as_array().unwrap() {
        let series = r["frame_ms_series"].as_array().unwrap();
        assert_eq!(series.len(), 4, "{r:#}");
        assert_eq!(r["frame_ms"]["samples"].as_u64(), Some(4), "{r:#}");
        assert!(series.iter().all(|t| t.as_f64().unwrap() > 0.0), "{r:#}");
    }
    // the ray leaves the left wall (rank 2) at its right edge where it enters the front wall
    // (rank 1) at its left edge
    let left = ray_row(&out.join("rank2/left-mono.png"), 159);
    let front = ray_row(&out.join("rank1/front-mono.png"), 0);
    assert!(
        (left - front).abs() <= 1.0,
        "seam: ray at row {left} on the left wall, {front} on the front wall"
    );
}

#[cfg(feature = "mpi")]
#[test]
fn three_ranks_in_windows_under_xvfb_present_the_same_frames() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let (_xvfb, display) = xvfb();
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), 120);
    // a .vlf on a shared path: every rank loads it itself
    let vlf = dir.path().join("cornell.vlf");
    let status = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .args([
            "propagate",
            cornell().to_str().unwrap(),
            "-o",
            vlf.to_str().unwrap(),
        ])
        .args(LIGHT)
        .status()
        .unwrap();
    assert!(status.success());
    let json = dir.path().join("w.json");
    let args = ["--frames", "8", "--json", json.to_str().unwrap()];
    let tmp = std::env::temp_dir();
    let env = [
        ("DISPLAY", display.as_str()),
        ("XDG_RUNTIME_DIR", tmp.to_str().unwrap()),
    ];
    let (ok, log) = finish(mpirun(&config, &vlf, &args, &env), Duration::from_secs(600));
    assert!(ok, "on {display}: {log}");
    assert!(!log.contains("sends the light field"), "{log}");
    let report = check_report(&json, 8);
    assert_eq!(report["mode"], "windows");
}

/// Start a long headless run; once every rank draws, send `signal` to rank 2's process; the
/// seconds until mpirun ended and everything printed.
#[cfg(feature = "mpi")]
fn lose_rank_2(signal: &str) -> (f64, String) {
    lose_rank_2_by(signal, None)
}

/// `lose_rank_2`, headless; or with `display` (Xvfb), in windows, and `action` "close" closes
/// rank 2's window (xdotool) instead of signalling it.
#[cfg(feature = "mpi")]
fn lose_rank_2_by(action: &str, display: Option<&str>) -> (f64, String) {
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), 64);
    let out = dir.path().join("out");
    let mut args = vec!["--frames", "100000", "--out", out.to_str().unwrap()];
    if display.is_none() {
        args.push("--headless");
    }
    args.extend(LIGHT);
    let log_path = dir.path().join("log");
    let log = std::fs::File::create(&log_path).unwrap();
    let tmp = std::env::temp_dir();
    let env: Vec<(&str, &str)> = match display {
        Some(d) => vec![("DISPLAY", d), ("XDG_RUNTIME_DIR", tmp.to_str().unwrap())],
        None => Vec::new(),
    };
    let mut c = mpirun(&config, &cornell(), &args, &env);
    c.stdout(log.try_clone().unwrap()).stderr(log);
    let mut child = KillOnDrop(c.spawn().expect("mpirun starts"));
    let read = || std::fs::read_to_string(&log_path).unwrap_or_default();
    let started = Instant::now();
    while !read().contains("sends the light field") {
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "did not start:\n{}",
            read()
        );
        assert!(
            child.0.try_wait().unwrap().is_none(),
            "ended early:\n{}",
            read()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    std::thread::sleep(Duration::from_secs(4)); // frames under way on every rank
    let text = read();
    let line = (text.lines())
        .find(|l| l.starts_with("vlf cluster: rank 2 of 3"))
        .expect("rank 2 says its pid");
    let pid = line
        .split("pid ")
        .nth(1)
        .unwrap()
        .split(')')
        .next()
        .unwrap();
    let t = Instant::now();
    let done = match (action, display) {
        ("close", Some(d)) => {
            let found = Command::new("xdotool")
                .args(["search", "--name", "vlf: left"])
                .env("DISPLAY", d)
                .output()
                .unwrap();
            let window = String::from_utf8_lossy(&found.stdout).trim().to_string();
            let close = ["windowclose", window.lines().next().unwrap_or("")];
            (Command::new("xdotool").args(close).env("DISPLAY", d)).status()
        }
        _ => Command::new("kill").args([action, pid]).status(),
    };
    assert!(done.unwrap().success());
    loop {
        if child.0.try_wait().unwrap().is_some() {
            break;
        }
        assert!(
            t.elapsed() < Duration::from_secs_f64(TIMEOUT_S * 3.0 + 10.0),
            "still running:\n{}",
            read()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = Command::new("kill")
        .args(["-KILL", pid])
        .stderr(Stdio::null())
        .status();
    let seconds = t.elapsed().as_secs_f64();
    eprintln!("rank 2 {action}: the run ended {seconds:.2} s later");
    (seconds, read())
}

#[cfg(feature = "mpi")]
#[test]
fn a_killed_rank_ends_the_run_naming_it() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let (seconds, log) = lose_rank_2("-KILL");
    // mpirun ends the job at once; ranks 0 and 1 say which rank was lost
    for rank in [0, 1] {
        // "lost rank 2 (...)", or with another rank gone first "lost rank 1 (...), rank 2 (...)"
        let said = log.lines().any(|l| {
            l.starts_with(&format!("vlf cluster rank {rank} "))
                && l.split_once("lost rank").is_some_and(|(_, lost)| {
                    lost.starts_with(" 2 (") || lost.contains(", rank 2 (")
                })
        });
        assert!(said, "rank {rank} did not name rank 2:\n{log}");
    }
    assert!(
        log.contains("LOST rank 2") && log.contains("cluster report"),
        "{log}"
    );
    assert!(seconds < TIMEOUT_S + 5.0, "took {seconds} s");
}

#[cfg(feature = "mpi")]
#[test]
fn a_hung_rank_is_lost_after_the_timeout() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    // stopped, rank 2 stays alive to mpirun: the frame lock's own deadline finds it
    let (seconds, log) = lose_rank_2("-STOP");
    // stopped while drawing, rank 2 misses the swap barrier; stopped before it took the next
    // frame state (the send to it never completes), it misses that: either names it, with the
    // timeout
    for rank in [0, 1] {
        let said = log.lines().any(|l| {
            l.starts_with(&format!("vlf cluster rank {rank} "))
                && (l.contains("lost rank 2: did not reach the swap barrier")
                    || l.contains("lost rank 2: took no frame state within"))
        });
        assert!(said, "rank {rank} did not name rank 2:\n{log}");
    }
    assert!(
        log.contains("LOST rank 2") && log.contains("frame lock: NOT OK"),
        "{log}"
    );
    assert!(
        (TIMEOUT_S - 1.0..TIMEOUT_S + 8.0).contains(&seconds),
        "took {seconds} s"
    );
}

#[cfg(feature = "mpi")]
#[test]
fn a_rank_losing_its_window_ends_the_run_naming_it() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    require("xdotool", "sudo apt-get install xdotool");
    let (_xvfb, display) = xvfb();
    let (seconds, log) = lose_rank_2_by("close", Some(&display));
    for rank in [0, 1] {
        let said = log.lines().any(|l| {
            l.starts_with(&format!("vlf cluster rank {rank} ")) && l.contains("lost rank 2")
        });
        assert!(said, "rank {rank} did not name rank 2:\n{log}");
    }
    assert!(
        log.contains("LOST rank 2") && log.contains("cluster report"),
        "{log}"
    );
    assert!(seconds < TIMEOUT_S + 8.0, "took {seconds} s");
}

/// Without the `mpi` feature the cluster tests cannot run: fail, saying how to run them.
#[cfg(not(feature = "mpi"))]
#[test]
fn cluster_tests_need_the_mpi_feature() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    // what a build without MPI says under mpirun
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), 64);
    let (ok, log) = finish(
        mpirun(&config, &cornell(), &["--headless"], &[]),
        Duration::from_secs(120),
    );
    assert!(
        !ok && log.contains("built without MPI") && log.contains("--features mpi"),
        "{log}"
    );
    panic!("the cluster tests need a build with MPI: cargo test --release --features mpi (bash tools/test.sh passes it; Open MPI: sudo apt-get install libopenmpi-dev openmpi-bin libclang-dev)");
}

/// A virtual X display (as tests/windows.rs): the server and its name.
#[cfg(feature = "mpi")]
fn xvfb() -> (KillOnDrop, String) {
    require("Xvfb", "sudo apt-get install xvfb");
    // a new number each call: a killed server leaves its socket and lock behind
    static CALLS: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let call = CALLS.fetch_add(20, std::sync::atomic::Ordering::Relaxed);
    for n in 0..20 {
        let number = 500 + (std::process::id() + call + n) % 400;
        if Path::new(&format!("/tmp/.X11-unix/X{number}")).exists()
            || Path::new(&format!("/tmp/.X{number}-lock")).exists()
        {
            continue;
        }
        let display = format!(":{number}");
        let child = Command::new("Xvfb")
            .args([
                display.as_str(),
                "-screen",
                "0",
                "800x400x24",
                "-nolisten",
                "tcp",
                // three ranks connect at once: a server reset between two would refuse one
                "-noreset",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb starts");
        let mut guard = KillOnDrop(child);
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            // ours, still running (not another server's socket, ours refused as "in use")
            if Path::new(&format!("/tmp/.X11-unix/X{number}")).exists() {
                std::thread::sleep(Duration::from_millis(300));
                if guard.0.try_wait().unwrap().is_none() {
                    return (guard, display);
                }
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    panic!("Xvfb did not start");
}

/// The three-rank display configuration `text` with its first `from` replaced by `to`, parsed.
fn parse_changed(text: &str, from: &str, to: &str) -> vlf::Result<vlf::display::DisplayConfig> {
    let changed = text.replacen(from, to, 1);
    assert_ne!(changed, text, "{from}");
    vlf::display::DisplayConfig::parse(&changed, Path::new("three.toml"))
}

/// Bad `[cluster]` settings are refused naming the key (no mpirun needed).
#[test]
fn cluster_config_errors_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(write_config(dir.path(), 64)).unwrap();
    let parse = |from: &str, to: &str| parse_changed(&text, from, to);
    let err = |from: &str, to: &str| parse(from, to).unwrap_err().to_string();
    let e = err(r#"walls = ["left"]"#, r#"walls = ["back"]"#);
    assert!(
        e.contains("cluster.node[2].walls") && e.contains("no wall named \"back\""),
        "{e}"
    );
    let e = err(r#"walls = ["left"]"#, r#"walls = ["left:left"]"#);
    assert!(
        e.contains("cluster.node[2].walls") && e.contains("separate"),
        "{e}"
    );
    let e = err(r#"walls = ["left"]"#, r#"walls = ["front"]"#);
    assert!(e.contains("already drawn by another node"), "{e}");
    let e = err("rank = 2\n", "rank = 2\nhost = \"x\"\n");
    assert!(
        e.contains("cluster.node[2]") && e.contains("either rank"),
        "{e}"
    );
    let e = err("timeout_s = 5", "timeout_s = -1");
    assert!(e.contains("cluster.timeout_s"), "{e}");
    let e = err("[[cluster.node]]\nrank = 0\nwalls = [\"floor\"]\n", "");
    assert!(
        e.contains("wall \"floor\"") && e.contains("drawn by no node"),
        "{e}"
    );
    // ranks and hosts are checked against the run
    let config = vlf::display::DisplayConfig::parse(&text, Path::new("three.toml")).unwrap();
    let cluster = config.cluster.clone().unwrap();
    let hosts = |n: usize| vec!["a".to_string(); n];
    let e = cluster.assign(&config, &hosts(2)).unwrap_err();
    assert!(
        e.contains("cluster.node[2].rank") && e.contains("-np 2"),
        "{e}"
    );
    assert_eq!(
        cluster.assign(&config, &hosts(3)).unwrap()[1],
        vec![(0, None)]
    );
    let by_host = parse("rank = 1\n", "host = \"b\"\n").unwrap();
    let e = (by_host.cluster.clone().unwrap())
        .assign(&by_host, &hosts(3))
        .unwrap_err();
    assert!(
        e.contains("cluster.node[1].host") && e.contains("no rank left on host \"b\""),
        "{e}"
    );
    // no nodes: the walls split in order
    let plain = parse("[[cluster.node]]", "[[unused]]");
    assert!(plain.is_err()); // unknown keys are refused
    let mut none = config.clone();
    none.cluster.as_mut().unwrap().nodes.clear();
    let plan = none
        .cluster
        .clone()
        .unwrap()
        .assign(&none, &hosts(2))
        .unwrap();
    assert_eq!(plan, vec![vec![(0, None), (1, None)], vec![(2, None)]]);
}

/// `[cluster] gpu`: which GPU each rank opens, from the ranks' hosts (no mpirun needed).
#[test]
fn each_rank_on_a_host_takes_its_own_gpu() {
    use vlf::gpu::AdapterChoice::{Default as Best, Gpu};
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(write_config(dir.path(), 64)).unwrap();
    let parse = |from: &str, to: &str| parse_changed(&text, from, to);
    let hosts: Vec<String> = ["a", "b", "a"].iter().map(|h| h.to_string()).collect();
    // the default, "local-rank": the n-th rank on a host takes the host's n-th GPU
    let config = vlf::display::DisplayConfig::parse(&text, Path::new("three.toml")).unwrap();
    let gpus = config.cluster.clone().unwrap().gpus(&hosts).unwrap();
    let on = |index| Gpu { index, wrap: true };
    assert_eq!(gpus, vec![on(0), on(0), on(1)]);
    // "default": every rank the best adapter (or VLF_GPU's)
    let same = parse("[cluster]\n", "[cluster]\ngpu = \"default\"\n").unwrap();
    assert_eq!(same.cluster.unwrap().gpus(&hosts).unwrap(), vec![Best; 3]);
    // a node's own gpu comes first, and is not wrapped round
    let own = parse("rank = 1\n", "rank = 1\ngpu = 3\n").unwrap();
    let gpus = own.cluster.unwrap().gpus(&hosts).unwrap();
    assert_eq!(
        gpus[1],
        Gpu {
            index: 3,
            wrap: false
        }
    );
    assert_eq!(gpus[0], on(0));
    // a wrong value names the key
    let e = parse("[cluster]\n", "[cluster]\ngpu = \"each\"\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("gpu") && e.contains("local-rank"), "{e}");
}

/// The state rank 0 broadcasts, as bytes and back (as `cluster::with_mpi` sends it): the head,
/// the navigation, the wand and the left hand arrive as sent, an untracked hand stays
/// untracked, and the digest the ranks compare tells a moved left hand apart.
#[test]
fn the_broadcast_frame_state_carries_the_wand_the_left_hand_and_the_targets() {
    use glam::{Quat, Vec3};
    use vlf::framelock::FrameState;
    use vlf::tracking::{HeldPoses, Pose, WandPose, MAX_TARGETS};
    assert_eq!(std::mem::size_of::<FrameState>(), 368);
    let pose = Pose {
        head: Vec3::new(0.1, 1.7, -0.2),
        head_rotation: Quat::from_rotation_y(0.4),
        room_position: Vec3::new(1.0, 0.0, 2.0),
        room_yaw_deg: 30.0,
    };
    let hand = |x: f32| WandPose {
        position: Vec3::new(x, 1.2, -0.4),
        rotation: Quat::from_rotation_x(0.3),
    };
    // targets 0 and the last seen, the others not (yet)
    let mut targets = [None; MAX_TARGETS];
    targets[0] = Some(hand(0.9));
    targets[MAX_TARGETS - 1] = Some(hand(-0.9));
    let held = HeldPoses {
        wand: Some(hand(0.3)),
        left_hand: Some(hand(-0.3)),
        targets,
    };
    let through_bytes =
        |s: FrameState| -> FrameState { bytemuck::pod_read_unaligned(bytemuck::bytes_of(&s)) };
    let state = through_bytes(FrameState::new(7, &pose, held, 1.5));
    assert_eq!(
        (state.frame, state.pose(), state.held(), state.exposure),
        (7, pose, held, 1.5)
    );
    assert!(!state.is_quit());
    for only in [
        HeldPoses {
            left_hand: None,
            ..held
        },
        HeldPoses { wand: None, ..held },
        HeldPoses {
            targets: [None; MAX_TARGETS],
            ..held
        },
        HeldPoses::default(),
    ] {
        assert_eq!(
            through_bytes(FrameState::new(8, &pose, only, 1.0)).held(),
            only
        );
    }
    let moved = HeldPoses {
        left_hand: Some(hand(-0.31)),
        ..held
    };
    assert_ne!(
        FrameState::new(7, &pose, held, 1.5).pose_digest(),
        FrameState::new(7, &pose, moved, 1.5).pose_digest()
    );
    let mut chair_moved = held;
    chair_moved.targets[MAX_TARGETS - 1] = Some(hand(-0.91));
    assert_ne!(
        FrameState::new(7, &pose, held, 1.5).pose_digest(),
        FrameState::new(7, &pose, chair_moved, 1.5).pose_digest()
    );
    assert!(through_bytes(FrameState::quit(9)).is_quit());
}

/// The mean radiance (r + g + b) of an EXR image.
#[cfg(feature = "mpi")]
fn mean_radiance(path: &Path) -> f64 {
    let image = vlf::render::image_io::read_exr(path).unwrap();
    let sum: f64 = (image.pixels.iter())
        .map(|p| (p[0] + p[1] + p[2]) as f64)
        .sum();
    sum / image.pixels.len() as f64
}

/// A study on the cluster: rank 0 takes the shipped conditions example's commands
/// (tools/study/conditions_example.py: state, gi-off, a refused name, state, stop) and every
/// rank switches in the same frame and stops with it. Each rank logs its own views
/// (`--log DIR`: DIR/rank<k>), gi-on before the switch's frame and gi-off from it on (rank 0's
/// log with the switch as an event); every rank's last frame (gi-off) replays pixel-identical
/// from that rank's log, and on the floor and the front wall the frame before the switch
/// (gi-on) is brighter (measured on lavapipe: 0.75 and 0.79 of it with direct light only).
#[cfg(feature = "mpi")]
#[test]
fn a_script_switches_every_ranks_condition_in_the_same_frame() {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), 48);
    let text = std::fs::read_to_string(&config).unwrap().replacen(
        "name = \"three\"\n",
        "name = \"three\"\ndefault_condition = \"gi-on\"\n",
        1,
    );
    let conditions = "[[condition]]\nname = \"gi-off\"\nglobal_illumination = false\n\
                      exposure = 1.5\n[[condition]]\nname = \"gi-on\"\n";
    std::fs::write(&config, text + conditions).unwrap();
    let (out, log, json) = (
        dir.path().join("out"),
        dir.path().join("log"),
        dir.path().join("r.json"),
    );
    let mut args = vec!["--headless", "--exr", "--frames", "100000", "--out"];
    args.push(out.to_str().unwrap());
    args.extend([
        "--log",
        log.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    args.extend(["--control", "127.0.0.1:0"]);
    args.extend(LIGHT);
    let mut c = mpirun(&config, &cornell(), &args, &[]);
    let mut child = c
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mpirun starts");
    let addr = control_address(&mut child);
    let replies = script_replies("tools/study/conditions_example.py", &addr, &mut child);
    assert_eq!(replies.len(), 5, "{replies:?}");
    assert_eq!(replies[0]["condition"], "gi-on");
    assert_eq!(replies[1]["ok"], true, "{replies:?}");
    let switched = replies[1]["frame"].as_u64().unwrap();
    assert_eq!(replies[3]["condition"], "gi-off");
    let last = replies[4]["frame"].as_u64().unwrap();
    // every rank drew the same frames with the same state (the digest covers the study's)
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["same_frames_and_poses"], true, "{report:#}");
    for (rank, view) in [(0, "floor-mono"), (1, "front-mono"), (2, "left-mono")] {
        let rank_log = log.join(format!("rank{rank}"));
        let (meta, records) = vlf::study::SessionLog::read(&rank_log).unwrap();
        assert_eq!(meta.views, [view], "rank {rank} logs its own view");
        assert_eq!(
            records.last().unwrap().frame,
            last,
            "rank {rank} stops with rank 0"
        );
        for r in &records {
            let expect = if r.frame >= switched {
                "gi-off"
            } else {
                "gi-on"
            };
            assert_eq!(r.condition, expect, "rank {rank}, frame {}", r.frame);
        }
        let at_switch = records.iter().find(|r| r.frame == switched).unwrap();
        assert_eq!(
            at_switch.events.contains("condition gi-off"),
            rank == 0,
            "the script's commands are rank 0's events"
        );
        let again = dir.path().join(format!("again{rank}"));
        let status = Command::new(env!("CARGO_BIN_EXE_vlf"))
            .args(["replay", rank_log.to_str().unwrap(), "--exr", "--out"])
            .arg(&again)
            .args(["--frames", &format!("{}..={last}", switched - 1)])
            .stderr(Stdio::null())
            .status()
            .unwrap();
        assert!(status.success(), "vlf replay of rank {rank}'s log");
        let live = out.join(format!("rank{rank}/{view}.exr"));
        let replayed = again.join(format!("frame-{last:06}/{view}.exr"));
        let (a, b) = (
            vlf::render::image_io::read_exr(&live).unwrap(),
            vlf::render::image_io::read_exr(&replayed).unwrap(),
        );
        assert!(
            a.pixels == b.pixels,
            "rank {rank}: the replay differs from what it drew"
        );
        let before = again.join(format!("frame-{:06}/{view}.exr", switched - 1));
        let (on, off) = (mean_radiance(&before), mean_radiance(&replayed));
        eprintln!("rank {rank} ({view}): mean radiance {on:.4} with global illumination, {off:.4} with direct light only");
        // the left wall looks away from the box (only the wand ray shows there)
        if rank != 2 {
            assert!(off < 0.85 * on, "rank {rank}: gi-on {on}, gi-off {off}");
        }
    }
}
