//! `.vlf` files: round trip, and every kind of damage or mismatch gives a clear error.

use crate::common;
use common::*;
use vlf::lightfield::{file, LightField};
use vlf::progress::Silent;
use vlf::propagate::PropagationParams;
use vlf::scene::Scene;

fn small_light_field() -> (Scene, LightField) {
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let params = small_light_field_params();
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    (scene, lf)
}

fn decode_err(bytes: &[u8]) -> String {
    match file::decode(bytes) {
        Ok(_) => panic!("damaged file decoded"),
        Err(e) => e,
    }
}

#[test]
fn round_trip_and_damage() {
    let (scene, lf) = small_light_field();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.vlf");
    file::save(&lf, &path).unwrap();
    let back = file::load(&path).unwrap();
    assert_eq!(back, lf);
    back.check_scene(&scene, &path).unwrap();
    // no temporary file left behind
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

    let bytes = std::fs::read(&path).unwrap();
    let mut wrong_magic = bytes.clone();
    wrong_magic[0] = b'X';
    assert!(decode_err(&wrong_magic).contains("not a vlf light field file"));

    let mut wrong_version = bytes.clone();
    wrong_version[8..12].copy_from_slice(&99u32.to_le_bytes());
    let e = decode_err(&wrong_version);
    assert!(
        e.contains("format version 99") && e.contains("re-run `vlf propagate`"),
        "{e}"
    );

    for cut in [4, 30, bytes.len() / 2, bytes.len() - 1] {
        assert!(
            decode_err(&bytes[..cut]).contains("truncated"),
            "cut at {cut}"
        );
    }

    // every flipped byte is caught (sampled across the whole file)
    for at in (0..bytes.len()).step_by((bytes.len() / 97).max(1)) {
        let mut flipped = bytes.clone();
        flipped[at] ^= 0x40;
        assert!(
            file::decode(&flipped).is_err(),
            "flipped byte at {at} went unnoticed"
        );
    }

    let e = file::load(&dir.path().join("missing.vlf"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.vlf"), "{e}");
}

#[test]
fn a_file_for_another_scene_is_refused() {
    let (_, lf) = small_light_field();
    let dir = tempfile::tempdir().unwrap();
    let mut obj = ObjBuilder::default();
    obj.cube("wall", glam::DVec3::ZERO, 0.5, true);
    let other = Scene::load(&write_scene(
        dir.path(),
        &obj,
        &[Mat {
            name: "wall",
            kd: [0.5; 3],
            ke: [1.0; 3],
        }],
        "",
    ))
    .unwrap();
    let e = lf
        .check_scene(&other, std::path::Path::new("cornell.vlf"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cornell.vlf")
            && e.contains("made for scene \"cornell\"")
            && e.contains("re-run"),
        "{e}"
    );
}

#[test]
fn a_failed_save_keeps_the_previous_file() {
    let (_, lf) = small_light_field();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keep.vlf");
    file::save(&lf, &path).unwrap();
    let before = std::fs::read(&path).unwrap();
    // saving into a folder that does not exist fails without touching the old file
    let bad = dir.path().join("no/such/folder/keep.vlf");
    assert!(file::save(&lf, &bad).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), before);
}

#[test]
fn texture_detail_round_trips_and_version_2_files_still_load() {
    // a textured scene keeps its texture detail through a file
    let scene = Scene::load(&repo_path("scenes/textured-room/scene.toml")).unwrap();
    let params = small_light_field_params();
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    let detail = lf
        .detail
        .as_ref()
        .expect("the textured room has texture detail");
    assert_eq!(detail.texel_albedo.len(), lf.total.len());
    let bytes = file::encode(&lf);
    assert_eq!(file::decode(&bytes).unwrap(), lf);
    // a bad texture record is named
    let mut bad = lf.clone();
    bad.detail.as_mut().unwrap().textures.info[0][1] = 1 << 20;
    let e = decode_err(&file::encode(&bad));
    assert!(e.contains("texture 0 lies outside its texels"), "{e}");

    // a file written before the detail (format 2: its first seven sections) loads, without it
    let (_, untextured) = small_light_field();
    let encoded = file::encode(&untextured);
    let sections = file::decode_sections(
        &encoded,
        file::MAGIC,
        file::FORMAT_VERSION,
        &[
            b"META", b"FACE", b"RVTX", b"TOTL", b"TRCT", b"TIDX", b"TTOT", b"TXIN", b"TXTL",
            b"FTEX", b"RUVS", b"TALB", b"NMAP", b"NDIR", b"SPEC",
        ],
        "test",
    )
    .unwrap();
    let tags = [
        b"META", b"FACE", b"RVTX", b"TOTL", b"TRCT", b"TIDX", b"TTOT",
    ];
    let old: Vec<(&[u8; 4], &[u8])> = tags.into_iter().zip(sections).collect();
    let old_bytes = file::encode_sections(file::MAGIC, 2, &old);
    assert_eq!(file::decode(&old_bytes).unwrap(), untextured);
}

fn small_light_field_params() -> PropagationParams {
    // coarser than the shared draft settings: a file's round trip needs little of a light field
    PropagationParams {
        geodesic_frequency: 2,
        grid_resolution: 16,
        texel_density: 4.0,
        ..draft_params()
    }
}

#[test]
fn normal_maps_round_trip_and_version_3_files_still_load() {
    let (_, lf) = small_light_field();
    // a light field with normal maps: per face a record, per texel a light direction
    let mut mapped = lf.clone();
    let texels = mapped.total.len();
    let faces = mapped.faces.len();
    let mut detail = vlf::lightfield::textures::SurfaceDetail {
        texel_albedo: vec![[0x3c00_3c00, 0x3c00]; texels],
        triangle_uv: vec![[0.0; 6]; mapped.render_vertices.len() / 3],
        ..Default::default()
    };
    detail.textures.face_textures = vec![[u32::MAX, u32::MAX, 0, 0]; faces];
    detail.textures.info = vec![[0, 1, 1, 0]];
    detail.textures.texels = vec![[0.5, 0.5, 1.0, 1.0]];
    detail.face_normal_maps = vec![[u32::MAX, 0]; faces];
    detail.face_normal_maps[0] = [0, 1.5f32.to_bits()];
    detail.texel_directions = (0..2 * texels as u32).map(|i| [i, i ^ 7]).collect();
    mapped.detail = Some(detail);
    let bytes = file::encode(&mapped);
    assert_eq!(file::decode(&bytes).unwrap(), mapped);
    // a texel direction short is named
    let mut bad = mapped.clone();
    bad.detail.as_mut().unwrap().texel_directions.pop();
    let e = decode_err(&file::encode(&bad));
    assert!(e.contains("normal maps"), "{e}");
    // a file written before normal maps (format 3: its first twelve sections) loads without them
    let mut plain = mapped.clone();
    let d = plain.detail.as_mut().unwrap();
    d.face_normal_maps.clear();
    d.texel_directions.clear();
    let all = [
        b"META", b"FACE", b"RVTX", b"TOTL", b"TRCT", b"TIDX", b"TTOT", b"TXIN", b"TXTL", b"FTEX",
        b"RUVS", b"TALB", b"NMAP", b"NDIR", b"SPEC",
    ];
    let encoded = file::encode(&plain);
    let sections =
        file::decode_sections(&encoded, file::MAGIC, file::FORMAT_VERSION, &all, "test").unwrap();
    let old: Vec<(&[u8; 4], &[u8])> = all.into_iter().zip(sections.clone()).take(12).collect();
    let old_bytes = file::encode_sections(file::MAGIC, 3, &old);
    assert_eq!(file::decode(&old_bytes).unwrap(), plain);
    // and one written before specular textures (format 4: its first fourteen) with its normal maps
    let encoded = file::encode(&mapped);
    let sections =
        file::decode_sections(&encoded, file::MAGIC, file::FORMAT_VERSION, &all, "test").unwrap();
    let v4: Vec<(&[u8; 4], &[u8])> = all.into_iter().zip(sections).take(14).collect();
    let v4_bytes = file::encode_sections(file::MAGIC, 4, &v4);
    assert_eq!(file::decode(&v4_bytes).unwrap(), mapped);
    // per face specular textures (a metal split per texel) round-trip; a short list is named
    let mut specular = mapped.clone();
    let faces = specular.faces.len();
    let d = specular.detail.as_mut().unwrap();
    d.textures.face_specular = vec![vlf::gpu::types::NO_FACE; faces];
    d.textures.face_specular[0] = 0;
    assert_eq!(file::decode(&file::encode(&specular)).unwrap(), specular);
    specular
        .detail
        .as_mut()
        .unwrap()
        .textures
        .face_specular
        .pop();
    let e = decode_err(&file::encode(&specular));
    assert!(e.contains("specular textures"), "{e}");
}
