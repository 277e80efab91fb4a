//! The reference path tracer: its own furnace, repeatability, textures. The light field measured
//! against it: tests/mitsuba.rs, beside the same light field against Mitsuba.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::progress::Silent;
use vlf::scene::{Camera, Scene};

#[test]
fn path_tracer_furnace_matches_le_over_one_minus_rho() {
    // 64x64 pixels, 256 samples per pixel: the image mean within 2%, every pixel within 10%
    let dir = tempfile::tempdir().unwrap();
    let (le, rho) = (1.0f32, 0.5f32);
    let mut obj = ObjBuilder::default();
    obj.cube("wall", DVec3::ZERO, 0.5, true);
    let scene = Scene::load(&write_scene(
        dir.path(),
        &obj,
        &[Mat {
            name: "wall",
            kd: [rho; 3],
            ke: [le; 3],
        }],
        "",
    ))
    .unwrap();
    let cam = Camera {
        name: "in".into(),
        eye: [0.1, -0.05, 0.2],
        target: [-1.0, 0.3, -0.6],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 90.0,
        size: [64, 64],
    };
    let r = vlf::reference::render(gpu(), &scene, &cam, [64, 64], 256, 7, &Silent).unwrap();
    let expected = (le / (1.0 - rho)) as f64;
    let mean = r.mean.pixels.iter().map(|p| p[1] as f64).sum::<f64>() / r.mean.pixels.len() as f64;
    assert!(
        (mean - expected).abs() / expected < 0.02,
        "mean {mean} vs {expected}"
    );
    let worst = r
        .mean
        .pixels
        .iter()
        .map(|p| (p[1] as f64 - expected).abs() / expected)
        .fold(0.0, f64::max);
    assert!(worst < 0.10, "a pixel is {:.1}% off", worst * 100.0);
    assert!(r
        .variance
        .pixels
        .iter()
        .all(|v| v[1] >= 0.0 && v[1].is_finite()));
}

#[test]
fn path_tracer_is_repeatable_and_seeded() {
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let cam = scene.camera(Some("front")).unwrap().clone();
    let a = vlf::reference::render(gpu(), &scene, &cam, [32, 32], 8, 1, &Silent).unwrap();
    let b = vlf::reference::render(gpu(), &scene, &cam, [32, 32], 8, 1, &Silent).unwrap();
    let c = vlf::reference::render(gpu(), &scene, &cam, [32, 32], 8, 2, &Silent).unwrap();
    assert_eq!(a.mean.pixels, b.mean.pixels);
    assert_ne!(a.mean.pixels, c.mean.pixels);
}

/// A face without texture coordinates shows its material's colour, not its texture, in the path
/// tracer as in the light field (prepare::atlas): the floor of the textured room with its `vt`
/// indices removed renders as the floor with no map_Kd at all (it used to read the checkerboard
/// at uv (0, 0): a dark square, 0.38 of the untextured floor).
#[test]
fn path_tracer_leaves_the_texture_off_faces_without_texture_coordinates() {
    let render = |obj_edit: &dyn Fn(String) -> String, mtl_edit: &dyn Fn(String) -> String| {
        let dir = tempfile::tempdir().unwrap();
        for f in ["scene.toml", "checker.png", "painting.png", "panel.png"] {
            std::fs::copy(
                repo_path(&format!("scenes/textured-room/{f}")),
                dir.path().join(f),
            )
            .unwrap();
        }
        let read =
            |f: &str| std::fs::read_to_string(repo_path(&format!("scenes/textured-room/{f}")));
        std::fs::write(
            dir.path().join("room.obj"),
            obj_edit(read("room.obj").unwrap()),
        )
        .unwrap();
        std::fs::write(
            dir.path().join("room.mtl"),
            mtl_edit(read("room.mtl").unwrap()),
        )
        .unwrap();
        let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
        // looking down at the floor
        let mut cam = scene.camera(Some("front")).unwrap().clone();
        (cam.eye, cam.target, cam.up, cam.fov_y_deg) =
            ([0.0, 1.5, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 40.0);
        vlf::reference::render(gpu(), &scene, &cam, [16, 16], 16, 3, &Silent).unwrap()
    };
    let keep = |s: String| s;
    let no_uv = |s: String| s.replace("f 1/1 2/2 3/3 4/4", "f 1 2 3 4");
    let no_map = |s: String| s.replace("Kd 0.9 0.9 0.9\nmap_Kd checker.png", "Kd 0.9 0.9 0.9");
    let without_uv = render(&no_uv, &keep);
    let untextured = render(&keep, &no_map);
    let mean = |f: &vlf::render::Frame| {
        f.pixels
            .iter()
            .map(|p| (p[0] + p[1] + p[2]) as f64)
            .sum::<f64>()
            / f.pixels.len() as f64
    };
    let (a, b) = (mean(&without_uv.mean), mean(&untextured.mean));
    assert!(
        (a / b - 1.0).abs() < 1e-3,
        "the floor without texture coordinates: mean {a}, the untextured floor {b}"
    );
}
