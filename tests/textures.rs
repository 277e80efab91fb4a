//! Diffuse textures (map_Kd) and textured emitters (map_Ke) reach propagation and rendering;
//! untextured scenes allocate no texture storage; a missing texture is a clear error.

use crate::common;
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

/// A floor textured with a checkerboard whose squares (6 cm) are about one atlas texel, under a
/// uniform sky and nothing else: its irradiance is pi x sky everywhere, so every point shows
/// Kd x texture(x) x sky exactly. Returns the scene and the two squares' linear values.
fn checkered_floor_under_the_sky(dir: &std::path::Path) -> (Scene, [f32; 2]) {
    // 16 x 16 pixels, 8 x 8 squares; sRGB 60 and 200
    let srgb = [60u8, 200u8];
    let image = image::RgbImage::from_fn(16, 16, |x, y| {
        let v = srgb[((x / 8 + y / 8) % 2) as usize];
        image::Rgb([v, v, v])
    });
    image.save(dir.join("checker.png")).unwrap();
    // a 2 m floor, its texture repeated 16 times each way: 32 squares of 6.25 cm
    let obj = "mtllib floor.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n\
               vt 0 0\nvt 16 0\nvt 16 16\nvt 0 16\nvn 0 1 0\nusemtl floor\n\
               f 1/1/1 4/4/1 3/3/1\nf 1/1/1 3/3/1 2/2/1\n";
    std::fs::write(dir.join("floor.obj"), obj).unwrap();
    std::fs::write(
        dir.join("floor.mtl"),
        "newmtl floor\nKd 0.9 0.9 0.9\nmap_Kd checker.png\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "name = \"checkered floor\"\nmesh = \"floor.obj\"\n[sky]\nradiance = [1.0, 1.0, 1.0]\n\
         [[camera]]\nname = \"down\"\neye = [0.0, 1.2, 0.0]\ntarget = [0.0, 0.0, 0.0]\n\
         up = [0.0, 0.0, -1.0]\nfov_y_deg = 40.0\nsize = [256, 256]\n",
    )
    .unwrap();
    let scene = Scene::load(&dir.join("scene.toml")).unwrap();
    let linear = srgb.map(|v| 0.9 * vlf::color::srgb_decode(v));
    (scene, linear)
}

/// The closed form of the checkered floor seen by camera "down" (256 x 256, looking straight
/// down from 1.2 m, x to the right, -z up the image) at the centre of pixel (i, j): which square
/// (0 dark, 1 light), or None within 1.5 image pixels of a square's edge (bilinear filtering
/// and the pixel's own extent blend the two there).
fn square_at(i: u32, j: u32) -> Option<usize> {
    let reach = 1.2 * (20.0f64).to_radians().tan();
    let (ndc_x, ndc_y) = (
        (i as f64 + 0.5) / 128.0 - 1.0,
        1.0 - (j as f64 + 0.5) / 128.0,
    );
    let (x, z) = (ndc_x * reach, -ndc_y * reach);
    // texture coordinates (the OBJ's), then image pixels from the image's top row
    let (u, v) = ((x + 1.0) * 8.0, (z + 1.0) * 8.0);
    let (px, py) = (u.fract() * 16.0, (1.0 - v.fract()) * 16.0);
    let edge = |p: f64| (p % 8.0).min(8.0 - p % 8.0);
    if edge(px) < 1.5 || edge(py) < 1.5 {
        return None;
    }
    Some(((px / 8.0) as usize + (py / 8.0) as usize) % 2)
}

/// Of the pixels away from the squares' edges: the share that shows its square's closed-form
/// value within `tolerance` (relative).
fn share_right(frame: &vlf::render::Frame, values: [f32; 2], tolerance: f32) -> f64 {
    let (mut right, mut counted) = (0usize, 0usize);
    for j in 0..frame.height {
        for i in 0..frame.width {
            let Some(square) = square_at(i, j) else {
                continue;
            };
            let shown = frame.pixels[(j * frame.width + i) as usize][1];
            counted += 1;
            right += usize::from((shown - values[square]).abs() <= tolerance * values[square]);
        }
    }
    right as f64 / counted as f64
}

#[test]
fn textures_finer_than_a_texel_keep_their_detail_in_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, [dark, light]) = checkered_floor_under_the_sky(dir.path());
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &small(), &Silent).unwrap();
    let detail = lf
        .detail
        .as_ref()
        .expect("a textured floor keeps its texture detail");
    assert_eq!(detail.triangle_uv.len(), 2);
    assert_eq!(detail.texel_albedo.len(), lf.total.len());
    let render = |lf: &vlf::lightfield::LightField| {
        let ledger = vlf::gpu::MemoryLedger::default();
        let resident = lf.upload(gpu()).unwrap();
        let mut r = vlf::render::Renderer::new(&resident, lf, &ledger).unwrap();
        r.set_samples_per_pixel(1).unwrap();
        r.render(lf.camera(None).unwrap(), 256, 256).unwrap()
    };
    let frame = render(&lf);
    // closed form: Kd x texture x sky, square by square where the pixel centre meets the floor
    let right = share_right(&frame, [dark, light], 0.005);
    let mean: f64 = frame.pixels.iter().map(|p| p[1] as f64).sum::<f64>() / 65536.0;
    let expected_mean = (dark as f64 + light as f64) / 2.0;
    println!(
        "texture detail: {:.1}% of the pixels inside the squares within 0.5% of the closed form (all within 0.2% on lavapipe); \
         mean {mean:.4} (closed form {expected_mean:.4})",
        right * 100.0
    );
    assert!(right > 0.97, "{right}");
    assert!(
        (mean / expected_mean - 1.0).abs() < 0.02,
        "mean {mean} vs {expected_mean}"
    );
    // without the detail the squares blur into each other at texel size
    let mut blurred = lf.clone();
    blurred.detail = None;
    let blur = share_right(&render(&blurred), [dark, light], 0.005);
    println!("at texel resolution: {:.1}%", blur * 100.0);
    assert!(blur < 0.5, "{blur}");
}
