//! Diffuse textures (map_Kd) and textured emitters (map_Ke) reach propagation and rendering;
//! untextured scenes allocate no texture storage; a missing texture is a clear error.

mod common;
use common::*;
use vlf::progress::Silent;
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
        rim_rays: false,
    }
}

fn texels_of(lf: &vlf::lightfield::LightField, scene: &Scene, material: &str) -> Vec<[f32; 4]> {
    let m = scene
        .materials
        .iter()
        .position(|m| m.name == material)
        .unwrap();
    let prepared = vlf::prepare::PreparedScene::new(scene, small().texel_density).unwrap();
    let mut out = Vec::new();
    for (i, p) in prepared.atlas.points.iter().enumerate() {
        let f = p[3].to_bits();
        if f != u32::MAX
            && prepared.faces[f as usize].material as usize == m
            && prepared.atlas.coverage[i] >= 1.0
        {
            out.push(lf.total[i]);
        }
    }
    out
}

#[test]
fn textured_room_shows_its_textures_in_the_light_field() {
    let scene = Scene::load(&repo_path("scenes/textured-room/scene.toml")).unwrap();
    assert_eq!(scene.textures.len(), 3);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let (lf, _, report) = vlf::propagate::propagate(gpu(), &scene, &small(), &Silent).unwrap();
    assert!(report.texture_bytes > 0);
    // the light panel's stripes (map_Ke): warm and cool texels, as in panel.png
    let panel = texels_of(&lf, &scene, "panel");
    let warm = panel.iter().filter(|t| t[0] > 2.0 * t[2]).count();
    let cool = panel.iter().filter(|t| t[2] > 2.0 * t[0]).count();
    assert!(
        warm > panel.len() / 4 && cool > panel.len() / 4,
        "panel: {warm} warm, {cool} cool of {}",
        panel.len()
    );
    // the checkerboard floor (map_Kd): light and dark squares far apart
    let floor = texels_of(&lf, &scene, "floor");
    let mut lum: Vec<f32> = floor.iter().map(|t| t[1]).collect();
    lum.sort_by(|a, b| a.total_cmp(b));
    let (dark, light) = (lum[lum.len() / 10], lum[lum.len() * 9 / 10]);
    assert!(
        light > 8.0 * dark,
        "checkerboard contrast lost: 10th percentile {dark}, 90th {light}"
    );
    // and it reaches the image
    let ledger = vlf::gpu::MemoryLedger::default();
    let resident = lf.upload(gpu()).unwrap();
    let mut r = vlf::render::Renderer::new(&resident, &lf, &ledger).unwrap();
    let frame = r.render(lf.camera(Some("front")).unwrap(), 64, 64).unwrap();
    assert!(frame.pixels.iter().flatten().all(|x| x.is_finite()));
}

#[test]
fn an_untextured_scene_allocates_no_texture_storage() {
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    assert!(scene.textures.is_empty());
    let (_, _, report) = vlf::propagate::propagate(gpu(), &scene, &small(), &Silent).unwrap();
    assert_eq!(report.texture_bytes, 0);
    assert!(!report
        .propagation_memory
        .iter()
        .any(|m| m.name.contains("texture")));
}

#[test]
fn a_missing_texture_names_material_and_file() {
    let dir = tempfile::tempdir().unwrap();
    for f in [
        "room.obj",
        "room.mtl",
        "scene.toml",
        "panel.png",
        "painting.png",
    ] {
        std::fs::copy(
            repo_path("scenes/textured-room").join(f),
            dir.path().join(f),
        )
        .unwrap();
    }
    let e = Scene::load(&dir.path().join("scene.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("room.mtl") && e.contains("\"floor\"") && e.contains("checker.png"),
        "{e}"
    );
    std::fs::write(dir.path().join("checker.png"), b"not a png").unwrap();
    let e = Scene::load(&dir.path().join("scene.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("checker.png") && e.contains("not a readable"),
        "{e}"
    );
}
