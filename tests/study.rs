//! The session log and exact replay (`vlf cave --headless --log DIR`, `vlf replay DIR`): a short
//! paced CAVE walk on the software adapter, logged, then drawn again from the log; the replayed
//! last frame is pixel-identical to the images the live run read back.

use crate::common;

use common::{control_address, draft_params, gpu, repo_path, script_replies};
use std::process::Command;
use vlf::display::DisplayConfig;
use vlf::progress::Silent;
use vlf::study::log::{Drawn, LOG_FORMAT};
use vlf::study::{SessionLog, SessionMeta};

/// The shipped walking CAVE at 96x60 per eye, paced against a 1 Hz refresh (so the pacer gives
/// views different eye rays per pixel frame by frame), its walk by absolute path.
fn walking_cave(dir: &std::path::Path) -> std::path::PathBuf {
    let walk = repo_path("config/paths/cornell-walk.toml");
    let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall-walk.toml"))
        .unwrap()
        .replace("pixels = [1920, 1200]", "pixels = [96, 60]")
        .replace("refresh_hz = 120", "refresh_hz = 1")
        .replace(
            "path = \"../paths/cornell-walk.toml\"",
            &format!("path = {:?}", walk.display().to_string()),
        );
    let path = dir.join("cave.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// A draft Cornell light field saved in `dir`, and `vlf cave --headless` on the walking CAVE
/// (`walking_cave`) drawing it for up to 100000 frames with a session log in `dir/log`.
fn long_headless_run(dir: &std::path::Path) -> Command {
    let config = walking_cave(dir);
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    let vlf_path = dir.join("cornell.vlf");
    vlf::lightfield::file::save(&lf, &vlf_path).unwrap();
    let mut cave = Command::new(env!("CARGO_BIN_EXE_vlf"));
    cave.args([
        "cave",
        config.to_str().unwrap(),
        "--headless",
        "--frames",
        "100000",
    ])
    .arg("--scene")
    .arg(&vlf_path)
    .arg("--log")
    .arg(dir.join("log"))
    .arg("--out")
    .arg(dir.join("out"))
    .stdout(std::process::Stdio::null());
    cave
}

/// `tools/study/parquet_check.py`: the log's frames.parquet read with pyarrow equals its
/// frames.csv row for row (a prefix of it after a SIGKILL); its counts.
fn parquet_matches_csv(log_dir: &std::path::Path) -> serde_json::Value {
    let out = Command::new("python3")
        .arg(repo_path("tools/study/parquet_check.py"))
        .arg(log_dir)
        .output()
        .unwrap_or_else(|e| panic!("python3 runs parquet_check.py ({e}); install Python 3 and pyarrow (bash tools/setup.sh test)"));
    assert!(
        out.status.success(),
        "frames.parquet against frames.csv (pyarrow missing? `bash tools/setup.sh test` installs it):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn same_pixels(a: &std::path::Path, b: &std::path::Path) {
    let (x, y) = (
        vlf::render::image_io::read_exr(a).unwrap(),
        vlf::render::image_io::read_exr(b).unwrap(),
    );
    assert_eq!((x.width, x.height), (y.width, y.height));
    let differ = x
        .pixels
        .iter()
        .zip(&y.pixels)
        .filter(|(p, q)| p != q)
        .count();
    assert_eq!(
        differ,
        0,
        "{} and {}: {differ} pixels differ",
        a.display(),
        b.display()
    );
}

/// A draft Cornell light field saved in `dir`, and `frames` frames of the display at `config`
/// drawn headless from it with a session log in `dir/log` and the last frame's images (EXR too)
/// in `dir/live`: the light field, and the log read back.
fn logged_cornell_run(
    dir: &std::path::Path,
    config: &std::path::Path,
    frames: u32,
) -> (
    vlf::lightfield::LightField,
    vlf::lightfield::ResidentLightField,
    SessionMeta,
    Vec<vlf::study::FrameRecord>,
) {
    logged_cornell_run_with(dir, config, frames, None)
}

/// `logged_cornell_run`, with `control` (a script's commands over TCP) and then every frame read
/// back into `dir/live/frame-<n>/`.
fn logged_cornell_run_with(
    dir: &std::path::Path,
    config: &std::path::Path,
    frames: u32,
    control: Option<&vlf::study::ControlServer>,
) -> (
    vlf::lightfield::LightField,
    vlf::lightfield::ResidentLightField,
    SessionMeta,
    Vec<vlf::study::FrameRecord>,
) {
    let display = DisplayConfig::load(config).unwrap();
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let (lf, resident, _) =
        vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    let vlf_path = dir.join("cornell.vlf");
    vlf::lightfield::file::save(&lf, &vlf_path).unwrap();
    let views: Vec<String> = (vlf::display::frame::wall_views(&display).iter())
        .map(|v| v.name(&display))
        .collect();
    let meta = SessionMeta {
        format: LOG_FORMAT,
        vlf_version: "test".into(),
        display_config: config.to_path_buf(),
        light_field: vlf_path,
        propagation: None,
        scene_hash: lf.meta.scene_hash.clone(),
        adapter: gpu().summary.name.clone(),
        started_unix_s: 0.0,
        views,
        columns: Vec::new(),
        headset: None,
        headset_setup: None,
        targets: display.tracking.target_names(),
    };
    let log_dir = dir.join("log");
    // the display's conditions, where it has any, made beside the Cornell box
    let main = vlf::display::conditions::MainField {
        source: &meta.light_field,
        lf: &lf,
        resident: &resident,
    };
    let conditions =
        vlf::display::conditions::Conditions::prepare(&display, config, main, &Silent).unwrap();
    {
        let mut log = SessionLog::create(&log_dir, meta).unwrap();
        let run = vlf::display::headless::HeadlessRun {
            frames,
            out: &dir.join("live"),
            exr: true,
            log: Some(&mut log),
            control,
            lsl: None,
            conditions: conditions.as_ref(),
            read_back_every_frame: control.is_some(),
        };
        vlf::display::headless::run_reporting(&lf, &resident, &display, config, run, &Silent)
            .unwrap();
    }
    let (meta, records) = SessionLog::read(&log_dir).unwrap();
    (lf, resident, meta, records)
}

#[test]
fn a_logged_session_replays_pixel_identical() {
    let dir = tempfile::tempdir().unwrap();
    let config = walking_cave(dir.path());
    let (_, _, meta, records) = logged_cornell_run(dir.path(), &config, 4);
    let (log_dir, live) = (dir.path().join("log"), dir.path().join("live"));
    assert_eq!(records.len(), 4);
    // closed cleanly: the Parquet has every row
    assert_eq!(parquet_matches_csv(&log_dir)["parquet_rows"], 4);
    assert!(records[..3]
        .iter()
        .all(|r| r.drawn == Drawn::Timed && r.cpu_ms.is_some()));
    assert_eq!(records[3].drawn, Drawn::ReadBack);
    assert!(records.iter().all(|r| r.views.len() == 8));
    // the walk moves the head from frame to frame
    assert_ne!(records[0].pose, records[3].pose);

    // the library's replay of the last frame, from the log alone
    let (lf2, resident2) = {
        let lf = vlf::lightfield::file::load(&meta.light_field).unwrap();
        let resident = lf.upload(gpu()).unwrap();
        (lf, resident)
    };
    let again = dir.path().join("again");
    let folders = vlf::display::replay::replay(
        (&lf2, &resident2),
        &meta,
        &records[3..],
        (&again, true),
        &Silent,
    )
    .unwrap();
    assert_eq!(folders, [again.join("frame-000003")]);
    for view in &meta.views {
        same_pixels(
            &live.join(format!("{view}.exr")),
            &folders[0].join(format!("{view}.exr")),
        );
    }

    // and the command line's: every frame, one folder each, the last one the same again
    let cli_out = dir.path().join("cli");
    let status = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .args(["replay", log_dir.to_str().unwrap(), "--exr", "--out"])
        .arg(&cli_out)
        .status()
        .unwrap();
    assert!(status.success());
    for f in 0..4 {
        assert!(cli_out
            .join(format!("frame-00000{f}/front-left.png"))
            .exists());
    }
    same_pixels(
        &live.join("front-left.exr"),
        &cli_out.join("frame-000003/front-left.exr"),
    );
    // a bad range is refused, naming it
    let bad = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .args(["replay", log_dir.to_str().unwrap(), "--frames", "9..12"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("no logged frame"));
}

#[test]
fn a_session_log_survives_sigkill() {
    let dir = tempfile::tempdir().unwrap();
    let log_dir = dir.path().join("log");
    let mut child = long_headless_run(dir.path())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // wait for rows on the disk (flushed at least once a second), then kill without warning
    let csv = log_dir.join("frames.csv");
    let began = std::time::Instant::now();
    while std::fs::read_to_string(&csv).map_or(0, |t| t.lines().count()) < 4 {
        assert!(began.elapsed().as_secs() < 120, "no rows after 2 minutes");
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    std::thread::sleep(std::time::Duration::from_millis(700));
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let (meta, records) = SessionLog::read(&log_dir).unwrap();
    assert_eq!(meta.views.len(), 8);
    assert!(records.len() >= 3, "{} rows", records.len());
    assert!((records.iter().enumerate()).all(|(i, r)| r.frame == i as u64));
    // every Parquet part closed before the kill reads back, equal to the CSV's rows
    let parquet = parquet_matches_csv(&log_dir);
    assert!(parquet["parquet_rows"].as_u64().unwrap() >= 1, "{parquet}");
}

/// The shipped Python example drives a headless run over `--control`: every command is
/// acknowledged with the frame it took effect in, a bad one is refused and changes nothing,
/// `teleport` moves the room from its frame on (in the log too), `stop` ends the run.
#[test]
fn an_experiment_script_controls_a_run_and_every_command_is_acknowledged() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let log_dir = dir.path().join("log");
    let report = dir.path().join("report.json");
    let mut child = long_headless_run(dir.path())
        .args(["--control", "127.0.0.1:0"])
        .arg("--json")
        .arg(&report)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut addr = String::new();
    let mut line = String::new();
    while stderr.read_line(&mut line).unwrap() > 0 {
        if let Some(a) = line.strip_prefix("control: listening on ") {
            addr = a.trim().to_string();
            break;
        }
        line.clear();
    }
    assert!(!addr.is_empty(), "vlf cave never said where it listens");
    // the rest of stderr drained, so the run never blocks on it
    std::thread::spawn(move || for _ in stderr.lines() {});
    let replies = script_replies("tools/study/control_example.py", &addr, &mut child);
    // state, trial, event, teleport, a refused command, state, event, stop
    assert_eq!(replies.len(), 8);
    let frame = |i: usize| replies[i]["frame"].as_u64().unwrap();
    assert!(
        replies.iter().enumerate().all(|(i, r)| r["ok"] == (i != 4)),
        "{replies:?}"
    );
    assert!(replies[4]["error"].as_str().unwrap().contains("fly"));
    let answered: Vec<u64> = [0, 1, 2, 3, 5, 6, 7].map(frame).to_vec();
    assert!(answered.windows(2).all(|w| w[0] <= w[1]), "{answered:?}");
    assert_eq!(replies[5]["room"], serde_json::json!([0.5, 0.0, 0.25]));
    assert_eq!(replies[5]["room_yaw_deg"], serde_json::json!(30.0));
    // the log: the events in the rows of their frames, the trial from its frame on, the room
    // moved from the teleport on, and every timed frame's pose age at submission
    let (_, records) = SessionLog::read(&log_dir).unwrap();
    let parquet = parquet_matches_csv(&log_dir);
    assert_eq!(parquet["parquet_rows"], records.len(), "{parquet}");
    let last = records.last().unwrap();
    assert_eq!((last.frame, last.drawn), (frame(7), Drawn::ReadBack));
    let at = |f: u64| records.iter().find(|r| r.frame == f).unwrap();
    assert!(at(frame(2)).events.contains("trial 1 begins"));
    assert!(records
        .iter()
        .all(|r| (r.block, r.trial) == if r.frame >= frame(1) { (1, 1) } else { (0, 0) }));
    let teleported = frame(3);
    assert!(records.iter().all(
        |r| (r.pose.room_position == glam::Vec3::new(0.5, 0.0, 0.25)) == (r.frame >= teleported)
    ));
    assert!((records.iter().filter(|r| r.drawn == Drawn::Timed))
        .all(|r| r.pose_to_submit_ms.is_some_and(|ms| ms >= 0.0)));
    // motion to photon: the predicted photons a refresh period (1 s here) after the GPU's end,
    // in every timed row and, as p50/p99, in the report
    assert!((records.iter().filter(|r| r.drawn == Drawn::Timed))
        .all(|r| r.pose_to_photon_ms.unwrap() >= r.pose_to_submit_ms.unwrap() + 1000.0));
    assert_eq!(last.pose_to_photon_ms, None);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let m = &report["motion_to_photon"];
    let timed = records.iter().filter(|r| r.drawn == Drawn::Timed).count();
    assert_eq!(m["pose_to_photon_ms"]["samples"], timed, "{m}");
    assert_eq!(m["refresh_ms"], 1000.0);
    let p50 = |k: &str| m[k]["median"].as_f64().unwrap();
    assert!(
        p50("pose_to_photon_ms") >= p50("pose_to_submit_ms") + 1000.0,
        "{m}"
    );
    assert!(m["pose_to_photon_ms"]["p99"].as_f64().unwrap() >= p50("pose_to_photon_ms"));
}

/// A one-wall display of 64x36 pixels at 10 Hz walking a scripted path with a wand, in `dir`,
/// and the liblsl configuration that keeps LSL's traffic on this machine (`lsl_api.cfg`).
fn small_lsl_display(dir: &std::path::Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let walk = dir.join("walk.toml");
    let key = |t: f32, head: [f32; 3], pos: [f32; 3], wand: ([f32; 3], f32, f32)| {
        format!(
            "[[keyframe]]\nt = {t:?}\nhead = {head:?}\nposition = {pos:?}\nyaw_deg = {:?}\n\
             wand_position = {:?}\nwand_yaw_deg = {:?}\nwand_pitch_deg = {:?}\n",
            t * 6.0,
            wand.0,
            wand.1,
            wand.2
        )
    };
    let text = key(
        0.0,
        [0.0, 1.2, 0.3],
        [0.0, 0.0, 2.2],
        ([0.25, 1.0, 0.0], 25.0, 12.0),
    ) + &key(
        4.0,
        [0.1, 1.1, 0.2],
        [0.2, -0.1, 0.5],
        ([0.3, 1.1, -0.1], 5.0, -10.0),
    );
    std::fs::write(&walk, text).unwrap();
    let config = dir.join("small.toml");
    std::fs::write(
        &config,
        format!(
            "name = \"lsl-test\"\nrefresh_hz = 10\n[start_pose]\nposition = [0.0, 0.0, 2.2]\n\
             [tracking]\nsource = \"scripted\"\npath = {:?}\n[[wall]]\nname = \"front\"\n\
             lower_left = [-0.3, 1.13, 0.0]\nlower_right = [0.3, 1.13, 0.0]\n\
             upper_left = [-0.3, 1.47, 0.0]\npixels = [64, 36]\n\
             output = {{ monitor = 0, window = [100, 100] }}\n",
            walk.display().to_string()
        ),
    )
    .unwrap();
    // machine scope: liblsl resolves streams on 127.0.0.1 only, and no IPv6
    let cfg = dir.join("lsl_api.cfg");
    std::fs::write(
        &cfg,
        "[ports]\nIPv6 = disable\n[multicast]\nResolveScope = machine\n",
    )
    .unwrap();
    (config, cfg)
}

/// `vlf cave --headless --lsl`: the shipped pylsl example (tools/study/lsl_example.py) reads
/// vlf.pose, vlf.frames and vlf.events while it sends an event, a trial and stop over
/// `--control`; the streams declare the display's rate and carry it, their timestamps rise
/// inside the run's LSL clock window, every pose sample is the session log's row of its frame
/// bit for bit, and the commands and their replies are markers at their frames' display times.
#[test]
fn lsl_outlets_carry_every_frame_as_the_session_log_has_it() {
    let dir = tempfile::tempdir().unwrap();
    let (config, lsl_cfg) = small_lsl_display(dir.path());
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    let vlf_path = dir.path().join("cornell.vlf");
    vlf::lightfield::file::save(&lf, &vlf_path).unwrap();
    let log_dir = dir.path().join("log");
    let mut child = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("cave")
        .arg(&config)
        .args(["--headless", "--lsl", "--frames", "100000"])
        .args(["--control", "127.0.0.1:0", "--scene"])
        .arg(&vlf_path)
        .arg("--log")
        .arg(&log_dir)
        .arg("--out")
        .arg(dir.path().join("out"))
        .env("LSLAPICFG", &lsl_cfg)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let addr = control_address(&mut child);
    let out = Command::new("python3")
        .arg(repo_path("tools/study/lsl_example.py"))
        .args([&addr, "4"])
        .env("LSLAPICFG", &lsl_cfg)
        .output()
        .unwrap_or_else(|e| panic!("python3 runs the LSL example ({e}); install Python 3 and pylsl (bash tools/setup.sh test)"));
    if !out.status.success() {
        let _ = child.kill();
        panic!(
            "tools/study/lsl_example.py failed (pylsl missing? `bash tools/setup.sh test` installs it):\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let run = child.wait_with_output().unwrap();
    assert!(run.status.success(), "stop ends the run cleanly");
    // the report's summary: motion to photon at the 10 Hz display's prediction
    let summary = String::from_utf8_lossy(&run.stdout);
    assert!(
        summary.contains("motion to photon (")
            && summary.contains("predicted: GPU end + one refresh, 100.000 ms"),
        "{summary}"
    );
    let got: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (_, records) = SessionLog::read(&log_dir).unwrap();
    check_lsl_streams(&got, &records);
}

/// What `lsl_example.py` read (`got`) against the session log's rows.
fn check_lsl_streams(got: &serde_json::Value, records: &[vlf::study::FrameRecord]) {
    use vlf::study::lsl::{FRAME_CHANNELS, POSE_CHANNELS};
    let stream = |name: &str| &got["streams"][name];
    let samples = |name: &str| -> Vec<(f64, Vec<serde_json::Value>)> {
        (stream(name)["samples"].as_array().unwrap().iter())
            .map(|s| (s[0].as_f64().unwrap(), s[1].as_array().unwrap().clone()))
            .collect()
    };
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let (began, ended) = (
        got["clock"][0].as_f64().unwrap(),
        got["clock"][1].as_f64().unwrap(),
    );
    let labels = |n: &str| serde_json::json!(n);
    assert_eq!(stream("vlf.pose")["rate"], 10.0);
    assert_eq!(stream("vlf.frames")["rate"], 10.0);
    assert_eq!(stream("vlf.events")["rate"], 0.0);
    let pose_labels: Vec<_> = POSE_CHANNELS.iter().map(|c| labels(c.0)).collect();
    assert_eq!(stream("vlf.pose")["labels"], serde_json::json!(pose_labels));
    let frame_labels: Vec<_> = FRAME_CHANNELS.iter().map(|c| labels(c.0)).collect();
    assert_eq!(
        stream("vlf.frames")["labels"],
        serde_json::json!(frame_labels)
    );

    let poses = samples("vlf.pose");
    assert!(
        poses.len() >= 25,
        "{} pose samples in 4 s at 10 Hz",
        poses.len()
    );
    assert!(
        poses.windows(2).all(|w| w[0].0 < w[1].0),
        "pose timestamps rise"
    );
    // stamped in the reader's clock: before it ended, and not before its inlets' buffer (60 s)
    // reaches back (on a loaded machine the run may push its first frames before the reader
    // begins; the inlet still hands them over)
    assert!(poses.iter().all(|p| p.0 > began - 60.0 && p.0 < ended));
    let span = poses.last().unwrap().0 - poses[0].0;
    let rate = (poses.len() - 1) as f64 / span;
    assert!(
        (rate - 10.0).abs() < 1.0,
        "pose stream at {rate:.2} Hz, declared 10"
    );
    let at = |f: u64| records.iter().find(|r| r.frame == f).unwrap();
    let mut worst_clock_error = 0.0f64;
    for (i, (t, v)) in poses.iter().enumerate() {
        let r = at(num(&v[19]) as u64);
        let (h, q, room) = (r.pose.head, r.pose.head_rotation, r.pose.room_position);
        let w = r.wand.expect("the walk has a wand");
        let expect = [
            h.x,
            h.y,
            h.z,
            q.x,
            q.y,
            q.z,
            q.w,
            w.position.x,
            w.position.y,
            w.position.z,
            w.rotation.x,
            w.rotation.y,
            w.rotation.z,
            w.rotation.w,
            room.x,
            room.y,
            room.z,
            r.pose.room_yaw_deg,
        ];
        let sent: Vec<f32> = v[..18].iter().map(|x| num(x) as f32).collect();
        assert_eq!(
            sent, expect,
            "frame {}: pose sample against frames.csv",
            r.frame
        );
        // the pose's age at the photons: a refresh period (100 ms) after the GPU's end
        let photon = num(&v[18]);
        // the same on the stream and in the log; a refresh period (100 ms) after the GPU's end
        match r.pose_to_photon_ms {
            Some(ms) => assert!(photon as f32 == ms as f32 && (100.0..1000.0).contains(&photon)),
            None => assert!(photon.is_nan() && r.drawn == vlf::study::log::Drawn::ReadBack),
        }
        // LSL's clock against the session log's: the same steps between frames
        if i > 0 {
            let r0 = at(num(&poses[i - 1].1[19]) as u64);
            let error = ((t - poses[i - 1].0) - (r.time_s - r0.time_s)).abs();
            worst_clock_error = worst_clock_error.max(error);
        }
    }
    eprintln!("LSL pose stream: {} samples, {rate:.3} Hz (declared 10), steps against the session log's within {:.3} ms", poses.len(), worst_clock_error * 1e3);
    assert!(worst_clock_error < 0.005, "{worst_clock_error} s");

    let frames = samples("vlf.frames");
    let mut shown_at = std::collections::BTreeMap::new();
    for (t, v) in &frames {
        let r = at(num(&v[0]) as u64);
        assert_eq!(num(&v[2]).is_nan(), r.gpu_ms.is_none());
        if let (Some(gpu), Some(cpu)) = (r.gpu_ms, r.cpu_ms) {
            assert_eq!((num(&v[1]), num(&v[2]), num(&v[3])), (*t, gpu, cpu));
            assert_eq!(num(&v[4]), if cpu > 100.0 { 1.0 } else { 0.0 });
        }
        shown_at.insert(r.frame, *t);
    }
    assert!(frames
        .windows(2)
        .all(|w| w[0].0 < w[1].0 && num(&w[0].1[0]) + 1.0 == num(&w[1].1[0])));

    // the markers: the script's event at the display time of the frame that acknowledged it
    let replies = got["replies"].as_array().unwrap();
    let events = samples("vlf.events");
    let text = |e: &(f64, Vec<serde_json::Value>)| e.1[0].as_str().unwrap().to_string();
    let event_frame = replies[0]["frame"].as_u64().unwrap();
    let marker = events
        .iter()
        .find(|e| text(e) == "lsl check: stimulus on")
        .expect("the event on vlf.events");
    assert_eq!(Some(&marker.0), shown_at.get(&event_frame));
    assert!(events.iter().any(|e| text(e) == "block 2 trial 5"));
    let commands: Vec<serde_json::Value> = (events.iter())
        .filter_map(|e| serde_json::from_str::<serde_json::Value>(&text(e)).ok())
        .collect();
    assert_eq!(commands.len(), 3, "{commands:?}");
    for (c, reply) in commands.iter().zip(replies) {
        assert_eq!(&c["reply"], reply);
    }
    assert_eq!(commands[0]["command"]["text"], "lsl check: stimulus on");
}

/// A scripted walk whose keyframes give a left hand, on a one-wall display with the shipped
/// mannequin: the headless loop poses the avatar's left hand where the path puts it, the session
/// log records the hand (format 3's left_hand columns), and `vlf replay` draws the logged frame
/// pixel-identical to the live one; the same frame replayed without the hand differs (the
/// raised arm is in the view; untracked, it hangs out of it).
#[test]
fn a_scripted_left_hand_is_logged_and_replayed_on_the_avatar() {
    let dir = tempfile::tempdir().unwrap();
    let walk = dir.path().join("walk.toml");
    let key = |t: f32, hand: [f32; 3]| {
        format!(
            "[[keyframe]]\nt = {t:?}\nhead = [0.0, 1.2, 0.3]\nposition = [0.0, 0.0, 2.2]\n\
             left_hand_position = {hand:?}\nleft_hand_pitch_deg = 40.0\n"
        )
    };
    let text = key(0.0, [-0.1, 1.25, 0.1]) + &key(2.0, [-0.05, 1.3, 0.1]);
    std::fs::write(&walk, text).unwrap();
    let config = dir.path().join("small.toml");
    std::fs::write(
        &config,
        format!(
            "name = \"left-hand\"\n[start_pose]\nposition = [0.0, 0.0, 2.2]\n\
             [tracking]\nsource = \"scripted\"\npath = {:?}\n[[wall]]\nname = \"front\"\n\
             lower_left = [-0.3, 1.0, 0.0]\nlower_right = [0.3, 1.0, 0.0]\n\
             upper_left = [-0.3, 1.45, 0.0]\npixels = [64, 48]\n\
             output = {{ monitor = 0, window = [100, 100] }}\n\
             [[object]]\nname = \"body\"\nkind = \"avatar\"\nmesh = {:?}\nscale = 0.7\n{}",
            walk.display().to_string(),
            repo_path("assets/avatar/mannequin.glb")
                .display()
                .to_string(),
            light_probes()
        ),
    )
    .unwrap();
    let (lf, resident, meta, records) = logged_cornell_run(dir.path(), &config, 3);
    let (log_dir, live) = (dir.path().join("log"), dir.path().join("live"));
    assert!(meta.columns.iter().any(|(n, _)| n == "left_hand_qw"));
    // the three frames spread over the 2 s walk: its left hand at 0, 1 and 2 s
    let path = vlf::tracking::source::ScriptedPath::load(&walk).unwrap();
    for (r, t) in records.iter().zip([0.0, 1.0, 2.0]) {
        assert_eq!(r.left_hand, path.left_hand_at(t), "frame {}", r.frame);
        assert_eq!(r.wand, None);
    }
    assert_eq!(parquet_matches_csv(&log_dir)["parquet_rows"], 3);

    let replay = |records: &[vlf::study::FrameRecord], out: &str| {
        let folders = vlf::display::replay::replay(
            (&lf, &resident),
            &meta,
            records,
            (&dir.path().join(out), true),
            &Silent,
        )
        .unwrap();
        let view = &meta.views[0];
        (
            live.join(format!("{view}.exr")),
            folders[0].join(format!("{view}.exr")),
        )
    };
    let (live_image, again) = replay(&records[2..], "again");
    same_pixels(&live_image, &again);
    let without = vlf::study::FrameRecord {
        left_hand: None,
        ..records[2].clone()
    };
    let (_, hanging) = replay(&[without], "hanging");
    let (a, b) = (
        vlf::render::image_io::read_exr(&again).unwrap(),
        vlf::render::image_io::read_exr(&hanging).unwrap(),
    );
    let differ = (a.pixels.iter().zip(&b.pixels))
        .filter(|(p, q)| p != q)
        .count();
    assert!(
        differ > 20,
        "the raised left arm changes only {differ} pixels"
    );
}

/// A scripted walk whose keyframes move a declared target, "cube" (`[[keyframe.target]]`), on
/// a one-wall display with a cube that follows it (`follow = "target"`): the session log records
/// the target (format 7's `target:cube` columns) where the path puts it, and `vlf replay` poses
/// the cube from the logged target, pixel-identical to the live frame; the same frame replayed
/// with the target not seen draws no cube.
#[test]
fn a_scripted_target_is_logged_and_replayed_with_its_object() {
    let dir = tempfile::tempdir().unwrap();
    let walk = dir.path().join("walk.toml");
    // the target in the room (the room stands at z = 2.2 in the world): the cube of
    // STILL_CUBE's place, moving 20 cm to the left over the walk
    let key = |t: f32, x: f32| {
        format!(
            "[[keyframe]]\nt = {t:?}\nhead = [0.0, 1.2, 0.3]\nposition = [0.0, 0.0, 2.2]\n\
             [[keyframe.target]]\nname = \"cube\"\nposition = [{x:?}, 0.55, -2.0]\nyaw_deg = 30.0\n"
        )
    };
    std::fs::write(&walk, key(0.0, 0.25) + &key(2.0, 0.05)).unwrap();
    std::fs::write(dir.path().join("cube.obj"), CUBE_OBJ).unwrap();
    let config = dir.path().join("small.toml");
    std::fs::write(
        &config,
        format!(
            "name = \"target\"\n[start_pose]\nposition = [0.0, 0.0, 2.2]\n\
             [tracking]\nsource = \"scripted\"\npath = {:?}\n\
             [[tracking.target]]\nname = \"box\"\n[[tracking.target]]\nname = \"cube\"\n\
             [[wall]]\nname = \"front\"\n\
             lower_left = [-0.3, 1.0, 0.0]\nlower_right = [0.3, 1.0, 0.0]\n\
             upper_left = [-0.3, 1.45, 0.0]\npixels = [64, 48]\n\
             output = {{ monitor = 0, window = [100, 100] }}\n\
             [[object]]\nname = \"cube\"\nmesh = \"cube.obj\"\nfollow = \"target\"\ntarget = \"cube\"\nscale = 2.5\n{}",
            walk.display().to_string(),
            light_probes()
        ),
    )
    .unwrap();
    let (lf, resident, meta, records) = logged_cornell_run(dir.path(), &config, 3);
    assert_eq!(meta.format, LOG_FORMAT);
    assert_eq!(meta.targets, ["box", "cube"]);
    assert!(meta.columns.iter().any(|(n, _)| n == "target:cube_qw"));
    // the three frames spread over the 2 s walk: the cube's target at 0, 1 and 2 s; "box" is
    // never seen; scripted, nothing raw
    let display = DisplayConfig::load(&config).unwrap();
    let source = display.pose_source(&config).unwrap();
    for (r, t) in records.iter().zip([0.0, 1.0, 2.0]) {
        let held = source.held_at(&display.tracking, t);
        assert_eq!(r.targets, held.targets, "frame {}", r.frame);
        assert!(r.targets[1].is_some() && r.targets[0].is_none());
        assert_eq!(r.raw.targets[1], None);
    }
    let live = dir.path().join("live/front-mono.exr");
    let again = vlf::display::replay::replay(
        (&lf, &resident),
        &meta,
        &records[2..],
        (&dir.path().join("again"), true),
        &Silent,
    )
    .unwrap();
    same_pixels(&live, &again[0].join("front-mono.exr"));
    let mut unseen = records[2].clone();
    unseen.targets[1] = None;
    let gone = replay_png((&lf, &resident), &meta, unseen, &dir.path().join("unseen"));
    let differ = differing(&read_png(&again[0].join("front-mono.png")), &gone);
    eprintln!("the target's cube: {differ} of 3072 pixels");
    assert!(
        differ > 30,
        "the cube on its target changes only {differ} pixels"
    );
}

/// A one-wall display (48x48, mono, static head) looking into the Cornell box through its open
/// front, with two conditions: `gi-on` (the default) and `gi-off` (direct light only, shown at
/// exposure 1.5).
fn conditions_display(dir: &std::path::Path) -> std::path::PathBuf {
    let config = dir.join("conditions.toml");
    std::fs::write(
        &config,
        "name = \"conditions-test\"\ndefault_condition = \"gi-on\"\n\
         [start_pose]\nposition = [0.0, 0.0, 2.2]\n\
         [tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\n\
         [[condition]]\nname = \"gi-off\"\nglobal_illumination = false\nexposure = 1.5\n\
         [[condition]]\nname = \"gi-on\"\n\
         [[wall]]\nname = \"front\"\nlower_left = [-1.0, 0.0, -1.2]\n\
         lower_right = [1.0, 0.0, -1.2]\nupper_left = [-1.0, 2.0, -1.2]\npixels = [48, 48]\n\
         output = { monitor = 0, window = [100, 100] }\n",
    )
    .unwrap();
    config
}

/// A 0.2 m cube as OBJ text.
const CUBE_OBJ: &str = "v -0.1 -0.1 -0.1\nv 0.1 -0.1 -0.1\nv 0.1 0.1 -0.1\nv -0.1 0.1 -0.1\n\
v -0.1 -0.1 0.1\nv 0.1 -0.1 0.1\nv 0.1 0.1 0.1\nv -0.1 0.1 0.1\n\
f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 7 3\nf 4 8 7\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";

/// The tests' displays light their objects with few probes (`common::LIGHT_PROBE_KEYS`).
fn light_probes() -> String {
    format!("[object_lighting]\n{}", common::LIGHT_PROBE_KEYS)
}

/// A one-wall display (64x48 pixels, 10 Hz, static head looking into the Cornell box) with
/// `objects` (TOML), in `dir`; the cube's mesh beside it.
fn small_display(dir: &std::path::Path, objects: &str) -> std::path::PathBuf {
    std::fs::write(dir.join("cube.obj"), CUBE_OBJ).unwrap();
    let config = dir.join("small.toml");
    std::fs::write(
        &config,
        format!(
            "name = \"replay\"\nrefresh_hz = 10\n[start_pose]\nposition = [0.0, 0.0, 2.2]\n\
             [tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\n[[wall]]\nname = \"front\"\n\
             lower_left = [-0.3, 1.0, 0.0]\nlower_right = [0.3, 1.0, 0.0]\n\
             upper_left = [-0.3, 1.45, 0.0]\npixels = [64, 48]\n\
             output = {{ monitor = 0, window = [100, 100] }}\n{objects}{}",
            light_probes()
        ),
    )
    .unwrap();
    config
}

/// Mean radiance (r+g+b) of the ceiling seen through the box's front in the 48x48 view of
/// `conditions_display`: the top rows (world y 1.83 to 2.0 on the wall), left and right of the
/// light (wall x 0.2 to 0.4 from the middle), where the eye ray meets the ceiling's front half.
fn ceiling_radiance(image: &vlf::render::Frame) -> f64 {
    let mut sum = (0.0, 0);
    for y in 0..4 {
        for x in (14..20).chain(28..34) {
            let p = image.pixels[(y * image.width + x) as usize];
            sum = (sum.0 + (p[0] + p[1] + p[2]) as f64, sum.1 + 1);
        }
    }
    sum.0 / sum.1 as f64
}

/// The shipped conditions example (tools/study/conditions_example.py) switches a headless run
/// of the Cornell box from `gi-on` to `gi-off` over `--control`: the reply names the frame, an
/// unknown condition is refused with the names there are, `state` says the condition; the log
/// has `gi-on` before that frame and `gi-off` from it on; `vlf replay` draws the run's last
/// frame (in gi-off, read back) pixel-identical, its PNG at the condition's exposure as well,
/// and direct light only leaves the ceiling (lit only by light that bounced) dark.
#[test]
fn an_experiment_script_switches_conditions_and_replay_draws_each_frame_in_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let config = conditions_display(dir.path());
    let log_dir = dir.path().join("log");
    let live = dir.path().join("live");
    let mut child = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("cave")
        .arg(&config)
        .args(["--headless", "--exr", "--frames", "100000"])
        .args(["--control", "127.0.0.1:0", "--scene"])
        .arg(repo_path("scenes/cornell/scene.toml"))
        .args(["--quality", "draft"])
        .arg("--log")
        .arg(&log_dir)
        .arg("--out")
        .arg(&live)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let addr = control_address(&mut child);
    let replies = script_replies("tools/study/conditions_example.py", &addr, &mut child);
    // state, condition gi-off, a refused condition, state, stop
    assert_eq!(replies.len(), 5, "{replies:?}");
    assert_eq!(replies[0]["condition"], "gi-on");
    assert_eq!(
        (replies[1]["ok"].as_bool(), replies[1]["cmd"].as_str()),
        (Some(true), Some("condition"))
    );
    let switched = replies[1]["frame"].as_u64().unwrap();
    assert!(switched > replies[0]["frame"].as_u64().unwrap());
    let refused = replies[2]["error"].as_str().unwrap();
    assert_eq!(replies[2]["ok"], false);
    assert!(
        refused.contains("sepia") && refused.contains("gi-on") && refused.contains("gi-off"),
        "{refused}"
    );
    assert_eq!(replies[3]["condition"], "gi-off");
    let last = replies[4]["frame"].as_u64().unwrap();

    // the log: gi-on before the switch's frame, gi-off from it on, the switch an event there
    let (meta, records) = SessionLog::read(&log_dir).unwrap();
    assert_eq!(records.last().unwrap().frame, last);
    for r in &records {
        let expect = if r.frame >= switched {
            "gi-off"
        } else {
            "gi-on"
        };
        assert_eq!(r.condition, expect, "frame {}", r.frame);
    }
    let at = |f: u64| records.iter().find(|r| r.frame == f).unwrap();
    assert!(at(switched).events.contains("condition gi-off"));
    assert!(meta.columns.iter().any(|(n, _)| n == "condition"));
    let parquet = parquet_matches_csv(&log_dir);
    assert_eq!(parquet["parquet_rows"], records.len(), "{parquet}");

    // replay: the last frame (gi-off) pixel-identical to the live read-back, and the frame
    // before the switch (gi-on, the same static head) drawn with global illumination
    let again = dir.path().join("again");
    let status = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .args(["replay", log_dir.to_str().unwrap(), "--exr", "--out"])
        .arg(&again)
        .args(["--frames", &format!("{}..={last}", switched - 1)])
        .stderr(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let view = &meta.views[0];
    let replayed = again.join(format!("frame-{last:06}"));
    same_pixels(
        &live.join(format!("{view}.exr")),
        &replayed.join(format!("{view}.exr")),
    );
    // the PNG as the walls showed it: the condition's exposure, the same both ways
    let png = |p: std::path::PathBuf| image::open(p).unwrap().to_rgb8().into_raw();
    let live_png = png(live.join(format!("{view}.png")));
    assert_eq!(live_png, png(replayed.join(format!("{view}.png"))));
    let gi_off = vlf::render::image_io::read_exr(&replayed.join(format!("{view}.exr"))).unwrap();
    let unexposed = vlf::render::image_io::display_image(&gi_off, 1.0).into_raw();
    assert_ne!(
        live_png, unexposed,
        "the PNG is written at the condition's exposure"
    );
    let before = again.join(format!("frame-{:06}/{view}.exr", switched - 1));
    let gi_on = vlf::render::image_io::read_exr(&before).unwrap();
    let (on, off) = (ceiling_radiance(&gi_on), ceiling_radiance(&gi_off));
    eprintln!("the ceiling's mean radiance (r+g+b): {on:.4} with global illumination, {off:.4} with direct light only");
    assert!(on > 0.05 && off < 0.2 * on, "gi-on {on}, gi-off {off}");
}

/// The keyframed cube of `small_display`: across the box in 0.3 s.
const MOVING_CUBE: &str = "[[object]]\nname = \"cube\"\nmesh = \"cube.obj\"\n\
[[object.keyframe]]\nt = 0.0\nposition = [-0.5, 1.1, 0.5]\n\
[[object.keyframe]]\nt = 0.3\nposition = [0.5, 1.3, 0.5]\nyaw_deg = 60.0\n";

fn read_png(path: &std::path::Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// One frame of the log `meta` replayed into `out` from the light field: its first view's PNG.
fn replay_png(
    (lf, resident): (
        &vlf::lightfield::LightField,
        &vlf::lightfield::ResidentLightField,
    ),
    meta: &SessionMeta,
    record: vlf::study::FrameRecord,
    out: &std::path::Path,
) -> image::RgbImage {
    let folders =
        vlf::display::replay::replay((lf, resident), meta, &[record], (out, false), &Silent)
            .unwrap();
    read_png(&folders[0].join(format!("{}.png", meta.views[0])))
}

/// The names of the files in `dir` that contain `part`.
fn names_with(dir: &std::path::Path, part: &str) -> Vec<String> {
    (std::fs::read_dir(dir).unwrap())
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(part))
        .collect()
}

fn differing(a: &image::RgbImage, b: &image::RgbImage) -> usize {
    assert_eq!(a.dimensions(), b.dimensions());
    (a.pixels().zip(b.pixels())).filter(|(p, q)| p != q).count()
}

/// A keyframed object moves with the frames' object time (frame / refresh_hz headless): the log
/// has the time each frame used (`object_time_s`) and `vlf replay` poses the object at it, so
/// the replayed last frame is pixel-identical to the live one; drawn at time 0 (as a log
/// without the column would be) the cube is elsewhere.
#[test]
fn a_keyframed_object_replays_at_its_logged_time() {
    let dir = tempfile::tempdir().unwrap();
    let config = small_display(dir.path(), MOVING_CUBE);
    let (lf, resident, meta, records) = logged_cornell_run(dir.path(), &config, 4);
    let times: Vec<Option<f64>> = records.iter().map(|r| r.object_time_s).collect();
    assert_eq!(times, [Some(0.0), Some(0.1), Some(0.2), Some(0.3)]);
    assert!(meta.columns.iter().any(|(n, _)| n == "object_time_s"));
    let live = dir.path().join("live/front-mono.exr");
    let again = vlf::display::replay::replay(
        (&lf, &resident),
        &meta,
        &records[3..],
        (&dir.path().join("again"), true),
        &Silent,
    )
    .unwrap();
    same_pixels(&live, &again[0].join("front-mono.exr"));
    let at_zero = vlf::study::FrameRecord {
        object_time_s: None,
        ..records[3].clone()
    };
    let start = replay_png((&lf, &resident), &meta, at_zero, &dir.path().join("start"));
    let moved = differing(&read_png(&again[0].join("front-mono.png")), &start);
    eprintln!("keyframed cube: {moved} of 3072 pixels differ between 0 s and 0.3 s");
    assert!(
        moved > 30,
        "the cube at 0 s and 0.3 s: {moved} pixels differ"
    );
}

/// A cube half a metre wide standing still in the Cornell box of `small_display`.
const STILL_CUBE: &str = "[[object]]\nname = \"cube\"\nmesh = \"cube.obj\"\n\
position = [0.25, 0.55, 0.2]\nyaw_deg = 30.0\nscale = 2.5\n";

/// A script's commands sent one after the other to `addr`, each once the one before was
/// acknowledged: the replies, in order.
fn send_in_turn(addr: std::net::SocketAddr, lines: &[&str]) -> Vec<serde_json::Value> {
    use std::io::{BufRead, Write};
    let mut client = std::net::TcpStream::connect(addr).unwrap();
    let mut replies = std::io::BufReader::new(client.try_clone().unwrap());
    let mut got = Vec::new();
    for line in lines {
        writeln!(client, "{line}").unwrap();
        let mut reply = String::new();
        replies.read_line(&mut reply).unwrap();
        got.push(serde_json::from_str(&reply).unwrap());
    }
    got
}

/// A logged headless run of the Cornell box (`logged_cornell_run_with`, every frame read back)
/// driven by a script sending `commands` in turn: every command acknowledged, their frames
/// rising, the last (`stop`) the log's last frame. The light field, the log, and each
/// command's frame.
fn scripted_cornell_run(
    dir: &std::path::Path,
    config: &std::path::Path,
    commands: &'static [&'static str],
) -> (
    vlf::lightfield::LightField,
    vlf::lightfield::ResidentLightField,
    SessionMeta,
    Vec<vlf::study::FrameRecord>,
    Vec<u64>,
) {
    let server = vlf::study::ControlServer::bind("127.0.0.1:0").unwrap();
    let addr = server.addr;
    let script = std::thread::spawn(move || send_in_turn(addr, commands));
    let (lf, resident, meta, records) =
        logged_cornell_run_with(dir, config, 100_000, Some(&server));
    let replies = script.join().unwrap();
    assert!(replies.iter().all(|r| r["ok"] == true), "{replies:?}");
    let at: Vec<u64> = (replies.iter())
        .map(|r| r["frame"].as_u64().unwrap())
        .collect();
    assert_eq!(at.len(), commands.len(), "{replies:?}");
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{at:?}");
    assert_eq!(records.last().unwrap().frame, *at.last().unwrap());
    (lf, resident, meta, records, at)
}

/// Every command that changes the picture, replayed at its frame: a script hides and shows the
/// cube, turns the objects' shadows and reflections off, flashes the walls white (then black)
/// and ends the test, over the control connection of a headless run that reads every frame back;
/// the log has each frame's switches and flash (`objects_hidden`, `shadows`, `reflections`,
/// `flash`), and `vlf replay` draws every frame pixel-identical to the live one. Where a
/// command changed the picture the frame differs from the one before it, and the hidden cube
/// drawn without the logged switches (as a format 4 log was replayed) differs from the live frame.
#[test]
fn every_command_that_changes_the_picture_replays_at_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    let config = small_display(dir.path(), STILL_CUBE);
    let (lf, resident, meta, records, at) = scripted_cornell_run(
        dir.path(),
        &config,
        &[
            r#"{"cmd": "event", "text": "begin"}"#,
            r#"{"cmd": "hide", "object": "cube"}"#,
            r#"{"cmd": "show", "object": "cube"}"#,
            r#"{"cmd": "shadows", "on": false}"#,
            r#"{"cmd": "reflections", "on": false}"#,
            r#"{"cmd": "flash"}"#,
            r#"{"cmd": "flash", "end": true}"#,
            r#"{"cmd": "stop"}"#,
        ],
    );
    let [_begin, hide, show, shadows, reflections, flash, flash_end, _stop] = at[..] else {
        panic!("{at:?}")
    };
    assert!(records.iter().all(|r| r.drawn == Drawn::ReadBack));
    let names: Vec<&str> = meta.columns.iter().map(|(n, _)| n.as_str()).collect();
    for column in ["objects_hidden", "shadows", "reflections", "flash"] {
        assert!(names.contains(&column), "{column}");
    }
    assert_eq!(
        parquet_matches_csv(&dir.path().join("log"))["parquet_rows"],
        records.len()
    );
    // the log: each switch from its frame on, the flash white at its frame, black until its end
    for r in &records {
        let f = r.frame;
        let switches = r.objects.as_ref().unwrap();
        let hidden: &[&str] = if (hide..show).contains(&f) {
            &["cube"]
        } else {
            &[]
        };
        assert_eq!(switches.hidden, hidden, "frame {f}");
        assert_eq!(switches.shadows, f < shadows, "frame {f}");
        assert_eq!(switches.reflections, f < reflections, "frame {f}");
        let lit = match f {
            f if f == flash => Some(true),
            f if (flash + 1..flash_end).contains(&f) => Some(false),
            _ => None,
        };
        assert_eq!(r.flash, lit, "frame {f}");
    }

    // replayed from the log: every frame the live one, pixel for pixel
    let again = dir.path().join("again");
    let folders =
        vlf::display::replay::replay((&lf, &resident), &meta, &records, (&again, true), &Silent)
            .unwrap();
    assert_eq!(folders.len(), records.len());
    let view = &meta.views[0];
    let live = |f: u64| dir.path().join(format!("live/frame-{f:06}/{view}"));
    for (r, folder) in records.iter().zip(&folders) {
        same_pixels(
            &live(r.frame).with_extension("exr"),
            &folder.join(format!("{view}.exr")),
        );
        let png = |p: std::path::PathBuf| read_png(&p);
        assert_eq!(
            differing(
                &png(live(r.frame).with_extension("png")),
                &png(folder.join(format!("{view}.png")))
            ),
            0,
            "frame {}",
            r.frame
        );
    }
    // where a command changed the picture, its frame differs from the one before
    let shown = |f: u64| read_png(&live(f).with_extension("png"));
    let changed = |f: u64| differing(&shown(f - 1), &shown(f));
    let (hid, reshown, unshadowed) = (changed(hide), changed(show), changed(shadows));
    eprintln!(
        "pixels of {} changed: hide {hid}, show {reshown}, shadows off {unshadowed}, reflections off {}",
        64 * 48,
        changed(reflections)
    );
    assert!(hid > 30 && reshown > 30, "hide {hid}, show {reshown}");
    assert!(unshadowed > 10, "shadows off: {unshadowed} pixels changed");
    let white = shown(flash);
    assert!(
        white.pixels().all(|p| p.0 == [255; 3]),
        "the flash is full white"
    );
    assert!(
        shown(flash + 1).pixels().all(|p| p.0 == [0; 3]),
        "then black"
    );
    assert!(changed(flash_end) > 1000, "the scene back after the test");
    // the hidden frame drawn without its logged switches (a format 4 log): the cube is there
    let record = records.iter().find(|r| r.frame == hide).unwrap();
    let unswitched = vlf::study::FrameRecord {
        objects: None,
        ..record.clone()
    };
    let older = replay_png(
        (&lf, &resident),
        &meta,
        unswitched,
        &dir.path().join("older"),
    );
    let differ = differing(&shown(hide), &older);
    assert!(
        differ > 30,
        "without the switches the cube shows: {differ} pixels differ"
    );
}

/// `vlf replay --video`: an MP4 that ffprobe reads, one frame per logged frame at the view's
/// size; `--overlay` changes the PNG only in the text's band, and only when asked; without
/// ffmpeg on the PATH the replay fails saying how to install it and leaves no file.
#[test]
fn a_replay_goes_to_a_video_with_the_events_overlaid() {
    let dir = tempfile::tempdir().unwrap();
    let config = small_display(dir.path(), MOVING_CUBE);
    let (_, _, _, records) = logged_cornell_run(dir.path(), &config, 4);
    let log_dir = dir.path().join("log");
    let video = dir.path().join("replay.mp4");
    let replay = |args: &[&str], path: Option<&str>| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_vlf"));
        c.arg("replay").arg(&log_dir).args(args);
        if let Some(p) = path {
            c.env("PATH", p);
        }
        c.output().unwrap()
    };
    let out = replay(
        &[
            "--video",
            video.to_str().unwrap(),
            "--view",
            "front-mono",
            "--overlay",
            "--out",
            dir.path().join("over").to_str().unwrap(),
        ],
        None,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let probe = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args([
            "-show_entries",
            "stream=nb_read_frames,width,height,codec_name,r_frame_rate",
        ])
        .args(["-of", "json"])
        .arg(&video)
        .output()
        .unwrap_or_else(|e| {
            panic!("ffprobe runs ({e}): `bash tools/setup.sh test` installs ffmpeg")
        });
    let probe: serde_json::Value = serde_json::from_slice(&probe.stdout).unwrap();
    let stream = &probe["streams"][0];
    assert_eq!(
        (&stream["codec_name"], &stream["width"], &stream["height"]),
        (&"h264".into(), &64.into(), &48.into()),
        "{probe}"
    );
    assert_eq!(stream["nb_read_frames"], "4", "{probe}");
    assert_eq!(stream["r_frame_rate"], "10/1", "the display's refresh_hz");
    let leftovers = names_with(dir.path(), "partial");
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // the overlay: only its band differs from the live image, and the band is the text's
    let plain = read_png(&dir.path().join("live/front-mono.png"));
    let over = read_png(&dir.path().join("over/frame-000003/front-mono.png"));
    let mut expect = plain.clone();
    let lines = vlf::display::replay::overlay::lines(&records, &records[3]);
    assert!(lines[0].starts_with("frame 3"), "{lines:?}");
    let [_, _, x1, y1] = vlf::display::replay::overlay::draw(&mut expect, &lines);
    assert_eq!(differing(&over, &expect), 0);
    let inside = differing(&plain, &over);
    eprintln!("overlay: band {x1}x{y1} pixels, {inside} of them changed; video {stream}");
    assert!(inside > 50, "{inside} pixels of overlay");
    for (x, y, p) in over.enumerate_pixels() {
        if x >= x1 || y >= y1 {
            assert_eq!(p, plain.get_pixel(x, y), "({x}, {y}) outside the band");
        }
    }
    // not asked: the replayed PNG is the live one
    let out = replay(
        &[
            "--frames",
            "3",
            "--out",
            dir.path().join("plain").to_str().unwrap(),
        ],
        None,
    );
    assert!(out.status.success());
    assert_eq!(
        differing(
            &plain,
            &read_png(&dir.path().join("plain/frame-000003/front-mono.png"))
        ),
        0
    );

    // no ffmpeg: a clear error, no video, nothing half-written
    let lost = dir.path().join("lost.mp4");
    let out = replay(&["--video", lost.to_str().unwrap()], Some("/nonexistent"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("apt-get install ffmpeg"),
        "{err}"
    );
    let names = names_with(dir.path(), "lost");
    assert!(names.is_empty(), "{names:?}");
    // an unknown view is refused with the session's views
    let out = replay(
        &["--video", lost.to_str().unwrap(), "--view", "back-left"],
        None,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("front-mono"), "{err}");
}

/// The third-person camera (`--third-person`, behind and above the logged head) sees the
/// participant's avatar: the same camera over the same frame without the avatar (a display
/// config without its `[[object]]`, the same views) differs where the body stands.
#[test]
fn a_third_person_camera_shows_the_avatar() {
    let dir = tempfile::tempdir().unwrap();
    let avatar = format!(
        "[[object]]\nname = \"body\"\nkind = \"avatar\"\nmesh = {:?}\nscale = 0.7\n",
        repo_path("assets/avatar/mannequin.glb")
            .display()
            .to_string()
    );
    let config = small_display(dir.path(), &avatar);
    let (lf, resident, meta, records) = logged_cornell_run(dir.path(), &config, 2);
    let camera = vlf::display::replay::ThirdPerson {
        eye: None,
        look_at: None,
        fov_y_deg: 60.0,
        size: [96, 64],
    };
    let third = |meta: &SessionMeta, out: &str| {
        let out = dir.path().join(out);
        let output = vlf::display::replay::ReplayOutput {
            images: Some(&out),
            camera: Some(camera),
            ..Default::default()
        };
        let folders = vlf::display::replay::replay_with(
            (&lf, &resident),
            meta,
            &records[1..],
            &output,
            &Silent,
        )
        .unwrap();
        read_png(&folders[0].join("third-person.png"))
    };
    let with = third(&meta, "with");
    assert_eq!(with.dimensions(), (96, 64));
    std::fs::create_dir(dir.path().join("bare")).unwrap();
    let bare = small_display(&dir.path().join("bare"), "");
    let without = third(
        &SessionMeta {
            display_config: bare,
            ..meta.clone()
        },
        "without",
    );
    let body = differing(&with, &without);
    eprintln!("third person: the avatar changes {body} of 6144 pixels");
    assert!(body > 100, "the avatar covers only {body} of 6144 pixels");
}

/// A live OSC tracker with a calibration that moves, turns and scales its poses: the session
/// log keeps each frame's raw head and wand as the tracker sent them (the `raw_*` columns)
/// beside the calibrated ones, and the calibrated are the calibration of the raw, bit for bit.
#[test]
fn raw_tracker_poses_are_logged_beside_the_calibrated_ones() {
    let dir = tempfile::tempdir().unwrap();
    let port = common::free_udp_port();
    let config = dir.path().join("live.toml");
    std::fs::write(
        &config,
        format!(
            "name = \"raw\"\n[start_pose]\nposition = [0.0, 0.0, 2.2]\n\
             [tracking]\nsource = \"osc\"\nport = {port}\n[tracking.calibration]\n\
             translation = [0.5, 0.0, -0.2]\nyaw_deg = 90.0\nunit_scale = 0.001\naxes = \"z_up\"\n\
             [[wall]]\nname = \"front\"\nlower_left = [-0.3, 1.0, 0.0]\nlower_right = [0.3, 1.0, 0.0]\n\
             upper_left = [-0.3, 1.45, 0.0]\npixels = [32, 24]\n\
             output = {{ monitor = 0, window = [100, 100] }}\n"
        ),
    )
    .unwrap();
    let head_q = glam::Quat::from_rotation_z(0.3).normalize();
    let wand_q = glam::Quat::from_rotation_x(-0.4).normalize();
    let sending = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let sender = {
        let sending = sending.clone();
        std::thread::spawn(move || {
            let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
            let mut k = 0.0f32;
            while sending.load(std::sync::atomic::Ordering::Relaxed) {
                for (addr, p, q) in [
                    ("/vlf/head", [100.0 + k, 2000.0, 1700.0], head_q),
                    ("/vlf/wand", [250.0, 1800.0 - k, 1200.0], wand_q),
                ] {
                    let packet = rosc::OscPacket::Message(rosc::OscMessage {
                        addr: addr.into(),
                        args: [p[0], p[1], p[2], q.x, q.y, q.z, q.w]
                            .into_iter()
                            .map(rosc::OscType::Float)
                            .collect(),
                    });
                    let bytes = rosc::encoder::encode(&packet).unwrap();
                    socket.send_to(&bytes, ("127.0.0.1", port)).unwrap();
                }
                k += 1.0;
                std::thread::sleep(std::time::Duration::from_millis(3));
            }
        })
    };
    let (_, _, meta, records) = logged_cornell_run(dir.path(), &config, 12);
    sending.store(false, std::sync::atomic::Ordering::Relaxed);
    sender.join().unwrap();
    assert!(meta.columns.iter().any(|(n, _)| n == "raw_left_hand_qw"));
    let display = DisplayConfig::load(&config).unwrap();
    let c = display.tracking.live().unwrap().calibration.unwrap();
    let with_raw: Vec<_> = records.iter().filter(|r| r.raw.head.is_some()).collect();
    assert!(
        with_raw.len() >= 6,
        "{} of 12 frames saw the tracker",
        with_raw.len()
    );
    for r in &with_raw {
        let (head, wand) = (r.raw.head.unwrap(), r.raw.wand.unwrap());
        // as sent (tracker millimetres, z up) ...
        assert_eq!((head.position.y, head.position.z), (2000.0, 1700.0));
        assert!(head.position.x >= 100.0 && head.position.x.fract() == 0.0);
        assert!(
            head.rotation.abs_diff_eq(head_q, 1e-6),
            "{:?}",
            head.rotation
        );
        assert_eq!((wand.position.x, wand.position.z), (250.0, 1200.0));
        // ... and calibrated from exactly those
        assert_eq!(r.pose.head, c.position(head.position), "frame {}", r.frame);
        assert_eq!(r.pose.head_rotation, c.orientation(head.rotation));
        assert_eq!(r.wand.unwrap().position, c.position(wand.position));
        assert_eq!(r.wand.unwrap().rotation, c.orientation(wand.rotation));
        assert!((r.pose.head - head.position).length() > 100.0);
        assert_eq!(r.raw.left_hand, None);
    }
    // the head moves between packets: the raw column follows the tracker frame by frame
    let xs: std::collections::BTreeSet<u32> = with_raw
        .iter()
        .map(|r| r.raw.head.unwrap().position.x as u32)
        .collect();
    assert!(xs.len() >= 2, "{xs:?}");
    eprintln!(
        "raw poses: {} of 12 frames with the tracker's, {} head positions",
        with_raw.len(),
        xs.len()
    );
    assert_eq!(
        parquet_matches_csv(&dir.path().join("log"))["parquet_rows"],
        12
    );
}

/// A one-wall display (48x48, mono, static head) with two conditions of other geometry: `box`
/// (the Cornell box, the `--scene`) and `room` (the textured room, another scene: its own
/// triangles, textures and light), each with the room's place in its scene.
fn two_scenes_display(dir: &std::path::Path) -> std::path::PathBuf {
    let config = dir.join("two-scenes.toml");
    let room = repo_path("scenes/textured-room/scene.toml");
    std::fs::write(
        &config,
        format!(
            "name = \"two-scenes\"\n[start_pose]\nposition = [0.0, 0.0, 2.2]\n\
             [tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\n\
             [[condition]]\nname = \"box\"\nstart_pose = {{ position = [0.0, 0.0, 2.2], yaw_deg = 0.0 }}\n\
             [[condition]]\nname = \"room\"\nlight_field = {room:?}\n\
             start_pose = {{ position = [0.0, 0.0, 2.6], yaw_deg = 0.0 }}\n\
             [[wall]]\nname = \"front\"\nlower_left = [-1.0, 0.0, -1.2]\n\
             lower_right = [1.0, 0.0, -1.2]\nupper_left = [-1.0, 2.0, -1.2]\npixels = [48, 48]\n\
             output = {{ monitor = 0, window = [100, 100] }}\n"
        ),
    )
    .unwrap();
    config
}

/// A condition may name another scene (other geometry): it is drawn by a renderer of its own,
/// made before the first frame. A script switches a headless Cornell box run to the textured
/// room, back and to the room again: the log has each frame's condition; every frame replays
/// pixel-identical; a frame in `room` is pixel-identical to a run whose `--scene` is the room
/// (from the condition's start pose), and differs from the box's frames.
#[test]
fn a_condition_of_another_scene_is_drawn_by_a_renderer_of_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let config = two_scenes_display(dir.path());
    let (lf, resident, meta, records, at) = scripted_cornell_run(
        dir.path(),
        &config,
        &[
            r#"{"cmd": "event", "text": "begin"}"#,
            r#"{"cmd": "condition", "name": "room"}"#,
            r#"{"cmd": "condition", "name": "box"}"#,
            r#"{"cmd": "condition", "name": "room"}"#,
            r#"{"cmd": "stop"}"#,
        ],
    );
    let [_begin, room, back, again, stop] = at[..] else {
        panic!("{at:?}")
    };
    for r in &records {
        let f = r.frame;
        let expect = if (room..back).contains(&f) || f >= again {
            "room"
        } else {
            "box"
        };
        assert_eq!(r.condition, expect, "frame {f}");
    }
    // replayed: every frame the live one
    let folders = vlf::display::replay::replay(
        (&lf, &resident),
        &meta,
        &records,
        (&dir.path().join("again"), true),
        &Silent,
    )
    .unwrap();
    let view = &meta.views[0];
    let live = |f: u64| dir.path().join(format!("live/frame-{f:06}/{view}.exr"));
    for (r, folder) in records.iter().zip(&folders) {
        same_pixels(&live(r.frame), &folder.join(format!("{view}.exr")));
    }
    // the room's frame as a run of the room itself draws it
    let alone = dir.path().join("alone");
    std::fs::create_dir_all(&alone).unwrap();
    let room_scene = repo_path("scenes/textured-room/scene.toml");
    let text = std::fs::read_to_string(&config).unwrap();
    let start = text.find("[[condition]]").unwrap();
    let wall = text.find("[[wall]]").unwrap();
    let room_only = alone.join("room.toml");
    let room_text = text[..start].replace("[0.0, 0.0, 2.2]", "[0.0, 0.0, 2.6]") + &text[wall..];
    std::fs::write(&room_only, room_text).unwrap();
    let scene = vlf::scene::Scene::load(&room_scene).unwrap();
    let (room_lf, room_resident, _) =
        vlf::propagate::propagate(gpu(), &scene, &draft_params(), &Silent).unwrap();
    let display = DisplayConfig::load(&room_only).unwrap();
    let run = vlf::display::headless::HeadlessRun {
        frames: 1,
        out: &alone,
        exr: true,
        log: None,
        control: None,
        lsl: None,
        conditions: None,
        read_back_every_frame: false,
    };
    vlf::display::headless::run_reporting(
        &room_lf,
        &room_resident,
        &display,
        &room_only,
        run,
        &Silent,
    )
    .unwrap();
    same_pixels(&alone.join(format!("{view}.exr")), &live(stop));
    let read = |p: std::path::PathBuf| vlf::render::image_io::read_exr(&p).unwrap();
    let (in_box, in_room) = (read(live(back)), read(live(stop)));
    let differ = (in_box.pixels.iter().zip(&in_room.pixels))
        .filter(|(p, q)| p != q)
        .count();
    eprintln!("the box's frame and the room's: {differ} of 2304 pixels differ");
    assert!(differ > 1000, "{differ}");
}
