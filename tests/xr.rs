//! OpenXR: the view math against hand-computed values, the errors without a loader or a
//! runtime, and a headset run when XR_RUNTIME_JSON names a runtime (it says plainly when none
//! is available and it did not run).

use glam::{Mat4, Vec3, Vec4};
use std::process::Command;
use vlf::display::xr::{pose_from_view, projection_from_fov, view_from_pose, Fov, XrPose};

#[test]
fn projection_of_an_asymmetric_fov_matches_the_hand_computed_matrix() {
    let fov = Fov { angle_left: -45f32.to_radians(), angle_right: 30f32.to_radians(), angle_up: 20f32.to_radians(), angle_down: -35f32.to_radians() };
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
    let pose = XrPose { orientation: q.to_array(), position: [0.3, 1.62, -0.4] };
    let view = view_from_pose(pose);
    // the eye sits at the view's origin, looking down its -z
    assert!(view.transform_point3(Vec3::from(pose.position)).length() < 1e-5);
    assert!((view.transform_vector3(q * Vec3::NEG_Z) - Vec3::NEG_Z).length() < 1e-5);
    let back = pose_from_view(view);
    let same_rotation = glam::Quat::from_array(back.orientation).dot(q).abs() > 1.0 - 1e-5;
    assert!(same_rotation && (Vec3::from(back.position) - Vec3::from(pose.position)).length() < 1e-5, "{back:?}");
}

fn vlf_xr(envs: &[(&str, &str)]) -> (bool, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vlf"));
    cmd.args(["xr", "--scene", concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell/scene.toml")]);
    for (k, v) in envs {
        cmd.env(k, v);
    }
    let out = cmd.output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn without_a_loader_the_error_says_what_to_install_and_how_to_select_a_runtime() {
    let (ok, err) = vlf_xr(&[("VLF_OPENXR_LOADER", "/nonexistent/libopenxr_loader.so.1")]);
    println!("{err}");
    assert!(!ok, "vlf xr succeeded without a loader");
    assert!(!err.contains("panicked"), "{err}");
    for needle in ["no OpenXR loader", "libopenxr-loader1", "Monado", "SteamVR", "XR_RUNTIME_JSON"] {
        assert!(err.contains(needle), "missing {needle:?} in: {err}");
    }
}

#[test]
fn without_a_runtime_the_error_names_the_selection_and_how_to_install_one() {
    let loader = ["/usr/lib/x86_64-linux-gnu/libopenxr_loader.so.1", "/usr/lib/libopenxr_loader.so.1"].into_iter().find(|p| std::path::Path::new(p).exists());
    let Some(loader) = loader else {
        panic!("this test needs the OpenXR loader (libopenxr_loader.so.1): run `bash tools/setup.sh` or `sudo apt-get install libopenxr-loader1`");
    };
    let (ok, err) = vlf_xr(&[("VLF_OPENXR_LOADER", loader), ("XR_RUNTIME_JSON", "/nonexistent/runtime.json")]);
    println!("{err}");
    assert!(!ok && !err.contains("panicked"), "{err}");
    for needle in ["no usable runtime", "XR_RUNTIME_JSON=/nonexistent/runtime.json", "Monado", "SteamVR"] {
        assert!(err.contains(needle), "missing {needle:?} in: {err}");
    }
}

#[test]
fn a_headset_run_when_a_runtime_is_configured() {
    match std::env::var("XR_RUNTIME_JSON") {
        Ok(path) if std::path::Path::new(&path).exists() => {
            let (ok, err) = vlf_xr(&[]);
            assert!(ok, "vlf xr failed with the runtime {path}: {err}");
        }
        _ => println!("no OpenXR runtime available (XR_RUNTIME_JSON unset or missing): the headset run did not run"),
    }
}
