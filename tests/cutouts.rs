//! Alpha cut-outs (issue 29 item 2): glTF alphaMode MASK / BLEND and MTL map_d cut holes where
//! every stage meets surfaces. A floor under a uniform sky with a black panel above it whose
//! stripes cover c = 3/4: the floor under the panel receives exactly what the holes let through,
//! pi Ls - c Ls x (the panel's cosine-weighted solid angle), through propagation's cell lines
//! (no direct light), through direct light's shadow rays, and in the path tracer; eye rays see
//! the floor through the holes and the panel elsewhere; the importers read what decides.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::progress::Silent;
use vlf::propagate::PropagationParams;
use vlf::scene::{Camera, Scene};

/// Coverage of the stripes: three texels of four covered.
const COVERAGE: f64 = 0.75;
/// The floor's albedo; the panel is black (what reaches the floor comes from the sky alone).
const FLOOR_ALBEDO: f64 = 0.5;
const PANEL_HEIGHT: f64 = 0.3;

/// A 4 x 4 RGBA image whose alpha is 255 in columns 0..3 and 0 in column 3.
fn stripes_png(path: &std::path::Path) {
    image::RgbaImage::from_fn(4, 4, |x, _| {
        image::Rgba([200, 100, 50, if x == 3 { 0 } else { 255 }])
    })
    .save(path)
    .unwrap();
}

/// A 2 x 2 floor (y = 0, up) under a 2 x 2 black panel (y = PANEL_HEIGHT, up) cut by 16
/// repeats of the stripes along x, under a uniform sky of radiance 1.
fn panel_scene(dir: &std::path::Path) -> Scene {
    stripes_png(&dir.join("stripes.png"));
    let h = PANEL_HEIGHT;
    let obj = format!(
        "mtllib scene.mtl\n\
         v -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\n\
         v -1 {h} 1\nv 1 {h} 1\nv 1 {h} -1\nv -1 {h} -1\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0 0\nvt 16 0\nvt 16 16\nvt 0 16\n\
         usemtl floor\nf 1/1 2/2 3/3 4/4\nusemtl panel\nf 5/5 6/6 7/7 8/8\n"
    );
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    std::fs::write(
        dir.join("scene.mtl"),
        format!(
            "newmtl floor\nKd {a} {a} {a}\n\nnewmtl panel\nKd 0 0 0\nmap_d stripes.png\n",
            a = FLOOR_ALBEDO
        ),
    )
    .unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "name = \"panel\"\nmesh = \"scene.obj\"\n[sky]\nradiance = [1.0, 1.0, 1.0]\n",
    )
    .unwrap();
    Scene::load(&dir.join("scene.toml")).unwrap()
}

fn params(direct_samples: u32) -> PropagationParams {
    PropagationParams {
        geodesic_frequency: 8,
        grid_resolution: 64,
        texel_density: 16.0,
        tolerance: 1e-3,
        max_iterations: 10,
        direct_samples,
        ..draft_params()
    }
}

/// Over the floor's texels within `reach` (normalised units) of the middle: the mean radiance
/// (green) of the light field and the mean the coverage says, rho/pi (pi - c I_panel(x)), with
/// I_panel the panel's irradiance at unit radiance (exact for a polygon).
fn floor_under_panel(scene: &Scene, total: &[[f32; 4]], reach: f64) -> (f64, f64, usize) {
    let prepared = vlf::prepare::PreparedScene::new(scene, params(0).texel_density).unwrap();
    let material = |name: &str| {
        let m = scene.materials.iter().position(|m| m.name == name);
        m.unwrap() as u32
    };
    let panel = face_corners(&prepared, material("panel"), DVec3::Y);
    let floor = material("floor");
    let (mut got, mut expected, mut n) = (0.0, 0.0, 0);
    for (i, p) in prepared.atlas.points.iter().enumerate() {
        let f = p[3].to_bits();
        let x = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        if f == u32::MAX
            || prepared.faces[f as usize].material != floor
            || prepared.atlas.coverage[i] < 1.0
            || x.x.abs() > reach
            || x.z.abs() > reach
        {
            continue;
        }
        let open = std::f64::consts::PI - COVERAGE * polygon_irradiance(x, DVec3::Y, &panel);
        got += total[i][1] as f64;
        expected += FLOOR_ALBEDO / std::f64::consts::PI * open;
        n += 1;
    }
    (got / n as f64, expected / n as f64, n)
}

/// The unblocked floor's radiance: rho x the sky.
fn unblocked() -> f64 {
    FLOOR_ALBEDO
}

#[test]
fn a_masked_panel_passes_the_light_its_coverage_says_through_the_cell_lines_and_shadow_rays() {
    let dir = tempfile::tempdir().unwrap();
    let scene = panel_scene(dir.path());
    assert!(scene.materials.iter().any(|m| m.cutout.is_some()));
    // (a) no direct light: the sky reaches the floor along the fixed directions' cell lines,
    // each left out where its line crosses the panel in a hole; (b) direct light: shadow rays
    for (samples, what, tolerance) in [(0, "cell lines", 0.04), (64, "shadow rays", 0.03)] {
        let (lf, _, _) =
            vlf::propagate::propagate(gpu(), &scene, &params(samples), &Silent).unwrap();
        let (got, expected, n) = floor_under_panel(&scene, &lf.total, 0.25);
        assert!(n >= 16, "{n} floor texels under the panel's middle");
        let passed = got / unblocked();
        let expected_passed = expected / unblocked();
        eprintln!(
            "{what}: floor under the panel {got:.5} (expected {expected:.5}): passes {passed:.4} \
             of the sky, coverage says {expected_passed:.4} ({n} texels)"
        );
        // an opaque panel would pass ~0.01 (its rim), no panel 1
        assert!(
            (passed / expected_passed - 1.0).abs() < tolerance,
            "{what}: the floor under the panel gets {passed:.4} of the sky, the coverage says \
             {expected_passed:.4}"
        );
    }
}

/// A camera between the panel and the floor, looking down at the floor's middle.
fn under_panel_camera() -> Camera {
    Camera {
        name: "under".into(),
        eye: [0.0, 0.1, 0.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, -1.0],
        fov_y_deg: 30.0,
        size: [16, 16],
    }
}

#[test]
fn the_path_tracer_passes_the_light_the_coverage_says() {
    let dir = tempfile::tempdir().unwrap();
    let scene = panel_scene(dir.path());
    let r = vlf::reference::render(
        gpu(),
        &scene,
        &under_panel_camera(),
        [16, 16],
        1024,
        3,
        &Silent,
    )
    .unwrap();
    let mean = r.mean.pixels.iter().map(|p| p[1] as f64).sum::<f64>() / 256.0;
    // the floor's middle, as floor_under_panel computes it at the centre
    let prepared = vlf::prepare::PreparedScene::new(&scene, 16.0).unwrap();
    let panel_m = scene.materials.iter().position(|m| m.name == "panel");
    let panel = face_corners(&prepared, panel_m.unwrap() as u32, DVec3::Y);
    let centre = prepared.normalisation.to_unit([0.0; 3]);
    let open = std::f64::consts::PI - COVERAGE * polygon_irradiance(centre, DVec3::Y, &panel);
    let expected = FLOOR_ALBEDO / std::f64::consts::PI * open;
    eprintln!("path tracer: floor's middle {mean:.5}, coverage says {expected:.5}");
    assert!(
        (mean / expected - 1.0).abs() < 0.02,
        "path tracer: the floor under the panel shows {mean:.5}, the coverage says {expected:.5}"
    );
}

#[test]
fn eye_rays_see_the_floor_through_the_holes_and_the_panel_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let scene = panel_scene(dir.path());
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &scene, &params(64), &Silent).unwrap();
    let (floor, _, _) = floor_under_panel(&scene, &lf.total, 0.15);
    let ledger = vlf::gpu::MemoryLedger::default();
    let resident = lf.upload(gpu()).unwrap();
    let mut r = vlf::render::Renderer::new(&resident, &lf, &ledger).unwrap();
    r.set_samples_per_pixel(1).unwrap();
    // from above: the panel's middle fills the view; one stripe period is ~12 pixels
    let cam = Camera {
        name: "above".into(),
        eye: [0.0, 1.2, 0.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, -1.0],
        fov_y_deg: 40.0,
        size: [64, 64],
    };
    let frame = r.render(&cam, 64, 64).unwrap();
    let g: Vec<f64> = frame.pixels.iter().map(|p| p[1] as f64).collect();
    // the panel is black: a covered pixel shows exactly 0; a hole shows the floor beneath
    let covered = g.iter().filter(|&&v| v == 0.0).count() as f64 / g.len() as f64;
    let holes: Vec<f64> = g.iter().copied().filter(|&v| v > 0.0).collect();
    let hole_mean = holes.iter().sum::<f64>() / holes.len().max(1) as f64;
    eprintln!(
        "eye rays: {covered:.3} of the pixels show the panel, the rest {hole_mean:.5} (the \
         floor under the middle {floor:.5})"
    );
    assert!(
        (covered - COVERAGE).abs() < 0.06,
        "{covered:.3} of the pixels show the panel; its coverage is {COVERAGE}"
    );
    assert!(
        (hole_mean / floor - 1.0).abs() < 0.07,
        "pixels through the holes show {hole_mean:.5}, the floor beneath is {floor:.5}"
    );
    // the same view without the cut-out: all panel
    let opaque = Scene {
        materials: (scene.materials.iter())
            .map(|m| vlf::scene::Material {
                cutout: None,
                ..m.clone()
            })
            .collect(),
        ..scene.clone()
    };
    let (lf, _, _) = vlf::propagate::propagate(gpu(), &opaque, &params(16), &Silent).unwrap();
    let resident = lf.upload(gpu()).unwrap();
    let mut r = vlf::render::Renderer::new(&resident, &lf, &ledger).unwrap();
    let frame = r.render(&cam, 64, 64).unwrap();
    assert!(
        frame.pixels.iter().all(|p| p[1] == 0.0),
        "an opaque black panel shows nothing else"
    );
}

/// A glTF model whose floor material is a cut-out: its base colour texture (a PNG beside it,
/// alpha 0.2 in the left half, 1 in the right) with `alpha` (mode and cutoff) and factor 0.8.
fn masked_gltf(dir: &std::path::Path, alpha: serde_json::Value) -> std::path::PathBuf {
    image::RgbaImage::from_fn(4, 2, |x, _| {
        image::Rgba([255, 255, 255, if x < 2 { 51 } else { 255 }])
    })
    .save(dir.join("leaf.png"))
    .unwrap();
    let mut floor = serde_json::json!({
        "name": "leaf",
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 0.8], "metallicFactor": 0.0,
                                  "baseColorTexture": {"index": 0}}
    });
    for (k, v) in alpha.as_object().unwrap() {
        floor[k] = v.clone();
    }
    let mut materials = gltf_basic_materials();
    materials[0] = floor;
    let nodes = serde_json::json!([{"children": [1, 2]}, {"mesh": 0}, {"mesh": 1}]);
    let extra = serde_json::json!({
        "images": [{"uri": "leaf.png"}],
        "textures": [{"source": 0}],
    });
    let path = dir.join("model.glb");
    std::fs::write(&path, gltf_model(materials, nodes, extra)).unwrap();
    path
}

/// The cutoff tools/mitsuba/reference.py gives `material` of `model` (`--dump-json`), if it
/// cuts holes in it.
fn reference_py_cutoff(model: &std::path::Path, material: &str) -> Option<f64> {
    let json = model.with_extension("json");
    python(
        "tools/mitsuba/reference.py",
        &[model.as_os_str(), "--dump-json".as_ref(), json.as_os_str()],
    );
    let dump: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    dump["materials"][material]["cutoff"].as_f64()
}

#[test]
fn gltf_mask_and_blend_are_read_with_cutoff_factor_and_texture_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let path = masked_gltf(
        dir.path(),
        serde_json::json!({"alphaMode": "MASK", "alphaCutoff": 0.4}),
    );
    let scene = Scene::load(&path).unwrap();
    let leaf = scene.materials.iter().find(|m| m.name == "leaf").unwrap();
    let cut = leaf.cutout.expect("MASK makes a cut-out");
    // alpha x factor < cutoff is alpha < cutoff / factor
    assert!((cut.cutoff - 0.4 / 0.8).abs() < 1e-6, "{cut:?}");
    let t = &scene.textures[cut.texture as usize];
    assert_eq!(t.alpha.len(), t.texels.len());
    assert!((t.alpha[0] - 0.2).abs() < 1e-6 && (t.alpha[3] - 1.0).abs() < 1e-6);
    // texture coordinates: the left half is a hole, the right half is not
    assert!(t.coverage([0.1, 0.5]) < cut.cutoff && t.coverage([0.9, 0.5]) >= cut.cutoff);
    assert!(
        !scene.warnings.iter().any(|w| w.contains("alpha")),
        "MASK is no longer an approximation: {:?}",
        scene.warnings
    );
    // the independent reader (tools/mitsuba/reference.py) makes the same cut-out of it
    let theirs = reference_py_cutoff(&path, "leaf").expect("reference.py cuts no holes");
    assert!(
        (theirs - cut.cutoff as f64).abs() < 1e-6,
        "{theirs} {cut:?}"
    );

    // BLEND: taken as MASK at 0.5, warned once for the material
    let dir = tempfile::tempdir().unwrap();
    let path = masked_gltf(dir.path(), serde_json::json!({"alphaMode": "BLEND"}));
    let scene = Scene::load(&path).unwrap();
    let leaf = scene.materials.iter().find(|m| m.name == "leaf").unwrap();
    assert!((leaf.cutout.unwrap().cutoff - 0.5 / 0.8).abs() < 1e-6);
    let blend: Vec<&String> = (scene.warnings.iter())
        .filter(|w| w.contains("BLEND"))
        .collect();
    assert_eq!(blend.len(), 1, "{:?}", scene.warnings);
    assert!(blend[0].contains("\"leaf\"") && blend[0].contains("cut-out"));

    // OPAQUE (the default): no cut-out, the alpha not even kept
    let dir = tempfile::tempdir().unwrap();
    let path = masked_gltf(dir.path(), serde_json::json!({}));
    let scene = Scene::load(&path).unwrap();
    assert!(scene.materials.iter().all(|m| m.cutout.is_none()));
    assert_eq!(reference_py_cutoff(&path, "leaf"), None);
    assert!(scene.textures.iter().all(|t| t.alpha.is_empty()));
}

#[test]
fn a_bad_alpha_texture_is_named_by_file_and_dissolve_without_a_map_stays_opaque() {
    let dir = tempfile::tempdir().unwrap();
    panel_scene(dir.path());
    std::fs::write(dir.path().join("stripes.png"), b"not a png").unwrap();
    let e = Scene::load(&dir.path().join("scene.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stripes.png") && e.contains("map_d") && e.contains("panel"),
        "{e}"
    );
    std::fs::remove_file(dir.path().join("stripes.png")).unwrap();
    let e = Scene::load(&dir.path().join("scene.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("stripes.png") && e.contains("cannot read"),
        "{e}"
    );
    // dissolve without a map (glass-like): opaque, warned
    let mtl = format!("newmtl floor\nKd {FLOOR_ALBEDO} 0.5 0.5\n\nnewmtl panel\nKd 0 0 0\nd 0.3\n");
    std::fs::write(dir.path().join("scene.mtl"), mtl).unwrap();
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    assert_eq!(scene.triangles.len(), 4);
    assert!(scene.materials.iter().all(|m| m.cutout.is_none()));
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("treated as opaque")),
        "{:?}",
        scene.warnings
    );
}
