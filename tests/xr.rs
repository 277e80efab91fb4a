//! OpenXR: the view math against hand-computed values, the errors without a loader or a
//! runtime, whole sessions through the system's Khronos loader on vlf's headless test runtime
//! (tests/xr-runtime: simulated headset, thumbsticks, rule checks), and a headset run on the
//! runtime XR_RUNTIME_JSON names, such as Monado or SteamVR (on the test runtime when the variable
//! is unset: it always runs).

use crate::common;

use glam::{Mat4, Vec3, Vec4};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use vlf::xr::{pose_from_view, projection_from_fov, view_from_pose, Fov, XrPose};

#[test]
fn projection_of_an_asymmetric_fov_matches_the_hand_computed_matrix() {
    let fov = Fov {
        angle_left: -45f32.to_radians(),
        angle_right: 30f32.to_radians(),
        angle_up: 20f32.to_radians(),
        angle_down: -35f32.to_radians(),
    };
    let (near, far) = (0.05f32, 100.0f32);
    let m = projection_from_fov(fov, near, far);
    // tan(-45) = -1, tan(30) = 0.577350, tan(20) = 0.363970, tan(-35) = -0.700208
    let (l, r, u, d) = (-1.0f32, 0.577_350_3, 0.363_970_2, -0.700_207_5);
    let expected = Mat4::from_cols(
        Vec4::new(2.0 / (r - l), 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 / (u - d), 0.0, 0.0),
        Vec4::new((r + l) / (r - l), (u + d) / (u - d), -100.0 / 99.95, -1.0),
        Vec4::new(0.0, 0.0, -5.0 / 99.95, 0.0),
    );
    assert!(m.abs_diff_eq(expected, 1e-5), "{m:?}\n{expected:?}");
    // the four edges of the field land on the edges of clip space, near on 0 and far on 1
    let ndc = |p: Vec3| {
        let c = m * p.extend(1.0);
        c.truncate() / c.w
    };
    assert!((ndc(Vec3::new(-1.0, 0.0, -1.0)).x + 1.0).abs() < 1e-5); // 45 degrees left
    assert!((ndc(Vec3::new(r, 0.0, -1.0)).x - 1.0).abs() < 1e-5);
    assert!((ndc(Vec3::new(0.0, u * 2.0, -2.0)).y - 1.0).abs() < 1e-5);
    assert!((ndc(Vec3::new(0.0, d, -1.0)).y + 1.0).abs() < 1e-5);
    assert!(ndc(Vec3::new(0.0, 0.0, -near)).z.abs() < 1e-5);
    assert!((ndc(Vec3::new(0.0, 0.0, -far)).z - 1.0).abs() < 1e-4);
}

#[test]
fn openxr_poses_and_views_round_trip() {
    let q = glam::Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.1);
    let pose = XrPose {
        orientation: q.to_array(),
        position: [0.3, 1.62, -0.4],
    };
    let view = view_from_pose(pose);
    // the eye sits at the view's origin, looking down its -z
    assert!(view.transform_point3(Vec3::from(pose.position)).length() < 1e-5);
    assert!((view.transform_vector3(q * Vec3::NEG_Z) - Vec3::NEG_Z).length() < 1e-5);
    let back = pose_from_view(view);
    let same_rotation = glam::Quat::from_array(back.orientation).dot(q).abs() > 1.0 - 1e-5;
    assert!(
        same_rotation && (Vec3::from(back.position) - Vec3::from(pose.position)).length() < 1e-5,
        "{back:?}"
    );
}

fn vlf_xr(envs: &[(&str, &str)]) -> (bool, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vlf"));
    cmd.args([
        "xr",
        "--scene",
        concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell/scene.toml"),
    ]);
    for (k, v) in envs {
        cmd.env(k, v);
    }
    let out = cmd.output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn without_a_loader_the_error_says_what_to_install_and_how_to_select_a_runtime() {
    let (ok, err) = vlf_xr(&[("VLF_OPENXR_LOADER", "/nonexistent/libopenxr_loader.so.1")]);
    println!("{err}");
    assert!(!ok, "vlf xr succeeded without a loader");
    assert!(!err.contains("panicked"), "{err}");
    for needle in [
        "no OpenXR loader",
        "libopenxr-loader1",
        "Monado",
        "SteamVR",
        "XR_RUNTIME_JSON",
    ] {
        assert!(err.contains(needle), "missing {needle:?} in: {err}");
    }
}

#[test]
fn without_a_runtime_the_error_names_the_selection_and_how_to_install_one() {
    let loader = [
        "/usr/lib/x86_64-linux-gnu/libopenxr_loader.so.1",
        "/usr/lib/libopenxr_loader.so.1",
    ]
    .into_iter()
    .find(|p| std::path::Path::new(p).exists());
    let Some(loader) = loader else {
        panic!("this test needs the OpenXR loader (libopenxr_loader.so.1): run `bash tools/setup.sh` or `sudo apt-get install libopenxr-loader1`");
    };
    let (ok, err) = vlf_xr(&[
        ("VLF_OPENXR_LOADER", loader),
        ("XR_RUNTIME_JSON", "/nonexistent/runtime.json"),
    ]);
    println!("{err}");
    assert!(!ok && !err.contains("panicked"), "{err}");
    for needle in [
        "no usable runtime",
        "XR_RUNTIME_JSON=/nonexistent/runtime.json",
        "Monado",
        "SteamVR",
    ] {
        assert!(err.contains(needle), "missing {needle:?} in: {err}");
    }
}

/// The eye images the test runtime recommends to every session here (`VLF_TEST_XR_EYE_PIXELS`,
/// a test may ask for others): a quarter of its default 256x224, as a software adapter draws
/// about 0.65 million eye rays a second, and what these tests check does not need more.
const EYE_PIXELS: (&str, [u32; 2]) = ("128x112", [128, 112]);

/// Small propagation settings: the session, not the light field, is under test.
const SMALL: [&str; 6] = [
    "--directions",
    "126",
    "--grid",
    "48",
    "--texel-density",
    "16",
];

fn system_loader() -> &'static str {
    ["/usr/lib/x86_64-linux-gnu/libopenxr_loader.so.1", "/usr/lib/libopenxr_loader.so.1"]
        .into_iter()
        .find(|p| Path::new(p).exists())
        .unwrap_or_else(|| panic!("the session tests need the OpenXR loader (libopenxr_loader.so.1): run `bash tools/setup.sh` or `sudo apt-get install libopenxr-loader1`"))
}

/// Build the test runtime (its own target folder, so this does not wait on the build that runs
/// the tests) and write the manifest the loader reads.
fn test_runtime() -> &'static Path {
    static MANIFEST: OnceLock<PathBuf> = OnceLock::new();
    MANIFEST.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let target = root.join("target/xr-test-runtime");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let out = Command::new(cargo)
            .args(["build", "--release", "--manifest-path"])
            .arg(root.join("tests/xr-runtime/Cargo.toml"))
            .env("CARGO_TARGET_DIR", &target)
            .output()
            .expect("cargo runs");
        assert!(out.status.success(), "building tests/xr-runtime failed:\n{}", String::from_utf8_lossy(&out.stderr));
        let library = target.join("release/libvlf_xr_test_runtime.so");
        assert!(library.exists(), "{} was not built", library.display());
        let manifest = Path::new(env!("CARGO_TARGET_TMPDIR")).join("vlf_xr_test_runtime.json");
        let json = serde_json::json!({"file_format_version": "1.0.0", "runtime": {"name": "vlf headless test runtime", "library_path": library}});
        std::fs::write(&manifest, json.to_string()).unwrap();
        manifest
    })
}

struct Session {
    ok: bool,
    stdout: String,
    stderr: String,
    report: serde_json::Value,
    runtime: std::collections::HashMap<String, String>,
    screenshot: Option<image::RgbImage>,
}

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell/scene.toml")
}

/// The Cornell box propagated at `SMALL` settings, once per run of this binary (every session
/// of it would otherwise propagate the same light field again: about 2 s each on lavapipe).
fn cornell_light_field() -> &'static Path {
    static PROPAGATED: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    PROPAGATED.get_or_init(|| {
        let vlf_file = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-shared-cornell.vlf");
        let out = Command::new(env!("CARGO_BIN_EXE_vlf"))
            .arg("propagate")
            .arg(cornell())
            .args(SMALL)
            .arg("-o")
            .arg(&vlf_file)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        vlf_file
    })
}

/// `vlf xr` on the test runtime; `name` keeps each test's files apart.
fn session(name: &str, scene: &Path, args: &[&str], envs: &[(&str, &str)]) -> Session {
    let (mut cmd, dir) = session_command(name, scene, args, envs);
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    session_ended(&dir, (out.status.success(), &out.stdout, stderr))
}

/// The command line of `vlf xr` on the test runtime, its screenshot, report and the runtime's
/// account in a fresh folder for `name` (returned).
fn session_command(
    name: &str,
    scene: &Path,
    args: &[&str],
    envs: &[(&str, &str)],
) -> (Command, PathBuf) {
    let manifest = test_runtime();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("xr-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (shot, json, runtime_report) = (
        dir.join("left.png"),
        dir.join("report.json"),
        dir.join("runtime.txt"),
    );
    // the Cornell box's light field propagated once for every session of the binary (a
    // conditions file may propagate the scene again, e.g. without global illumination: those
    // sessions need the scene itself)
    let scene = match scene == cornell() && !args.contains(&"--conditions") {
        true => cornell_light_field(),
        false => scene,
    };
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vlf"));
    cmd.arg("xr")
        .arg("--scene")
        .arg(scene)
        .args(SMALL)
        .args(args);
    cmd.arg("--json").arg(&json);
    // a test that names its own screenshot (an EXR) reads it itself
    if !args.contains(&"--screenshot") {
        cmd.arg("--screenshot").arg(&shot);
    }
    cmd.env("VLF_OPENXR_LOADER", system_loader())
        .env("XR_RUNTIME_JSON", manifest)
        .env("VLF_TEST_XR_REPORT", &runtime_report);
    cmd.env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .env("VLF_TEST_XR_EYE_PIXELS", EYE_PIXELS.0);
    for (k, v) in envs {
        cmd.env(k, v);
    }
    (cmd, dir)
}

/// What a `session_command` left in `dir` once it ended: whether it succeeded, and its output.
fn session_ended(dir: &Path, (ok, stdout, stderr): (bool, &[u8], String)) -> Session {
    let (shot, json, runtime_report) = (
        dir.join("left.png"),
        dir.join("report.json"),
        dir.join("runtime.txt"),
    );
    let stdout = String::from_utf8_lossy(stdout).into_owned();
    println!("{stdout}\n{stderr}");
    let report = std::fs::read_to_string(&json)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(serde_json::Value::Null);
    let runtime = std::fs::read_to_string(&runtime_report)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| {
            l.split_once('=')
                .map(|(k, v)| (k.to_string(), v.to_string()))
        })
        .collect();
    let screenshot = image::open(&shot).ok().map(|i| i.to_rgb8());
    Session {
        ok,
        stdout,
        stderr,
        report,
        runtime,
        screenshot,
    }
}

/// Mean display value and the share of pixels above a dim threshold.
fn brightness(img: &image::RgbImage) -> (f64, f64) {
    let n = (img.width() * img.height()) as f64;
    let values: Vec<f64> = img
        .pixels()
        .map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0)
        .collect();
    (
        values.iter().sum::<f64>() / n,
        values.iter().filter(|&&v| v > 8.0).count() as f64 / n,
    )
}

#[test]
fn a_session_runs_frames_through_the_loader_and_ends_cleanly() {
    let s = session(
        "frames",
        &cornell(),
        &["--frames", "24", "--screenshot-frame", "12"],
        &[],
    );
    assert!(
        s.ok && !s.stderr.contains("panicked"),
        "vlf xr failed: {}",
        s.stderr
    );
    // the runtime's own account: every frame ended with a valid two-view projection layer,
    // both images released each frame, no rule broken
    assert_eq!(
        s.runtime.get("violation").map(String::as_str),
        Some("none"),
        "{:?}",
        s.runtime
    );
    let count = |k: &str| {
        s.runtime
            .get(k)
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0)
    };
    assert!(count("layers_checked") >= 24, "{:?}", s.runtime);
    assert_eq!(
        count("images_released"),
        2 * count("layers_checked"),
        "{:?}",
        s.runtime
    );
    // the session went through its states in order, to the end
    let states = s.report["states"]
        .as_array()
        .expect("states in the report")
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect::<Vec<_>>()
        .join(",");
    assert!(
        states.starts_with("idle,ready,synchronized,visible,focused"),
        "{states}"
    );
    assert!(states.ends_with("stopping,idle,exiting"), "{states}");
    assert!(
        s.report["ended"]
            .as_str()
            .unwrap()
            .starts_with("cleanly, after the 24 frames"),
        "{}",
        s.report
    );
    assert_eq!(s.report["frames"], 24);
    assert!(
        s.report["frames_skipped"].as_u64().unwrap() >= 1,
        "the first frame (synchronized, not yet visible) is not to be rendered"
    );
    // the per-eye report: GPU time per eye (lavapipe has timestamps), missed frames counted
    let eyes = s.report["eyes"].as_array().unwrap();
    assert_eq!(eyes.len(), 2);
    for (eye, name) in eyes.iter().zip(["left", "right"]) {
        assert_eq!(eye["eye"], name);
        assert_eq!(eye["pixels"], serde_json::json!(EYE_PIXELS.1));
        let gpu = &eye["gpu_ms"];
        assert!(
            gpu["samples"].as_u64().unwrap() == 24
                && gpu["median"].as_f64().unwrap() > 0.0
                && gpu["max"].as_f64().unwrap() >= gpu["p99"].as_f64().unwrap(),
            "{eye}"
        );
    }
    assert!(
        s.report["missed_frames"].is_u64()
            && s.report["display_period_ms"].as_f64().unwrap() > 11.0
    );
    // the runtime converts the system clock (XR_KHR_convert_timespec_time): late frames are counted
    assert!(
        s.report["late_frames"].as_u64().is_some_and(|n| n <= 24),
        "{}",
        s.report
    );
    // the first frames one by one (a start-up burst: began late, or finished late): all 24,
    // each predicted a refresh or more after the one before, xrWaitFrame returning before it
    let first = s.report["first_frames"].as_array().unwrap();
    assert_eq!(first.len(), 24, "{}", s.report["first_frames"]);
    let display = |f: &serde_json::Value| f["display_ms"].as_f64().unwrap();
    assert_eq!(display(&first[0]), 0.0);
    for pair in first.windows(2) {
        assert!(
            display(&pair[1]) - display(&pair[0]) >= 11.0,
            "{}",
            s.report["first_frames"]
        );
        assert!(pair[1]["woke_before_display_ms"].as_f64().unwrap() > 0.0);
        assert!(pair[1]["gpu_done_before_display_ms"].is_f64());
    }
    // motion to photon as the runtime predicts it: each timed frame's pose located before its
    // predicted display time
    let photon = &s.report["pose_to_photon_ms"];
    assert!(
        photon["samples"] == 24 && photon["min"].as_f64().unwrap() > 0.0,
        "{photon}"
    );
    for needle in [
        "eye    pixels",
        "left ",
        "right ",
        "motion to photon (head pose located -> predicted display time)",
        "missed display refreshes",
        "after their predicted display time",
        "session states: idle -> ready",
    ] {
        assert!(
            s.stdout.contains(needle),
            "missing {needle:?} in the printed report:\n{}",
            s.stdout
        );
    }
    // the left eye's swapchain image, as the runtime received it: the Cornell box, not black
    let shot = s.screenshot.expect("--screenshot wrote the left eye");
    assert_eq!(shot.dimensions(), EYE_PIXELS.1.into());
    let (mean, lit) = brightness(&shot);
    println!("left eye: mean {mean:.1}, lit {:.0}%", lit * 100.0);
    assert!(
        mean > 3.0 && lit > 0.05,
        "the left eye is (nearly) black: mean {mean:.1}, lit {lit:.3}"
    );
}

#[test]
fn the_left_thumbstick_walks_the_viewer_into_the_room() {
    // lockstep display: 23 steps of 1/90 s at 1.4 m/s walk 0.36 m on any machine
    let frames = ["--frames", "24", "--screenshot-frame", "24"];
    let still = session(
        "stick-still",
        &cornell(),
        &frames,
        &[
            ("VLF_TEST_XR_LEFT_STICK", "0,0"),
            ("VLF_TEST_XR_LOCKSTEP", "1"),
        ],
    );
    let walked = session(
        "stick-forward",
        &cornell(),
        &frames,
        &[
            ("VLF_TEST_XR_LEFT_STICK", "0,1"),
            ("VLF_TEST_XR_LOCKSTEP", "1"),
        ],
    );
    assert!(still.ok && walked.ok, "{}\n{}", still.stderr, walked.stderr);
    let (_, lit_still) = brightness(&still.screenshot.unwrap());
    let (_, lit_walked) = brightness(&walked.screenshot.unwrap());
    println!("lit share: standing {lit_still:.3}, after walking forward {lit_walked:.3}");
    // 0.36 m closer to the open box from 3.9 m: it covers about (3.9 / 3.54)^2 = 1.21 times the
    // area (measured on lavapipe: 0.104 -> 0.138, 1.33 times; a stick that walks nowhere: 1.0)
    assert!(lit_walked > lit_still * 1.12, "pushing the thumbstick forward did not bring the box closer: {lit_still:.3} -> {lit_walked:.3}");
}

#[test]
fn a_saved_light_field_goes_onto_the_runtimes_device_and_the_runtime_can_end_the_session() {
    // the Cornell light field `vlf propagate` saved for this binary's sessions
    let s = session(
        "runtime-ends",
        cornell_light_field(),
        &["--screenshot-frame", "3"],
        &[("VLF_TEST_XR_END_AFTER", "8")],
    );
    assert!(s.ok, "{}", s.stderr);
    assert_eq!(
        s.runtime.get("violation").map(String::as_str),
        Some("none"),
        "{:?}",
        s.runtime
    );
    assert!(
        s.report["ended"]
            .as_str()
            .unwrap()
            .contains("the runtime or the user ended the session"),
        "{}",
        s.report
    );
    assert!(s.report["frames"].as_u64().unwrap() >= 6, "{}", s.report);
    assert!(
        !s.stderr.contains("propagated in"),
        "the saved light field was propagated again: {}",
        s.stderr
    );
    let (mean, _) = brightness(&s.screenshot.expect("left eye written"));
    assert!(
        mean > 3.0,
        "the left eye from the loaded light field is black"
    );
}

#[test]
fn a_screenshot_of_a_frame_the_session_never_reached_is_an_error() {
    let s = session(
        "late-screenshot",
        &cornell(),
        &["--screenshot-frame", "50"],
        &[("VLF_TEST_XR_END_AFTER", "5")],
    );
    assert!(!s.ok && !s.stderr.contains("panicked"), "{}", s.stderr);
    assert!(s.stderr.contains("before frame 50"), "{}", s.stderr);
}

/// The runtime of the headset run: the one XR_RUNTIME_JSON names (Monado, SteamVR) when it is
/// set, else vlf's headless test runtime, so the run always happens. A path that does not
/// exist fails the test rather than silently falling back.
fn headset_runtime() -> (PathBuf, &'static str) {
    match std::env::var_os("XR_RUNTIME_JSON") {
        Some(path) => {
            let path = PathBuf::from(path);
            assert!(
                path.exists(),
                "XR_RUNTIME_JSON={} does not exist: unset it to run on vlf's test runtime",
                path.display()
            );
            (path, "the configured runtime")
        }
        None => (
            test_runtime().to_path_buf(),
            "vlf's headless test runtime (XR_RUNTIME_JSON unset)",
        ),
    }
}

#[test]
fn a_headset_run_on_the_configured_runtime_or_else_the_test_runtime() {
    let (manifest, which) = headset_runtime();
    println!("runtime: {which}: {}", manifest.display());
    let shot = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-headset-run-left.png");
    let _ = std::fs::remove_file(&shot);
    let out = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("xr")
        .arg("--scene")
        .arg(cornell())
        .args(SMALL)
        .args(["--frames", "60", "--screenshot-frame", "30", "--screenshot"])
        .arg(&shot)
        .env("VLF_OPENXR_LOADER", system_loader())
        .env("XR_RUNTIME_JSON", &manifest)
        // read by vlf's test runtime only
        .env("VLF_TEST_XR_EYE_PIXELS", EYE_PIXELS.0)
        .output()
        .unwrap();
    let (stdout, err) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    println!("{stdout}\n{err}");
    assert!(
        out.status.success() && !err.contains("panicked"),
        "vlf xr failed on {which} ({}): {err}",
        manifest.display()
    );
    assert!(
        stdout.contains("ended: cleanly, after the 60 frames"),
        "the session did not run its 60 frames on {which}:\n{stdout}"
    );
    let (mean, lit) = brightness(
        &image::open(&shot)
            .expect("the left eye was written")
            .to_rgb8(),
    );
    assert!(
        mean > 3.0 && lit > 0.05,
        "the left eye is (nearly) black on {which}: mean {mean:.1}, lit {lit:.3}"
    );
}

#[test]
fn a_lost_session_ends_with_the_report_and_a_failing_exit_code() {
    let s = session(
        "lost",
        &cornell(),
        &["--screenshot-frame", "2"],
        &[("VLF_TEST_XR_LOSE_AFTER", "5")],
    );
    assert!(!s.ok && !s.stderr.contains("panicked"), "{}", s.stderr);
    assert!(s.stderr.contains("lost the session after"), "{}", s.stderr);
    assert!(
        s.stdout.contains(
            "session states: idle -> ready -> synchronized -> visible -> focused -> loss_pending"
        ),
        "{}",
        s.stdout
    );
    assert_eq!(s.report["lost"], true);
    assert_eq!(
        s.runtime.get("violation").map(String::as_str),
        Some("none"),
        "{:?}",
        s.runtime
    );
}

#[test]
fn ctrl_c_ends_the_session_cleanly_with_the_report() {
    let manifest = test_runtime();
    let mut child = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("xr")
        .arg("--scene")
        .arg(cornell())
        .args(SMALL)
        .env("VLF_OPENXR_LOADER", system_loader())
        .env("XR_RUNTIME_JSON", manifest)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // wait until vlf says its frames run (a fixed wait after propagation could interrupt the
    // warm-up on a loaded machine), let a few go, then interrupt as an operator would
    let stderr = child.stderr.take().unwrap();
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(stderr));
    for line in lines.by_ref() {
        if line.unwrap().starts_with("OpenXR frames: running") {
            break;
        }
    }
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let rest: Vec<String> = lines.map_while(|l| l.ok()).collect();
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}\n{}", rest.join("\n"));
    assert!(out.status.success(), "{}", rest.join("\n"));
    assert!(
        stdout.contains("ended: cleanly, interrupted (Ctrl-C)")
            && stdout.contains("stopping -> idle -> exiting"),
        "{stdout}"
    );
}

#[test]
fn the_resolution_scale_sets_the_swapchain_size() {
    let s = session(
        "scale",
        &cornell(),
        &[
            "--frames",
            "4",
            "--screenshot-frame",
            "4",
            "--resolution-scale",
            "1.5",
        ],
        &[],
    );
    assert!(s.ok, "{}", s.stderr);
    // the test runtime recommends EYE_PIXELS (128x112) per eye
    assert_eq!(
        s.report["eyes"][0]["pixels"],
        serde_json::json!([192, 168]),
        "{}",
        s.report
    );
    assert_eq!(
        s.screenshot.expect("left eye written").dimensions(),
        (192, 168)
    );
    assert_eq!(
        s.runtime.get("violation").map(String::as_str),
        Some("none"),
        "{:?}",
        s.runtime
    );
    let bad = session("scale-bad", &cornell(), &["--resolution-scale", "0"], &[]);
    assert!(
        !bad.ok && bad.stderr.contains("--resolution-scale 0"),
        "{}",
        bad.stderr
    );
}

/// `--fit-frame-time`: the first frame probes both eyes against the runtime's period and shows
/// nothing (an empty frame, within the rules), then the eyes are paced; the report says what was
/// probed and drawn. On a fast enough adapter 1 eye ray fits the tiny eyes and the pacer runs;
/// on a slow one the report must say that nothing fitted.
#[test]
fn fitting_the_frame_time_probes_the_first_frame_then_paces_the_eyes() {
    let s = session(
        "fit",
        &cornell(),
        &[
            "--frames",
            "16",
            "--screenshot-frame",
            "8",
            "--fit-frame-time",
        ],
        &[("VLF_TEST_XR_EYE_PIXELS", "24x24")],
    );
    assert!(
        s.ok && !s.stderr.contains("panicked"),
        "vlf xr failed: {}",
        s.stderr
    );
    assert_eq!(
        s.runtime.get("violation").map(String::as_str),
        Some("none"),
        "{:?}",
        s.runtime
    );
    let fit = &s.report["fit"];
    let probes = fit["probes"]
        .as_array()
        .expect("the fit's probes in the JSON");
    assert_eq!(probes[0]["eye_rays_per_pixel"], 1, "{fit}");
    assert!(
        (fit["budget_ms"].as_f64().unwrap() - 1000.0 / 90.0).abs() < 0.01,
        "{fit}"
    );
    assert!(
        s.stdout.contains("frame time fit: budget 11.11 ms"),
        "{}",
        s.stdout
    );
    if fit["fits"].as_bool().unwrap() {
        let rays = s.report["pacer"]["eye_rays_per_pixel"]
            .as_array()
            .expect("paced");
        assert_eq!(rays.len(), 2);
        assert_eq!(s.report["quality"]["paced_eye_rays_per_pixel"], 16);
        assert!(
            s.stdout.contains("frame pacing: views held at"),
            "{}",
            s.stdout
        );
    } else {
        assert!(s.report["pacer"].is_null() && s.stdout.contains("NOTHING FITS"));
    }
    // the probing frame is not one of the 16 timed frames, and the picture still shows the box
    assert!(s.report["ended"]
        .as_str()
        .unwrap()
        .starts_with("cleanly, after the 16 frames"));
    let (mean, _) = brightness(s.screenshot.as_ref().expect("a screenshot"));
    assert!(mean > 5.0, "the left eye is black");
}

/// A session of `frames` frames with the head standing still and the display in lockstep, so
/// that two runs see the same views; the left eye of its last frame.
fn still_session(name: &str, args: &[&str], envs: &[(&str, &str)]) -> Session {
    let mut all_args = vec!["--frames", "6", "--screenshot-frame", "6"];
    all_args.extend_from_slice(args);
    let mut all_envs = vec![
        ("VLF_TEST_XR_STILL_HEAD", "1"),
        ("VLF_TEST_XR_LOCKSTEP", "1"),
    ];
    all_envs.extend_from_slice(envs);
    let s = session(name, &cornell(), &all_args, &all_envs);
    assert!(s.ok && !s.stderr.contains("panicked"), "{}", s.stderr);
    assert_eq!(
        s.runtime.get("violation").map(String::as_str),
        Some("none"),
        "{:?}",
        s.runtime
    );
    s
}

fn runtime_count(s: &Session, key: &str) -> u64 {
    s.runtime
        .get(key)
        .and_then(|v| v.parse::<u64>().ok())
        .unwrap_or_else(|| panic!("{key} not in the runtime's report: {:?}", s.runtime))
}

/// The largest difference of any channel of any pixel between two screenshots.
fn max_difference(a: &image::RgbImage, b: &image::RgbImage) -> u8 {
    assert_eq!(a.dimensions(), b.dimensions());
    (a.as_raw().iter().zip(b.as_raw()))
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0)
}

#[test]
fn both_eyes_go_on_one_array_swapchain_in_one_multiview_pass_with_depth_as_the_per_eye_path_shows_them(
) {
    let array = still_session("array", &[], &[]);
    // vlf says which path ran, and the runtime saw the same
    let r = &array.report;
    assert_eq!(r["swapchains"], "array", "{r}");
    // one multiview pass where the device's multiview passes vlf's check (Mesa 22's lavapipe
    // draws only the first layer and fails it), else a pass per layer, and the report says why
    let eye_layers = r["eye_layers"].as_str().unwrap();
    let expected = match r["multiview"].as_bool().unwrap() {
        true => "one array swapchain (2 layers), both eyes in one pass (multiview)",
        false => "one array swapchain (2 layers), a pass per layer (",
    };
    assert!(eye_layers.starts_with(expected), "{r}");
    println!("eyes: {eye_layers}");
    assert_eq!(r["depth_submitted"], true, "{r}");
    assert!(
        r["depth"]
            .as_str()
            .unwrap()
            .starts_with("submitted (XR_KHR_composition_layer_depth"),
        "{r}"
    );
    assert!(
        array.stdout.contains(&format!("eyes: {eye_layers}"))
            && array.stdout.contains("depth: submitted"),
        "{}",
        array.stdout
    );
    let rt = &array.runtime;
    assert_eq!(rt["swapchains"], "1 array (2 layers) + depth", "{rt:?}");
    assert_eq!(rt["depth_extension"], "enabled", "{rt:?}");
    // every view of every frame carried its depth; one colour and one depth image released a frame
    let layers = runtime_count(&array, "layers_checked");
    assert!(layers >= 6, "{rt:?}");
    assert_eq!(runtime_count(&array, "depth_views"), 2 * layers, "{rt:?}");
    assert_eq!(runtime_count(&array, "views_without_depth"), 0, "{rt:?}");
    assert_eq!(
        runtime_count(&array, "images_released"),
        2 * layers,
        "{rt:?}"
    );
    // the left eye's depth as the runtime read it back: within [0, 1], the box in front (its
    // nearest point a few metres away with near 0.05 m and far 500 m), the black around it far
    let value = |k: &str| rt[k].parse::<f64>().unwrap();
    assert_eq!(value("depth_left_outside_share"), 0.0, "{rt:?}");
    let (near, far) = (0.05, 500.0);
    let metres = |z: f64| near * far / (far - z * (far - near));
    let nearest = metres(value("depth_left_min"));
    println!(
        "left eye depth: nearest {nearest:.2} m, {:.0}% far",
        value("depth_left_far_share") * 100.0
    );
    assert!(
        (1.0..20.0).contains(&nearest),
        "nearest {nearest} m: {rt:?}"
    );
    assert_eq!(value("depth_left_max"), 1.0, "{rt:?}");
    let far_share = value("depth_left_far_share");
    assert!(far_share > 0.2 && far_share < 0.98, "{rt:?}");
    // the right layer holds the right eye: its depth differs from the left's where the eyes'
    // parallax moves an edge or changes a distance (0 if the multiview pass gave a layer the
    // wrong eye)
    let differ = value("depth_eyes_differ_share");
    assert!(differ > 0.01, "the eyes' depths are alike: {rt:?}");

    // the fallback, forced: a swapchain per eye, each with its depth; the same picture
    let per_eye = still_session("per-eye", &["--swapchains", "per-eye"], &[]);
    assert_eq!(per_eye.report["swapchains"], "per-eye");
    assert_eq!(per_eye.report["multiview"], false);
    assert_eq!(
        per_eye.report["eye_layers"],
        "per-eye swapchains (--swapchains per-eye)"
    );
    assert_eq!(per_eye.runtime["swapchains"], "2 per-eye + depth");
    let layers = runtime_count(&per_eye, "layers_checked");
    assert_eq!(runtime_count(&per_eye, "depth_views"), 2 * layers);
    assert_eq!(runtime_count(&per_eye, "images_released"), 4 * layers);
    // the right eye's depth as the per-eye path submits it
    let right_mean = |s: &Session| s.runtime["depth_right_mean"].parse::<f64>().unwrap();
    assert!(
        (right_mean(&array) - right_mean(&per_eye)).abs() < 1e-6,
        "right eye depth: array {} per-eye {}",
        right_mean(&array),
        right_mean(&per_eye)
    );
    let (a, b) = (array.screenshot.unwrap(), per_eye.screenshot.unwrap());
    let (mean, lit) = brightness(&a);
    assert!(
        mean > 3.0 && lit > 0.02,
        "the left eye is black: {mean} {lit}"
    );
    let diff = max_difference(&a, &b);
    assert!(
        diff <= 1,
        "the array and per-eye left eyes differ by up to {diff}"
    );
}

#[test]
fn the_compute_colour_pass_puts_on_the_swapchains_what_the_fragment_pass_does() {
    let eyes = |s: &Session| s.report["eye_layers"].as_str().unwrap().to_string();
    // on the runtime's 8-bit sRGB swapchain: a compute pass and a copy, the fragment pass writing
    // the depth alone
    let compute = still_session("colour-compute", &["--layer-colour", "compute"], &[]);
    assert!(
        eyes(&compute)
            .ends_with("; the colour by a compute pass and a copy, the depth by the fragment pass"),
        "{}",
        compute.report
    );
    // the default: one fragment pass
    let fragment = still_session("colour-fragment", &[], &[]);
    assert!(!eyes(&fragment).contains("compute"), "{}", fragment.report);
    // the same picture within the last bit (the shader's sRGB encoding against the format's)
    let reference = fragment.screenshot.as_ref().unwrap();
    let (mean, lit) = brightness(reference);
    assert!(
        mean > 3.0 && lit > 0.02,
        "the left eye is black: {mean} {lit}"
    );
    let diff = max_difference(compute.screenshot.as_ref().unwrap(), reference);
    assert!(
        diff <= 1,
        "compute and fragment colour differ by up to {diff}"
    );
    // and the same depth in both eyes, as the runtime read it back
    for key in ["depth_left_min", "depth_left_far_share", "depth_right_mean"] {
        let mean = |s: &Session| s.runtime[key].parse::<f64>().unwrap();
        assert!(
            (mean(&compute) - mean(&fragment)).abs() < 1e-6,
            "{key}: compute {} fragment {}",
            mean(&compute),
            mean(&fragment)
        );
    }
    // without depth there is no fragment pass at all: the same picture
    let alone = still_session(
        "colour-compute-alone",
        &["--layer-colour", "compute"],
        &[("VLF_TEST_XR_NO_DEPTH", "1")],
    );
    assert!(
        eyes(&alone).ends_with("; the colour by a compute pass and a copy, no fragment pass"),
        "{}",
        alone.report
    );
    let diff = max_difference(alone.screenshot.as_ref().unwrap(), reference);
    assert!(
        diff <= 1,
        "compute without depth and fragment differ by up to {diff}"
    );
    // a runtime whose swapchains take no copies: the fragment pass, and the report says why
    let refused = still_session(
        "colour-no-copies",
        &["--layer-colour", "compute"],
        &[("VLF_TEST_XR_NO_COPY_DST", "1")],
    );
    assert!(
        eyes(&refused).contains(
            "; the colour by the fragment pass (the runtime refused swapchains that take copies"
        ),
        "{}",
        refused.report
    );
    assert_eq!(refused.report["swapchains"], "array", "{}", refused.report);
    let diff = max_difference(refused.screenshot.as_ref().unwrap(), reference);
    assert_eq!(
        diff, 0,
        "the fallback and the fragment pass differ by up to {diff}"
    );
}

#[test]
fn a_runtime_without_depth_layers_gets_none_and_the_report_says_so() {
    let s = still_session("no-depth", &[], &[("VLF_TEST_XR_NO_DEPTH", "1")]);
    assert_eq!(s.report["depth_submitted"], false, "{}", s.report);
    assert_eq!(
        s.report["depth"],
        "not offered by the runtime (no XR_KHR_composition_layer_depth)"
    );
    assert!(
        s.stdout.contains("depth: not offered by the runtime"),
        "{}",
        s.stdout
    );
    assert_eq!(s.report["swapchains"], "array");
    assert_eq!(s.runtime["depth_extension"], "not offered");
    assert_eq!(s.runtime["swapchains"], "1 array (2 layers)");
    assert_eq!(runtime_count(&s, "depth_views"), 0);
    assert_eq!(runtime_count(&s, "depth_swapchains"), 0);
}

#[test]
fn a_runtime_refusing_array_swapchains_gets_one_per_eye_and_the_report_says_why() {
    let s = still_session("no-array", &[], &[("VLF_TEST_XR_NO_ARRAY", "1")]);
    assert_eq!(s.report["swapchains"], "per-eye", "{}", s.report);
    assert!(
        s.report["eye_layers"]
            .as_str()
            .unwrap()
            .starts_with("per-eye swapchains (the runtime refused an array swapchain"),
        "{}",
        s.report
    );
    assert_eq!(runtime_count(&s, "arrays_refused"), 1);
    assert_eq!(s.runtime["swapchains"], "2 per-eye + depth");
    assert_eq!(runtime_count(&s, "views_without_depth"), 0);
    let (mean, _) = brightness(&s.screenshot.expect("left eye written"));
    assert!(mean > 3.0, "the left eye is black");
    // insisting on the array is an error that says what to do
    let insist = session(
        "no-array-insist",
        &cornell(),
        &[
            "--frames",
            "2",
            "--screenshot-frame",
            "1",
            "--swapchains",
            "array",
        ],
        &[("VLF_TEST_XR_NO_ARRAY", "1")],
    );
    assert!(
        !insist.ok && !insist.stderr.contains("panicked"),
        "{}",
        insist.stderr
    );
    assert!(
        insist.stderr.contains("refused an array swapchain")
            && insist.stderr.contains("--swapchains auto"),
        "{}",
        insist.stderr
    );
}

/// The shipped headset body (config/headset/body.toml) as text, its mesh's path made absolute
/// (for copies written elsewhere).
fn shipped_headset_body_text() -> String {
    std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/headset/body.toml"
    ))
    .unwrap()
    .replace(
        "../../assets",
        concat!(env!("CARGO_MANIFEST_DIR"), "/assets"),
    )
}

/// The shipped headset body with few light probes (`common::LIGHT_PROBE_KEYS`), written once:
/// what these tests check (the hands on the grips, the arm hanging, logging and replay) does not
/// depend on how finely the body is lit.
fn headset_body() -> String {
    static BODY: OnceLock<PathBuf> = OnceLock::new();
    let path = BODY.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-lighter-body");
        std::fs::create_dir_all(&dir).unwrap();
        let text = shipped_headset_body_text();
        assert!(
            text.trim_end().ends_with("sky_shadow_samples = 2"),
            "config/headset/body.toml no longer ends with its [object_lighting] table: {text}"
        );
        let path = dir.join("body.toml");
        std::fs::write(&path, text + common::LIGHT_PROBE_KEYS).unwrap();
        path
    });
    path.display().to_string()
}

/// The scripted grips (stage metres, and yaw, pitch, roll in degrees): both hands reach forward
/// and down into the left eye's view.
const LEFT_GRIP: ([f32; 3], [f32; 3]) = ([-0.2, 1.4, -0.4], [0.0, 30.0, 0.0]);
const RIGHT_GRIP: ([f32; 3], [f32; 3]) = ([0.15, 1.35, -0.35], [-20.0, 10.0, 5.0]);

fn grip_env((p, a): ([f32; 3], [f32; 3])) -> String {
    format!("{},{},{},{},{},{}", p[0], p[1], p[2], a[0], a[1], a[2])
}

/// A scripted grip as the runtime reports it in the stage.
fn stage_grip((p, a): ([f32; 3], [f32; 3])) -> glam::Affine3A {
    let rotation = glam::Quat::from_rotation_y(a[0].to_radians())
        * glam::Quat::from_rotation_x(a[1].to_radians())
        * glam::Quat::from_rotation_z(a[2].to_radians());
    glam::Affine3A::from_rotation_translation(rotation, Vec3::from(p))
}

fn vec3(v: &serde_json::Value) -> Vec3 {
    let f = |i: usize| v[i].as_f64().unwrap_or(f64::NAN) as f32;
    Vec3::new(f(0), f(1), f(2))
}

fn world_pose(v: &serde_json::Value) -> Option<glam::Affine3A> {
    let p = &v["position"];
    let o = &v["orientation"];
    (!v.is_null()).then(|| {
        let q = glam::Quat::from_xyzw(
            o[0].as_f64().unwrap() as f32,
            o[1].as_f64().unwrap() as f32,
            o[2].as_f64().unwrap() as f32,
            o[3].as_f64().unwrap() as f32,
        );
        glam::Affine3A::from_rotation_translation(q, vec3(p))
    })
}

/// The body's last frame as the report gives it: the world from the stage, the head, the grips
/// and the avatar's hands; each grip checked against the scripted one moved into the world.
fn body_of(s: &Session, grips: [Option<([f32; 3], [f32; 3])>; 2]) -> serde_json::Value {
    let body = s.report["body"].clone();
    let frames = s.report["frames"].as_u64().unwrap();
    assert_eq!(body["objects"], serde_json::json!(["body"]), "{body}");
    let last = body["last"].clone();
    let world = glam::Affine3A::from_rotation_translation(
        glam::Quat::from_rotation_y((last["room_yaw_deg"].as_f64().unwrap() as f32).to_radians()),
        vec3(&last["room_position"]),
    );
    // the still head: between the eyes at 1.6 m, looking along the stage's -z
    let head = world_pose(&last["head"]).unwrap();
    let expected = world * glam::Affine3A::from_translation(Vec3::new(0.0, 1.6, 0.0));
    assert!(head.abs_diff_eq(expected, 1e-4), "{head:?} {expected:?}");
    for (side, grip) in ["left", "right"].iter().zip(grips) {
        let located = body[format!("frames_with_{side}_grip")].as_u64().unwrap();
        let reported = world_pose(&last[format!("{side}_grip")]);
        match grip {
            Some(g) => {
                assert_eq!(located, frames, "{side}: {body}");
                let reported = reported.expect("a located grip in the report");
                let expected = world * stage_grip(g);
                assert!(
                    reported.abs_diff_eq(expected, 1e-4),
                    "{side} grip {reported:?}, scripted {expected:?}"
                );
            }
            None => assert!(located == 0 && reported.is_none(), "{side}: {body}"),
        }
    }
    last
}

/// The avatar's hand joints from the same head and grips, posed here on the CPU by the shipped
/// avatar; the report's hands must agree within 1 mm.
fn check_hands_against_the_rig(last: &serde_json::Value) -> [Vec3; 2] {
    let avatar = vlf::dynamic::avatar::Avatar::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/avatar/mannequin.glb"),
    )
    .unwrap();
    let head = world_pose(&last["head"]).unwrap();
    let (left, right) = (
        world_pose(&last["left_grip"]),
        world_pose(&last["right_grip"]),
    );
    let joints = avatar.pose_joints(head, left, right);
    let hands = [
        vlf::dynamic::avatar::Role::HandLeft,
        vlf::dynamic::avatar::Role::HandRight,
    ]
    .map(|r| Vec3::from(joints[avatar.joint(r).unwrap()].translation));
    let reported = [
        vec3(&last["avatar_hands"][0]),
        vec3(&last["avatar_hands"][1]),
    ];
    for (cpu, drawn) in hands.iter().zip(&reported) {
        assert!(
            cpu.distance(*drawn) < 1e-3,
            "posed here {cpu}, drawn {drawn}"
        );
    }
    reported
}

/// Where a stage point falls in the still head's left eye image, in pixels.
fn in_left_eye(point: Vec3, [width, height]: [u32; 2]) -> (i32, i32) {
    let fov = Fov {
        angle_left: -0.942,
        angle_right: 0.698,
        angle_up: 0.768,
        angle_down: -0.855,
    };
    let eye = XrPose {
        orientation: [0.0, 0.0, 0.0, 1.0],
        position: [-0.032, 1.6, 0.0],
    };
    let clip = projection_from_fov(fov, 0.05, 100.0) * view_from_pose(eye) * point.extend(1.0);
    let ndc = clip.truncate() / clip.w;
    (
        ((ndc.x + 1.0) * 0.5 * width as f32) as i32,
        ((1.0 - ndc.y) * 0.5 * height as f32) as i32,
    )
}

#[test]
fn the_headset_draws_the_body_with_its_hands_on_the_controllers_grips() {
    let (left, right) = (grip_env(LEFT_GRIP), grip_env(RIGHT_GRIP));
    let grips = [
        ("VLF_TEST_XR_LEFT_GRIP", left.as_str()),
        ("VLF_TEST_XR_RIGHT_GRIP", right.as_str()),
    ];
    let body = headset_body();
    let with = still_session("body", &["--objects", &body], &grips);
    let without = still_session("no-body", &[], &grips);
    assert!(without.report.get("body").is_none(), "{}", without.report);
    // the moving objects' pass is timed in the headset's frames in flight (its pacer makes room
    // for it) as a pass of its own: every eye keeps a time per timed frame
    let frames = with.report["frames"].as_u64().unwrap();
    let objects = &with.report["objects_gpu_ms"];
    assert!(
        objects["samples"].as_u64() == Some(frames) && objects["median"].as_f64() > Some(0.0),
        "{}",
        with.report
    );
    for eye in with.report["eyes"].as_array().unwrap() {
        assert_eq!(eye["gpu_ms"]["samples"].as_u64(), Some(frames), "{eye}");
    }
    assert!(without.report["objects_gpu_ms"].is_null());
    assert!(
        with.stdout
            .contains("objects: body; left grip located in 6 frames, right grip in 6 of 6"),
        "{}",
        with.stdout
    );
    let last = body_of(&with, [Some(LEFT_GRIP), Some(RIGHT_GRIP)]);
    let hands = check_hands_against_the_rig(&last);
    // both grips are within the arms' reach: the hands are on them
    for (hand, grip) in hands.iter().zip(["left_grip", "right_grip"]) {
        let at = world_pose(&last[grip]).unwrap().translation;
        assert!(
            hand.distance(at.into()) < 1e-3,
            "{grip}: hand at {hand}, grip at {at}"
        );
    }
    // the picture: where each hand is, the body is drawn; above the eyes' height (the arms are
    // all below it, and they shadow nothing the eye sees there) the picture is the same
    let (a, b) = (with.screenshot.unwrap(), without.screenshot.unwrap());
    let size = [a.width(), a.height()];
    let differs = |x: i32, y: i32| {
        let (p, q) = (
            a.get_pixel(x as u32, y as u32),
            b.get_pixel(x as u32, y as u32),
        );
        (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0)
    };
    for g in [LEFT_GRIP, RIGHT_GRIP] {
        let (x, y) = in_left_eye(Vec3::from(g.0), size);
        let near: Vec<u8> = (-3..=3)
            .flat_map(|dy| (-3..=3).map(move |dx| (x + dx, y + dy)))
            .map(|(x, y)| differs(x, y))
            .collect();
        let changed = near.iter().filter(|&&d| d > 24).count();
        println!(
            "grip {:?} at pixel ({x}, {y}): {changed} of 49 pixels around it changed",
            g.0
        );
        assert!(
            changed >= 40,
            "the hand at {:?} is not drawn at ({x}, {y})",
            g.0
        );
    }
    let (_, horizon) = in_left_eye(Vec3::new(0.0, 1.6, -1.0), size);
    let above = (0..horizon - 2)
        .flat_map(|y| (0..size[0] as i32).map(move |x| (x, y)))
        .map(|(x, y)| differs(x, y))
        .max()
        .unwrap_or(0);
    let below = (horizon..size[1] as i32)
        .flat_map(|y| (0..size[0] as i32).map(move |x| (x, y)))
        .filter(|&(x, y)| differs(x, y) > 24)
        .count();
    println!("above the eyes' height (rows 0..{}) the largest difference is {above}; below, {below} pixels changed", horizon - 2);
    assert_eq!(
        above, 0,
        "the body changed the picture above the eyes' height"
    );
    assert!(below > 500, "{below} pixels of the arms");
}

#[test]
fn an_untracked_controllers_arm_hangs() {
    let right = grip_env(RIGHT_GRIP);
    let body = headset_body();
    let s = still_session(
        "body-one-hand",
        &["--objects", &body],
        &[("VLF_TEST_XR_RIGHT_GRIP", right.as_str())],
    );
    let last = body_of(&s, [None, Some(RIGHT_GRIP)]);
    let [left, right] = check_hands_against_the_rig(&last);
    let head = world_pose(&last["head"]).unwrap().translation;
    let right_grip = world_pose(&last["right_grip"]).unwrap().translation;
    assert!(right.distance(right_grip.into()) < 1e-3);
    // the left hand hangs: beside the body, well below the shoulders, not ahead of it
    let below_eyes = head.y - left.y;
    println!(
        "the hanging left hand: {below_eyes} m below the eyes, {} m to the left",
        head.x - left.x
    );
    assert!(below_eyes > 0.6, "{left} under a head at {head}");
    assert!(
        head.x - left.x > 0.1 && (left.z - head.z).abs() < 0.2,
        "{left}"
    );
}

#[test]
fn a_bad_key_in_the_objects_file_is_named_before_any_runtime_starts() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-bad-objects");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("body.toml");
    let text = shipped_headset_body_text();
    for (bad, needle) in [
        (text.replace("scale = 1.0", "scael = 1.0"), "scael"),
        (
            text.replace("shadow_samples = 4", "shadow_samples = 4\nprobe_rays = 100"),
            "probe_rays = 100",
        ),
        (
            text.replace(
                "kind = \"avatar\"",
                "kind = \"avatar\"\nfollow = \"left_foot\"",
            ),
            "left_foot",
        ),
    ] {
        std::fs::write(&path, bad).unwrap();
        // no loader: the file is read first
        let (ok, err) = {
            let out = Command::new(env!("CARGO_BIN_EXE_vlf"))
                .args(["xr", "--scene"])
                .arg(cornell())
                .arg("--objects")
                .arg(&path)
                .env("VLF_OPENXR_LOADER", "/nonexistent/libopenxr_loader.so.1")
                .output()
                .unwrap();
            (
                out.status.success(),
                String::from_utf8_lossy(&out.stderr).into_owned(),
            )
        };
        println!("{err}");
        assert!(!ok && !err.contains("panicked"), "{err}");
        assert!(
            err.contains("body.toml") && err.contains(needle),
            "{needle} not named: {err}"
        );
        assert!(
            !err.contains("OpenXR loader"),
            "the runtime was tried first: {err}"
        );
    }
}

/// `vlf xr` on the test runtime (`name`, `args`, `envs` as `session_command`) under a script:
/// each of `commands` sent once the one before was acknowledged (the last must end the
/// session); the replies, and the session once it ended.
fn scripted_session(
    name: &str,
    (args, envs): (&[&str], &[(&str, &str)]),
    commands: &[&str],
) -> (Vec<serde_json::Value>, Session) {
    use std::io::{BufRead, Write};
    let (mut cmd, out_dir) = session_command(name, &cornell(), args, envs);
    let mut child = (cmd.stdout(std::process::Stdio::piped()))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let (mut addr, mut said, mut line) = (None, String::new(), String::new());
    while addr.is_none() && stderr.read_line(&mut line).unwrap() > 0 {
        addr = (line.strip_prefix("control: listening on ")).map(|a| a.trim().to_string());
        said.push_str(&line);
        line.clear();
    }
    let addr = addr.unwrap_or_else(|| panic!("vlf xr never said where it listens:\n{said}"));
    let rest = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = std::io::Read::read_to_string(&mut stderr, &mut text);
        text
    });
    let mut client = std::net::TcpStream::connect(&addr).unwrap();
    let mut replies = std::io::BufReader::new(client.try_clone().unwrap());
    let mut got: Vec<serde_json::Value> = Vec::new();
    for command in commands {
        writeln!(client, "{command}").unwrap();
        let mut reply = String::new();
        replies.read_line(&mut reply).unwrap();
        got.push(serde_json::from_str(&reply).unwrap());
    }
    let status = child.wait().unwrap();
    let mut stdout = Vec::new();
    std::io::Read::read_to_end(&mut child.stdout.take().unwrap(), &mut stdout).unwrap();
    let s = session_ended(
        &out_dir,
        (status.success(), &stdout, said + &rest.join().unwrap()),
    );
    (got, s)
}

/// `vlf xr`'s arguments for a session an experiment script ends (`stop`) over `--control` on a
/// free port, logged into `log`, with `extra`.
fn scripted_args<'a, const N: usize>(log: &'a str, extra: [&'a str; N]) -> Vec<&'a str> {
    let mut args = vec!["--frames", "100000", "--screenshot-frame", "1"];
    args.extend(["--control", "127.0.0.1:0", "--log", log]);
    args.extend(extra);
    args
}

/// The headset's study tools, as the CAVE's: a script over `vlf xr --control` sends an event,
/// hides and shows the body, asks for the latency test's flash and a condition (both refused,
/// saying why, nothing changed), asks for the state and stops the session, each command
/// acknowledged with its frame; `--log` writes a row per frame drawn with the head between the
/// eyes, the controllers' grips in the stage, the body hidden exactly from the hide's frame to
/// the show's, the event in its frame's row and the runtime's predicted display time; the
/// Parquet equals the CSV; `vlf replay` of a headset's log is refused, saying why.
#[test]
fn a_script_controls_a_headset_session_and_its_log_has_every_frame() {
    let (left, right) = (grip_env(LEFT_GRIP), grip_env(RIGHT_GRIP));
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-study-log");
    let _ = std::fs::remove_dir_all(&dir);
    let log = dir.join("log");
    let body = headset_body();
    let args = scripted_args(log.to_str().unwrap(), ["--objects", &body]);
    let envs = [
        ("VLF_TEST_XR_STILL_HEAD", "1"),
        ("VLF_TEST_XR_LEFT_GRIP", left.as_str()),
        ("VLF_TEST_XR_RIGHT_GRIP", right.as_str()),
    ];
    let commands = [
        r#"{"cmd": "event", "text": "trial 1 begins"}"#,
        r#"{"cmd": "hide", "object": "body"}"#,
        r#"{"cmd": "flash"}"#,
        r#"{"cmd": "condition", "name": "gi-off"}"#,
        r#"{"cmd": "state"}"#,
        r#"{"cmd": "show", "object": "body"}"#,
        r#"{"cmd": "stop"}"#,
    ];
    let (got, s) = scripted_session("study", (&args, &envs), &commands);
    assert!(s.ok && !s.stderr.contains("panicked"), "{}", s.stderr);
    assert_eq!(s.runtime.get("violation").map(String::as_str), Some("none"));
    // acknowledged with their frames, in order; flash and condition refused with the reason
    let ok: Vec<bool> = got.iter().map(|r| r["ok"] == true).collect();
    assert_eq!(ok, [true, true, false, false, true, true, true], "{got:?}");
    let flash = got[2]["error"].as_str().unwrap();
    assert!(
        flash.contains("headset") && flash.contains("latency"),
        "{flash}"
    );
    let condition = got[3]["error"].as_str().unwrap();
    assert!(condition.contains("[[condition]]"), "{condition}");
    let frame = |i: usize| got[i]["frame"].as_u64().unwrap();
    let (event, hide, state, show, stop) = (frame(0), frame(1), frame(4), frame(5), frame(6));
    assert!(
        event < hide && hide < state && state < show && show < stop,
        "{got:?}"
    );
    assert_eq!(got[4]["logging"], true, "{}", got[4]);

    // the log: a row for every frame drawn up to the stop
    let (meta, records) = vlf::study::SessionLog::read(&log).unwrap();
    assert!(
        meta.headset.as_deref().unwrap().contains("vlf"),
        "{:?}",
        meta.headset
    );
    assert_eq!(meta.views, ["headset-left", "headset-right"]);
    let frames: Vec<u64> = records.iter().map(|r| r.frame).collect();
    // (the runtime may ask for a frame or two more between the stop and the session's end)
    let counted: Vec<u64> = (0..records.len() as u64).collect();
    assert!(
        frames == counted && stop < records.len() as u64,
        "{frames:?}, stop {stop}"
    );
    assert_eq!(
        s.report["frames"].as_u64(),
        Some(records.len() as u64),
        "{}",
        s.report
    );
    let at = |f: u64| &records[f as usize];
    assert!(at(event).events.contains("trial 1 begins"));
    assert!(at(hide).events.contains("hide body"));
    let (lg, rg) = (stage_grip(LEFT_GRIP), stage_grip(RIGHT_GRIP));
    for r in &records {
        let hidden: &[&str] = if (hide..show).contains(&r.frame) {
            &["body"]
        } else {
            &[]
        };
        assert_eq!(
            r.objects.as_ref().unwrap().hidden,
            hidden,
            "frame {}",
            r.frame
        );
        // the still head between the eyes at 1.6 m; the grips where the runtime put them
        assert!(
            (r.pose.head - Vec3::new(0.0, 1.6, 0.0)).length() < 1e-4,
            "{:?}",
            r.pose
        );
        let close = |w: &Option<vlf::tracking::WandPose>, g: glam::Affine3A| {
            let w = w.expect("a located grip");
            (w.position - Vec3::from(g.translation)).length() < 1e-4
        };
        assert!(close(&r.left_hand, lg) && close(&r.wand, rg), "{r:?}");
        assert_eq!(r.views.len(), 2);
        let (submit, photon) = (r.pose_to_submit_ms.unwrap(), r.pose_to_photon_ms.unwrap());
        assert!(submit >= 0.0 && photon.is_finite(), "{r:?}");
        assert!(r.object_time_s.is_some());
    }
    // motion to photon: each row to the runtime's predicted display time, as the report has it
    let photon: Vec<f64> = records
        .iter()
        .map(|r| r.pose_to_photon_ms.unwrap())
        .collect();
    let logged = vlf::stats::Distribution::of(&photon);
    let reported = &s.report["pose_to_photon_ms"];
    eprintln!(
        "headset log: {} frames; event at {event}, hide {hide}, state {state}, show {show}, stop {stop}; pose_to_photon_ms median {:.3} (report {})",
        records.len(),
        logged.median,
        reported["median"]
    );
    assert!(logged.min > 0.0, "{logged:?}");
    assert_eq!(reported["samples"].as_u64(), Some(records.len() as u64));
    let off = (logged.median - reported["median"].as_f64().unwrap()).abs();
    assert!(off < 0.05, "log {logged:?}, report {reported}");
    let check = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tools/study/parquet_check.py"
        ))
        .arg(&log)
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
}

/// `vlf xr --lsl`: the shipped pylsl example (tools/study/lsl_example.py) reads vlf.pose,
/// vlf.frames and vlf.events off a headset session while it sends an event, a trial and stop
/// over `--control`; the pose stream's timestamps rise, every pose sample is its frame's row of
/// the session log (the head between the eyes), and the event is a marker.
#[test]
fn a_headset_sessions_lsl_outlets_carry_its_logged_frames() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-lsl");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("log");
    // machine scope: liblsl resolves streams on 127.0.0.1 only, and no IPv6
    let cfg = dir.join("lsl_api.cfg");
    let text = "[ports]\nIPv6 = disable\n[multicast]\nResolveScope = machine\n";
    std::fs::write(&cfg, text).unwrap();
    let cfg = cfg.to_str().unwrap();
    let args = scripted_args(log.to_str().unwrap(), ["--lsl"]);
    let envs = [
        ("VLF_TEST_XR_STILL_HEAD", "1"),
        ("VLF_TEST_XR_LOCKSTEP", "1"),
        ("LSLAPICFG", cfg),
    ];
    let (mut cmd, _) = session_command("lsl", &cornell(), &args, &envs);
    let mut child = (cmd.stdout(std::process::Stdio::null()))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let addr = {
        use std::io::BufRead;
        let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
        let mut line = String::new();
        loop {
            line.clear();
            assert!(
                stderr.read_line(&mut line).unwrap() > 0,
                "no control address"
            );
            if let Some(a) = line.strip_prefix("control: listening on ") {
                let a = a.trim().to_string();
                std::thread::spawn(move || for _ in stderr.lines() {});
                break a;
            }
        }
    };
    let out = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tools/study/lsl_example.py"
        ))
        .args([&addr, "2"])
        .env("LSLAPICFG", cfg)
        .output()
        .unwrap();
    if !out.status.success() {
        let _ = child.kill();
        panic!("lsl_example.py: {}", String::from_utf8_lossy(&out.stderr));
    }
    assert!(
        child.wait().unwrap().success(),
        "stop ends the session cleanly"
    );
    let got: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        (got["replies"].as_array().unwrap().iter()).all(|r| r["ok"] == true),
        "{got}"
    );
    let (_, records) = vlf::study::SessionLog::read(&log).unwrap();
    let poses = got["streams"]["vlf.pose"]["samples"].as_array().unwrap();
    assert!(poses.len() >= 5, "{} pose samples", poses.len());
    let stamps: Vec<f64> = poses.iter().map(|p| p[0].as_f64().unwrap()).collect();
    assert!(
        stamps.windows(2).all(|w| w[0] < w[1]),
        "pose timestamps rise"
    );
    for p in poses {
        let v = p[1].as_array().unwrap();
        let frame = v[19].as_f64().unwrap() as usize;
        let head = records[frame].pose.head;
        let sent = Vec3::new(
            v[0].as_f64().unwrap() as f32,
            v[1].as_f64().unwrap() as f32,
            v[2].as_f64().unwrap() as f32,
        );
        assert_eq!(sent, head, "frame {frame}");
    }
    let events = got["streams"]["vlf.events"]["samples"].as_array().unwrap();
    assert!(
        (events.iter()).any(|e| e[1][0].as_str().unwrap().contains("lsl check: stimulus on")),
        "{events:?}"
    );
    eprintln!(
        "headset LSL: {} pose samples, {} log rows",
        poses.len(),
        records.len()
    );
}

/// A headset study's conditions (`--conditions`, as a display config's `[[condition]]`
/// tables): direct light only in effect from the first frame shows a darker eye than the same
/// still session without conditions; and a mistake in the file is named, with the condition and
/// the key, before any runtime starts.
#[test]
fn a_conditions_file_sets_what_the_headset_draws_and_its_mistakes_are_named() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-conditions-files");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("conditions.toml");
    std::fs::write(
        &file,
        "default_condition = \"gi-off\"\n[[condition]]\nname = \"gi-on\"\n\
         [[condition]]\nname = \"gi-off\"\nglobal_illumination = false\n",
    )
    .unwrap();
    let plain = still_session("conditions-plain", &[], &[]);
    let args = ["--conditions", file.to_str().unwrap()];
    let off = still_session("conditions-gi-off", &args, &[]);
    assert!(off.stderr.contains("(direct light only)"), "{}", off.stderr);
    let (on_mean, _) = brightness(plain.screenshot.as_ref().unwrap());
    let (off_mean, _) = brightness(off.screenshot.as_ref().unwrap());
    eprintln!("left eye's mean display value: {on_mean:.2} with global illumination, {off_mean:.2} with direct light only");
    assert!(
        off_mean < 0.85 * on_mean,
        "gi-on {on_mean}, gi-off {off_mean}"
    );
    // a condition's exposure is what the headset shows (times --exposure)
    let dim_file = dir.join("dim.toml");
    std::fs::write(
        &dim_file,
        "[[condition]]\nname = \"dim\"\nexposure = 0.25\n",
    )
    .unwrap();
    let dim = still_session(
        "conditions-dim",
        &["--conditions", dim_file.to_str().unwrap()],
        &[],
    );
    let (dim_mean, _) = brightness(dim.screenshot.as_ref().unwrap());
    eprintln!("left eye's mean display value at the condition's exposure 0.25: {dim_mean:.2}");
    assert!(
        dim_mean < 0.75 * on_mean,
        "exposure 1: {on_mean}, 0.25: {dim_mean}"
    );

    for (bad, needle) in [
        ("[[condition]]\nname = \"a\"\nexposur = 2.0\n", "exposur"),
        (
            "default_condition = \"b\"\n[[condition]]\nname = \"a\"\n",
            "\"b\"",
        ),
        (
            "[[condition]]\nname = \"a\"\nobjects_visible = [\"body\"]\n",
            "body",
        ),
    ] {
        std::fs::write(&file, bad).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_vlf"))
            .args(["xr", "--scene"])
            .arg(cornell())
            .arg("--conditions")
            .arg(&file)
            .env("VLF_OPENXR_LOADER", "/nonexistent/libopenxr_loader.so.1")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        println!("{err}");
        assert!(!out.status.success() && !err.contains("panicked"), "{err}");
        assert!(
            err.contains("conditions.toml") && err.contains(needle),
            "{needle} not named: {err}"
        );
        assert!(
            !err.contains("OpenXR loader"),
            "the runtime was tried first: {err}"
        );
    }
}

/// A script switches a headset session's condition over `--control` (the CAVE's `condition`
/// command): acknowledged with its frame, `state` names it, and the log's `condition` column is
/// the default before that frame and the new one from it on, the switch an event there.
#[test]
fn a_script_switches_a_headset_sessions_condition() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-conditions-switch-files");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("conditions.toml");
    std::fs::write(
        &file,
        "[[condition]]\nname = \"gi-on\"\n[[condition]]\nname = \"gi-off\"\n\
         global_illumination = false\nexposure = 1.5\n",
    )
    .unwrap();
    let log = dir.join("log");
    let args = scripted_args(
        log.to_str().unwrap(),
        ["--conditions", file.to_str().unwrap()],
    );
    let envs = [("VLF_TEST_XR_STILL_HEAD", "1")];
    let commands = [
        r#"{"cmd": "state"}"#,
        r#"{"cmd": "condition", "name": "gi-off"}"#,
        r#"{"cmd": "condition", "name": "sepia"}"#,
        r#"{"cmd": "state"}"#,
        r#"{"cmd": "stop"}"#,
    ];
    let (got, s) = scripted_session("conditions-switch", (&args, &envs), &commands);
    assert!(s.ok && !s.stderr.contains("panicked"), "{}", s.stderr);
    let ok: Vec<bool> = got.iter().map(|r| r["ok"] == true).collect();
    assert_eq!(ok, [true, true, false, true, true], "{got:?}");
    assert_eq!(got[0]["condition"], "gi-on", "{got:?}");
    assert!(
        got[2]["error"].as_str().unwrap().contains("gi-off"),
        "{got:?}"
    );
    assert_eq!(got[3]["condition"], "gi-off", "{got:?}");
    let switched = got[1]["frame"].as_u64().unwrap();
    let (_, records) = vlf::study::SessionLog::read(&log).unwrap();
    assert!(records.iter().any(|r| r.frame < switched), "{got:?}");
    for r in &records {
        let expect = if r.frame >= switched {
            "gi-off"
        } else {
            "gi-on"
        };
        assert_eq!(r.condition, expect, "frame {}", r.frame);
    }
    let at_switch = records.iter().find(|r| r.frame == switched).unwrap();
    assert!(
        at_switch.events.contains("condition gi-off"),
        "{at_switch:?}"
    );
}

/// `vlf replay` of a headset's session (`vlf xr --log`): each eye drawn again from the pose and
/// field of view the runtime located it at, the body on the head between the eyes and on the
/// logged grips, in the logged condition. The left eye of the screenshot's frame is
/// pixel-identical (linear radiance) to what the live run drew (`--screenshot left.exr`), the
/// head having moved between frames; the replay's PNG is at the condition's exposure, as the
/// headset showed it.
#[test]
fn a_headset_session_replays_pixel_identical_from_its_log() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("xr-replay-files");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let conditions = dir.join("conditions.toml");
    std::fs::write(
        &conditions,
        "default_condition = \"dim\"\n[[condition]]\nname = \"bright\"\n\
         [[condition]]\nname = \"dim\"\nexposure = 0.5\n",
    )
    .unwrap();
    let (log, shot) = (dir.join("log"), dir.join("left.exr"));
    let body = headset_body();
    let (left, right) = (grip_env(LEFT_GRIP), grip_env(RIGHT_GRIP));
    let args = [
        "--frames",
        "5",
        "--screenshot-frame",
        "5",
        "--screenshot",
        shot.to_str().unwrap(),
        "--log",
        log.to_str().unwrap(),
        "--objects",
        &body,
        "--conditions",
        conditions.to_str().unwrap(),
    ];
    let envs = [
        ("VLF_TEST_XR_LOCKSTEP", "1"),
        ("VLF_TEST_XR_LEFT_GRIP", left.as_str()),
        ("VLF_TEST_XR_RIGHT_GRIP", right.as_str()),
    ];
    let s = session("replay-live", &cornell(), &args, &envs);
    assert!(s.ok && !s.stderr.contains("panicked"), "{}", s.stderr);
    let live = vlf::render::image_io::read_exr(&shot).expect("the live left eye");

    let again = dir.join("again");
    let out = Command::new(env!("CARGO_BIN_EXE_vlf"))
        .arg("replay")
        .arg(&log)
        .args(["--frames", "3..=4", "--exr", "--out"])
        .arg(&again)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && !said.contains("panicked"), "{said}");
    let eye = |frame: u32, name: &str| again.join(format!("frame-{frame:06}/headset-{name}"));
    let replayed = vlf::render::image_io::read_exr(&eye(4, "left.exr")).unwrap();
    let differing = (live.pixels.iter().zip(&replayed.pixels))
        .filter(|(a, b)| a != b)
        .count();
    let earlier = vlf::render::image_io::read_exr(&eye(3, "left.exr")).unwrap();
    let moved = (earlier.pixels.iter().zip(&replayed.pixels))
        .filter(|(a, b)| a != b)
        .count();
    let right_eye = vlf::render::image_io::read_exr(&eye(4, "right.exr")).unwrap();
    let stereo = (right_eye.pixels.iter().zip(&replayed.pixels))
        .filter(|(a, b)| a != b)
        .count();
    eprintln!(
        "replayed left eye of frame 4 ({}x{}): {differing} pixels differ from the live one; {moved} differ from frame 3, {stereo} from the right eye",
        live.width, live.height
    );
    assert_eq!((replayed.width, replayed.height), (live.width, live.height));
    assert_eq!(differing, 0, "the replay is not what the run drew");
    assert!(moved > 0 && stereo > 0, "moved {moved}, stereo {stereo}");
    // the PNG as the headset showed it: at the condition's exposure
    let png = image::open(eye(4, "left.png")).unwrap().to_rgb8();
    let expected = vlf::render::image_io::display_image(&replayed, 0.5);
    assert!(png == expected, "the PNG is not the eye at exposure 0.5");
}

/// The mean absolute difference of every channel of every pixel between two screenshots.
fn mean_difference(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let sum: u64 = (a.as_raw().iter().zip(b.as_raw()))
        .map(|(x, y)| x.abs_diff(*y) as u64)
        .sum();
    sum as f64 / a.as_raw().len() as f64
}

/// Edge antialiasing draws the headset's eyes too (`vlf xr --aa 1 --edge-samples 8`): the report
/// names it, and the left eye is closer to 16 eye rays per pixel than 1 eye ray is (measured on
/// the Cornell box: mean difference 0.10 of 255 against 0.30).
#[test]
fn edge_antialiasing_draws_the_headset_eyes() {
    let shot = |s: &Session| s.screenshot.clone().unwrap();
    let edges = still_session("edges-8", &["--aa", "1", "--edge-samples", "8"], &[]);
    assert_eq!(
        edges.report["quality"]["edge_samples"], 8,
        "{}",
        edges.report
    );
    let one = shot(&still_session("edges-1", &["--aa", "1"], &[]));
    let sixteen = shot(&still_session("edges-16", &["--aa", "16"], &[]));
    let (with_edges, without) = (
        mean_difference(&shot(&edges), &sixteen),
        mean_difference(&one, &sixteen),
    );
    println!(
        "mean difference from 16 eye rays: 1 eye ray {without:.4}, 8 at edges {with_edges:.4}"
    );
    assert!(with_edges < 0.6 * without, "{with_edges} against {without}");
}
