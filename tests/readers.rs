//! Property tests over the readers of untrusted input (the fuzz targets' twins, in plain
//! `cargo test`): scene TOML, OBJ and .vlf bytes, random and mutated, give Ok or an error
//! naming the file, never a panic; every damage to a .vlf is caught.

mod common;
use common::*;
use proptest::prelude::*;
use std::path::Path;
use vlf::lightfield::file;
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
    };
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &params, false).unwrap();
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
