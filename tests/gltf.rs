//! glTF import: a scene written by an independent tool (pygltflib, through tools/obj2gltf.py)
//! gives the light field its OBJ gives, texel for texel; `vlf generate --format gltf` likewise;
//! the importer's features (hierarchy, strips and fans, cameras, material rules, texture
//! transform, embedded images) on hand-made files; textures at scale are resolved to texel
//! density. Bad files are in tests/scene_errors.rs and tests/readers.rs.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

fn small() -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 4,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 24.0,
        tolerance: 1e-3,
        max_iterations: 50,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 16,
        mirror_direct: false,
    }
}

/// tools/obj2gltf.py (pygltflib): fails, never skips, when the package is missing.
fn obj2gltf(scene: &str, out: &Path, glb: bool) -> PathBuf {
    let mut cmd = std::process::Command::new("python3");
    cmd.arg(repo_path("tools/obj2gltf.py"))
        .arg(repo_path(scene))
        .arg(out);
    if glb {
        cmd.arg("--glb");
    }
    let o = cmd
        .output()
        .expect("python3 must be installed to run tools/obj2gltf.py");
    assert!(
        o.status.success(),
        "tools/obj2gltf.py failed (it needs pygltflib and numpy: `python3 -m pip install pygltflib numpy`, or bash tools/setup.sh):\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    out.join("scene.toml")
}

fn assert_same_light_field(a: &Scene, b: &Scene) {
    assert_eq!(a.triangles.len(), b.triangles.len());
    let (la, _, _) = vlf::propagate::propagate(gpu(), a, &small(), false).unwrap();
    let (lb, _, _) = vlf::propagate::propagate(gpu(), b, &small(), false).unwrap();
    assert_eq!(la.total.len(), lb.total.len(), "atlas sizes differ");
    let mut worst = 0.0f32;
    for (x, y) in la.total.iter().zip(&lb.total) {
        for c in 0..4 {
            worst = worst.max((x[c] - y[c]).abs());
        }
    }
    assert!(worst <= 1e-5, "largest texel difference {worst}");
}

#[test]
fn cornell_written_by_pygltflib_gives_the_obj_light_field() {
    let dir = tempfile::tempdir().unwrap();
    let toml = obj2gltf("scenes/cornell/scene.toml", dir.path(), false);
    let obj = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let gltf = Scene::load(&toml).unwrap();
    // the same repairs (the OBJ's duplicated triangles), named for the glTF file
    let after_path = |w: &Vec<String>| -> Vec<String> {
        w.iter()
            .map(|s| s.split_once(": ").map_or(s.clone(), |x| x.1.to_string()))
            .collect()
    };
    assert_eq!(after_path(&gltf.warnings), after_path(&obj.warnings));
    assert_same_light_field(&obj, &gltf);
}

#[test]
fn textured_room_as_glb_by_pygltflib_gives_the_obj_light_field() {
    let dir = tempfile::tempdir().unwrap();
    obj2gltf("scenes/textured-room/scene.toml", dir.path(), true);
    // the .glb loads on its own (its scene.toml beside it gives the cameras)
    let gltf = Scene::load(&dir.path().join("model.glb")).unwrap();
    assert_eq!(gltf.textures.len(), 3);
    assert_eq!(gltf.cameras.len(), 2);
    let obj = Scene::load(&repo_path("scenes/textured-room/scene.toml")).unwrap();
    assert_same_light_field(&obj, &gltf);
}
