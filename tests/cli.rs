//! The command line end to end on the software adapter: propagate to a file with a report,
//! render PNG and EXR from it, and clear errors for bad use.

use crate::common;
use common::*;
use std::process::Command;

fn vlf() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vlf"))
}

const SMALL: &[&str] = &["--directions", "21", "--grid", "32", "--texel-density", "8"];

#[test]
fn propagate_then_render_from_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let vlf_path = dir.path().join("cornell.vlf");
    let report = dir.path().join("report.json");
    let out = vlf()
        .arg("propagate")
        .arg(repo_path("scenes/cornell/scene.toml"))
        .arg("-o")
        .arg(&vlf_path)
        .arg("--report")
        .arg(&report)
        .args(SMALL)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for row in [
        "faces",
        "diffuse elements",
        "non-diffuse elements",
        "visibility",
        "propagation",
        "iterations",
        "final residual",
        "GPU memory, propagating",
        "GPU memory, rendering",
    ] {
        assert!(stdout.contains(row), "summary lacks {row:?}:\n{stdout}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["faces"], 16);
    assert_eq!(json["non_diffuse_elements"], 0);
    assert_eq!(json["tile_bytes"], 0);
    assert!(
        json["render_memory_bytes"].as_u64().unwrap()
            < json["propagation_memory_bytes"].as_u64().unwrap()
    );

    for ext in ["png", "exr"] {
        let image = dir.path().join(format!("front.{ext}"));
        let out = vlf()
            .arg("render")
            .arg(&vlf_path)
            .args(["--camera", "front", "--size", "96x64", "-o"])
            .arg(&image)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(image.exists());
    }
    let frame = vlf::render::image_io::read_exr(&dir.path().join("front.exr")).unwrap();
    assert_eq!((frame.width, frame.height), (96, 64));
    assert!(frame
        .pixels
        .iter()
        .flatten()
        .all(|x| x.is_finite() && *x >= 0.0));
    // the light is the brightest thing in view, the open front shows black sky at the corners
    let max = frame.pixels.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    assert!(max > 10.0, "the emitter (Ke 17) is not visible: max {max}");
    let mean = frame.pixels.iter().map(|p| p[1] as f64).sum::<f64>() / frame.pixels.len() as f64;
    assert!(mean > 0.05, "image is nearly black: mean green {mean}");
}

#[test]
fn bad_use_gives_a_clear_error_and_nonzero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk.vlf");
    std::fs::write(&junk, b"not a light field").unwrap();
    let out = vlf()
        .arg("render")
        .arg(&junk)
        .arg("-o")
        .arg(dir.path().join("x.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("junk.vlf") && err.contains("not a vlf light field file"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");

    let out = vlf()
        .arg("render")
        .arg(repo_path("scenes/cornell/scene.toml"))
        .args(["--camera", "nope", "-o"])
        .arg(dir.path().join("x.png"))
        .args(SMALL)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("camera \"nope\" not found") && err.contains("front"),
        "{err}"
    );

    let err = propagate_refused(
        &["--grid", "30", "--tile", "8"],
        &dir.path().join("x.vlf"),
        &[],
    );
    assert!(
        err.contains("tile size 8 must divide the grid resolution 30"),
        "{err}"
    );

    // a light field into a folder that does not exist: refused before the propagation
    let nowhere = dir.path().join("no-such-folder").join("x.vlf");
    let started = std::time::Instant::now();
    let err = propagate_refused(&[], &nowhere, &[]);
    assert!(
        err.contains("no-such-folder") && err.contains("does not exist"),
        "{err}"
    );
    assert!(started.elapsed().as_secs_f64() < 5.0, "it propagated first");

    // VLF_GPU picks a hardware GPU by index: a wrong one is refused saying what there is
    for (value, says) in [("one", "give a GPU's index"), ("7", "GPU 7 was asked for")] {
        let err = propagate_refused(SMALL, &dir.path().join("x.vlf"), &[("VLF_GPU", value)]);
        assert!(
            err.contains(says) && err.contains("VLF_GPU"),
            "VLF_GPU={value}: {err}"
        );
        assert!(!dir.path().join("x.vlf").exists());
    }
}

/// `vlf propagate` of the Cornell box into `output` with `args` and `env`: it must fail; what
/// it said.
fn propagate_refused(args: &[&str], output: &std::path::Path, env: &[(&str, &str)]) -> String {
    let out = vlf()
        .arg("propagate")
        .arg(repo_path("scenes/cornell/scene.toml"))
        .args(args)
        .arg("-o")
        .arg(output)
        .envs(env.iter().copied())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{err}");
    err
}

#[test]
fn reference_compare_and_sweep_write_their_files() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo_path("scenes/cornell/scene.toml");
    let reference = dir.path().join("ref.exr");
    let variance = dir.path().join("var.exr");
    let out = vlf()
        .arg("reference")
        .arg(&scene)
        .args(["--size", "32x32", "--spp", "16", "-o"])
        .arg(&reference)
        .arg("--variance")
        .arg(&variance)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(reference.exists() && variance.exists());

    let image = dir.path().join("vlf.exr");
    let out = vlf()
        .arg("render")
        .arg(&scene)
        .args(["--size", "32x32", "--ssaa", "2", "-o"])
        .arg(&image)
        .args(SMALL)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let diff = dir.path().join("diff.png");
    let out = vlf()
        .arg("compare")
        .arg(&image)
        .arg(&reference)
        .arg("--json")
        .arg("--diff")
        .arg(&diff)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "mse",
        "rmse",
        "rel_mse",
        "max_abs",
        "display_mse",
        "flip_mean",
    ] {
        assert!(
            json[key]
                .as_f64()
                .is_some_and(|v| v.is_finite() && v >= 0.0),
            "{key}: {}",
            json[key]
        );
    }
    assert!(diff.exists());

    let sweep = dir.path().join("sweep");
    let out = vlf()
        .arg("sweep")
        .arg(&scene)
        .arg("--reference")
        .arg(&reference)
        .args([
            "--directions",
            "6,21",
            "--grid",
            "16",
            "--texel-density",
            "6",
            "--spp",
            "1,4",
            "--ssaa",
            "1",
            "--out",
        ])
        .arg(&sweep)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(sweep.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 + 2, "{csv}");
    assert!(
        csv.lines().skip(1).any(|l| l.starts_with("light field"))
            && csv.lines().any(|l| l.starts_with("path tracer"))
    );
    let png = image::open(sweep.join("sweep.png")).unwrap();
    assert!(png.width() >= 800);
}

/// Each missing file, through each command that reads one: one "error:" line that names the
/// file and states the cause once, and nothing else on stderr before it (no probing noise
/// from backends vlf does not use, such as EGL's "XDG_RUNTIME_DIR is invalid or not set").
#[test]
fn a_missing_file_is_named_with_its_cause_once_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing");
    let scene = repo_path("scenes/cornell/scene.toml");
    let png = dir.path().join("x.png");
    let cases: Vec<(&str, Vec<std::ffi::OsString>, std::path::PathBuf)> = vec![
        (
            "render a missing .vlf",
            vec![
                "render".into(),
                missing.join("a.vlf").into(),
                "-o".into(),
                png.clone().into(),
            ],
            missing.join("a.vlf"),
        ),
        (
            "propagate a missing scene",
            vec![
                "propagate".into(),
                missing.join("scene.toml").into(),
                "-o".into(),
                dir.path().join("x.vlf").into(),
            ],
            missing.join("scene.toml"),
        ),
        (
            "render with a missing --config",
            vec![
                "render".into(),
                scene.clone().into(),
                "--config".into(),
                missing.join("p.toml").into(),
                "-o".into(),
                png.clone().into(),
            ],
            missing.join("p.toml"),
        ),
        (
            "render with a missing --lightfield",
            vec![
                "render".into(),
                scene.clone().into(),
                "--lightfield".into(),
                missing.join("b.vlf").into(),
                "-o".into(),
                png.clone().into(),
            ],
            missing.join("b.vlf"),
        ),
    ];
    for (what, args, path) in cases {
        let out = vlf()
            .args(&args)
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("WGPU_BACKEND")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{what}: succeeded");
        let lines: Vec<&str> = err
            .lines()
            .filter(|l| !l.starts_with("warning: "))
            .collect();
        assert_eq!(
            lines.len(),
            1,
            "{what}: expected one error line, got:\n{err}"
        );
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(&*path.to_string_lossy()),
            "{what}: the file is not named: {err}"
        );
        assert_eq!(
            lines[0].matches("No such file or directory").count(),
            1,
            "{what}: the cause is not stated exactly once: {err}"
        );
        assert!(!err.contains("XDG_RUNTIME_DIR"), "{what}: {err}");
    }
}

/// The settings each way of asking gives, read back from the report: no flags (the software
/// preset on a software adapter, saying so and estimating the time; the default on a GPU),
/// --quality presets, flags over a preset, and --config with --quality refused.
#[test]
fn quality_presets_and_the_software_adapters_lighter_settings() {
    let dir = tempfile::tempdir().unwrap();
    let propagate = |args: &[&str]| {
        let report = dir.path().join("r.json");
        let _ = std::fs::remove_file(&report);
        let out = vlf()
            .arg("propagate")
            .arg(repo_path("scenes/cornell/scene.toml"))
            .arg("-o")
            .arg(dir.path().join("x.vlf"))
            .arg("--report")
            .arg(&report)
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{args:?}: {err}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (json, err)
    };
    let preset = |name: &str| {
        vlf::propagate::PropagationParams::from_toml_file(&repo_path(&format!(
            "config/propagation/{name}.toml"
        )))
        .unwrap()
    };
    let (json, err) = propagate(&["--max-iterations", "1"]);
    let software = json["adapter"]["software"].as_bool().unwrap();
    let expected = if software {
        preset("software")
    } else {
        preset("default")
    };
    assert_eq!(
        json["params"]["geodesic_frequency"], expected.geodesic_frequency,
        "{}",
        json["params"]
    );
    assert_eq!(json["params"]["grid_resolution"], expected.grid_resolution);
    assert_eq!(
        json["params"]["max_iterations"], 1,
        "the flag overrides the automatic choice"
    );
    assert_eq!(
        err.contains("software adapter") && err.contains("lighter settings"),
        software,
        "{err}"
    );
    assert_eq!(
        err.contains("estimate: propagating takes") && err.contains("rough model"),
        software,
        "{err}"
    );
    // the estimate reads as English: "takes under a second", "takes about 40 s"
    assert!(!err.contains("about under"), "{err}");

    let (json, err) = propagate(&["--quality", "draft"]);
    assert_eq!(
        json["params"],
        serde_json::to_value(preset("draft")).unwrap()
    );
    assert!(
        !err.contains("lighter settings"),
        "an explicit preset is not replaced: {err}"
    );
    let (json, _) = propagate(&["--quality", "draft", "--directions", "126", "--grid", "32"]);
    assert_eq!(
        (
            json["params"]["geodesic_frequency"].as_u64(),
            json["params"]["grid_resolution"].as_u64()
        ),
        (Some(5), Some(32))
    );
    assert_eq!(
        json["params"]["texel_density"],
        preset("draft").texel_density
    );

    let out = vlf()
        .arg("render")
        .arg(repo_path("scenes/cornell/scene.toml"))
        .args(["--quality", "high", "--config"])
        .arg(repo_path("config/propagation/paper.toml"))
        .args(["-o", "x.png"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--quality") && err.contains("--config"),
        "{err}"
    );
    let out = vlf()
        .arg("render")
        .arg(repo_path("scenes/cornell/scene.toml"))
        .args(["--quality", "best", "-o", "x.png"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("draft") && err.contains("high"),
        "the choices are listed: {err}"
    );
}

#[test]
fn mirrors_virtual_emitters_are_on_by_default_and_the_summary_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let propagate = |args: &[&str]| {
        let out = vlf()
            .arg("propagate")
            .arg(repo_path("scenes/cornell-mirror/scene.toml"))
            .arg("-o")
            .arg(dir.path().join("x.vlf"))
            .args(SMALL)
            .args(["--max-iterations", "2", "--direct-samples", "4"])
            .args(args)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        (out.status.success(), stdout, err)
    };
    let (ok, stdout, err) = propagate(&[]);
    assert!(ok, "{err}");
    assert!(
        stdout.contains("mirrors' virtual emitters included"),
        "{stdout}"
    );
    let (ok, stdout, err) = propagate(&["--no-mirror-direct"]);
    assert!(ok, "{err}");
    assert!(
        stdout.contains("mirrors' virtual emitters not included"),
        "{stdout}"
    );
    let (ok, _, err) = propagate(&["--mirror-direct", "--no-mirror-direct"]);
    assert!(!ok && err.contains("cannot be used with"), "{err}");
}

/// A CAVE on the software adapter, where a full-size frame takes minutes: before the first
/// frame vlf says how long its frames will take and what shortens them, then a line per frame
/// with the time left (nothing of the kind on a real GPU).
#[test]
fn a_cave_on_a_software_adapter_says_how_long_it_takes_and_shows_progress() {
    let dir = tempfile::tempdir().unwrap();
    let config = std::fs::read_to_string(repo_path("config/displays/desktop.toml"))
        .unwrap()
        .replace("pixels = [1280, 720]", "pixels = [64, 36]");
    let path = dir.path().join("desk.toml");
    std::fs::write(&path, config).unwrap();
    let out = vlf()
        .arg("cave")
        .arg(&path)
        .arg("--scene")
        .arg(repo_path("scenes/cornell/scene.toml"))
        .args(["--headless", "--frames", "2", "--out"])
        .arg(dir.path().join("out"))
        .args(SMALL)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let software = gpu().summary.software;
    assert_eq!(
        err.contains("estimate:") && err.contains("2 frames take") && err.contains("shorten it"),
        software,
        "{err}"
    );
    assert_eq!(
        err.contains("frame 1 of 2 drawn after") && err.contains("all 2 frames drawn in"),
        software,
        "{err}"
    );
    assert!(!err.contains("about under"), "{err}");
}
