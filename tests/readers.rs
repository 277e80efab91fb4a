//! Property tests over the readers of untrusted input (the fuzz targets' twins, in plain
//! `cargo test`): scene TOML, OBJ, glTF (.glb, .gltf) and .vlf bytes, random and mutated, give Ok or an error
//! naming the file, never a panic; every damage to a .vlf is caught.

use crate::common;
use common::*;
use proptest::prelude::*;
use std::path::Path;
use vlf::lightfield::file;
use vlf::progress::Silent;
use vlf::scene::{Scene, SceneFile};

fn valid_toml() -> String {
    std::fs::read_to_string(repo_path("scenes/cornell-mirror/scene.toml")).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn any_text_as_scene_toml_is_ok_or_a_named_error(text in "\\PC{0,400}") {
        if let Err(e) = SceneFile::parse(&text, Path::new("p/scene.toml")) {
            prop_assert!(e.to_string().contains("p/scene.toml"));
        }
    }

    #[test]
    fn a_mutated_scene_toml_is_ok_or_a_named_error(cut in 0usize..2000, at in 0usize..2000, byte in any::<u8>()) {
        let mut bytes = valid_toml().into_bytes();
        let at = at % bytes.len();
        bytes[at] = byte;
        bytes.truncate(cut.max(1).min(bytes.len()));
        if let Ok(text) = String::from_utf8(bytes) {
            if let Err(e) = SceneFile::parse(&text, Path::new("p/scene.toml")) {
                prop_assert!(e.to_string().contains("p/scene.toml"));
            }
        }
    }

    #[test]
    fn a_mutated_display_toml_is_ok_or_a_named_error(cut in 0usize..4000, at in 0usize..4000, byte in any::<u8>()) {
        let mut bytes = std::fs::read(repo_path("config/displays/cave-4wall.toml")).unwrap();
        let at = at % bytes.len();
        bytes[at] = byte;
        bytes.truncate(cut.max(1).min(bytes.len()));
        if let Ok(text) = String::from_utf8(bytes) {
            if let Err(e) = vlf::display::DisplayConfig::parse(&text, Path::new("p/display.toml")) {
                prop_assert!(e.to_string().contains("p/display.toml"), "{}", e);
            }
        }
    }

    #[test]
    fn any_text_as_display_toml_is_ok_or_a_named_error(text in "\\PC{0,300}") {
        if let Err(e) = vlf::display::DisplayConfig::parse(&text, Path::new("p/display.toml")) {
            prop_assert!(e.to_string().contains("p/display.toml"));
        }
    }

    #[test]
    fn random_bytes_are_not_a_light_field(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        prop_assert!(file::decode(&bytes).is_err());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn random_obj_text_is_ok_or_a_named_error(lines in proptest::collection::vec("(v|f|vt|usemtl|g|#)[ 0-9.eE/+-]{0,30}", 0..30)) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.mtl"), "newmtl a\nKd 0.5 0.5 0.5\nKe 1 1 1\n").unwrap();
        std::fs::write(dir.path().join("m.obj"), format!("mtllib m.mtl\nusemtl a\n{}\n", lines.join("\n"))).unwrap();
        std::fs::write(dir.path().join("scene.toml"), "name = \"p\"\nmesh = \"m.obj\"\n").unwrap();
        if let Err(e) = Scene::load(&dir.path().join("scene.toml")) {
            let e = e.to_string();
            prop_assert!(e.contains("m.obj") || e.contains("m.mtl"), "{}", e);
        }
    }
}

#[test]
fn every_damage_to_a_light_field_file_is_caught() {
    let scene = Scene::load(&repo_path("scenes/cornell-mirror/scene.toml")).unwrap();
    let params = vlf::propagate::PropagationParams {
        geodesic_frequency: 2,
        grid_resolution: 16,
        tile_size: 8,
        texel_density: 4.0,
        tolerance: 1e-2,
        max_iterations: 10,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 16,
        mirror_direct: false,
        rim_rays: false,
    };
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    let bytes = file::encode(&lf);
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 512,
        ..ProptestConfig::default()
    });
    runner
        .run(
            &(0..bytes.len(), 1u8..=255, 0..bytes.len()),
            |(at, mask, cut)| {
                let mut flipped = bytes.clone();
                flipped[at] ^= mask;
                prop_assert!(
                    file::decode(&flipped).is_err(),
                    "flipping byte {} went unnoticed",
                    at
                );
                prop_assert!(
                    file::decode(&bytes[..cut]).is_err(),
                    "a file cut at {} decoded",
                    cut
                );
                Ok(())
            },
        )
        .unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn random_mtl_text_is_ok_or_a_named_error(lines in proptest::collection::vec("(newmtl a|Kd|Ke|Ks|Ka|Ns|d|illum|map_Kd)[ 0-9.eE-]{0,16}", 0..12)) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.mtl"), lines.join("\n")).unwrap();
        std::fs::write(dir.path().join("m.obj"), "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n").unwrap();
        std::fs::write(dir.path().join("scene.toml"), "name = \"p\"\nmesh = \"m.obj\"\n").unwrap();
        if let Err(e) = Scene::load(&dir.path().join("scene.toml")) {
            let e = e.to_string();
            prop_assert!(e.contains("m.obj") || e.contains("m.mtl"), "{}", e);
        }
    }
}

fn valid_glb() -> Vec<u8> {
    gltf_model(
        gltf_basic_materials(),
        serde_json::json!([{"children": [1, 2, 3]}, {"mesh": 0}, {"mesh": 1}, {"mesh": 2}]),
        serde_json::json!({}),
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn a_mutated_glb_is_ok_or_a_named_error(cut in 0usize..2000, at in 0usize..2000, byte in any::<u8>()) {
        let mut bytes = valid_glb();
        let at = at % bytes.len();
        bytes[at] = byte;
        bytes.truncate(cut.max(1).min(bytes.len()));
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.glb"), &bytes).unwrap();
        if let Err(e) = Scene::load(&dir.path().join("m.glb")) {
            prop_assert!(e.to_string().contains("m.glb"), "{}", e);
        }
    }

    #[test]
    fn random_bytes_as_glb_or_gltf_are_ok_or_a_named_error(bytes in proptest::collection::vec(any::<u8>(), 0..256), json in "\\PC{0,200}") {
        let dir = tempfile::tempdir().unwrap();
        let mut glb = b"glTF\x02\0\0\0".to_vec();
        glb.extend(&bytes);
        std::fs::write(dir.path().join("m.glb"), &glb).unwrap();
        if let Err(e) = Scene::load(&dir.path().join("m.glb")) {
            prop_assert!(e.to_string().contains("m.glb"), "{}", e);
        }
        std::fs::write(dir.path().join("m.gltf"), json).unwrap();
        if let Err(e) = Scene::load(&dir.path().join("m.gltf")) {
            prop_assert!(e.to_string().contains("m.gltf"), "{}", e);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Numbers in the JSON changed at random (offsets, counts, strides, indices, modes).
    #[test]
    fn a_gltf_with_random_numbers_is_ok_or_a_named_error(which in 0usize..64, value in prop_oneof![Just(-1i64), 0i64..20, Just(4096), Just(u32::MAX as i64)]) {
        let bytes = valid_glb();
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let text = String::from_utf8(bytes[20..20 + len].to_vec()).unwrap();
        let bin = bytes[20 + len + 8..].to_vec();
        // the which-th number in the JSON text becomes value
        let mut out = String::new();
        let mut seen = 0;
        let mut chars = text.char_indices().peekable();
        while let Some((_, c)) = chars.next() {
            if c.is_ascii_digit() && !out.ends_with(|p: char| p.is_ascii_alphanumeric() || p == '.' || p == '_') {
                let mut n = c.to_string();
                while let Some(&(_, d)) = chars.peek() {
                    if d.is_ascii_digit() || d == '.' { n.push(d); chars.next(); } else { break; }
                }
                out.push_str(&if seen == which { value.to_string() } else { n });
                seen += 1;
            } else {
                out.push(c);
            }
        }
        let json: serde_json::Value = match serde_json::from_str(&out) { Ok(j) => j, Err(_) => return Ok(()) };
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.glb"), glb(&json, &bin)).unwrap();
        if let Err(e) = Scene::load(&dir.path().join("m.glb")) {
            prop_assert!(e.to_string().contains("m.glb"), "{}", e);
        }
    }
}
