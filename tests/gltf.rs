//! glTF import: a scene written by an independent tool (pygltflib, through tools/obj2gltf.py)
//! gives the light field its OBJ gives, texel for texel; `vlf generate --format gltf` likewise;
//! the importer's features (hierarchy, strips and fans, cameras, material rules, texture
//! transform, embedded images) on hand-made files; textures at scale are resolved to texel
//! density. Bad files are in tests/scene_errors.rs and tests/readers.rs.

use crate::common;
use common::*;
use std::path::{Path, PathBuf};
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

/// Both scenes propagated alike: every texel of the two light fields equal within 1e-5.
fn assert_same_light_field(a: &Scene, b: &Scene) {
    assert_eq!(a.triangles.len(), b.triangles.len());
    // two iterations: direct light and a bounce reach every texel, and equal scenes must give
    // equal texels at any iteration (converging only repeats the same transport)
    let params = PropagationParams {
        max_iterations: 2,
        ..small()
    };
    let (la, _, _) = vlf::propagate::propagate(gpu(), a, &params, &Silent).unwrap();
    let (lb, _, _) = vlf::propagate::propagate(gpu(), b, &params, &Silent).unwrap();
    assert_eq!(la.total.len(), lb.total.len(), "atlas sizes differ");
    let mut worst = 0.0f32;
    for (x, y) in la.total.iter().zip(&lb.total) {
        for c in 0..4 {
            worst = worst.max((x[c] - y[c]).abs());
        }
    }
    eprintln!(
        "{}: {} texels, largest difference {worst}",
        b.name,
        la.total.len()
    );
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

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn hierarchy_primitives_materials_and_cameras_are_imported() {
    let dir = tempfile::tempdir().unwrap();
    let nodes = serde_json::json!([
        {"name": "root", "translation": [0.0, 1.0, 0.0], "children": [1, 2, 3, 4]},
        {"mesh": 0, "scale": [2.0, 2.0, 2.0]},
        {"mesh": 1, "translation": [0.0, 0.5, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
        {"mesh": 2, "translation": [5.0, 0.0, 0.0]},
        {"camera": 0, "translation": [0.5, 1.0, 4.0]}
    ]);
    let extra = serde_json::json!({
        "cameras": [{"name": "cam", "type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 2.0, "znear": 0.1}}],
        "extensionsUsed": ["KHR_materials_emissive_strength"]
    });
    let path = write(
        dir.path(),
        "m.glb",
        &gltf_model(gltf_basic_materials(), nodes, extra),
    );
    let s = Scene::load(&path).unwrap();
    // floor: 2 triangles; light: 2; strip: 2; fan: 2; the point primitive is skipped
    assert_eq!(s.triangles.len(), 8, "{:?}", s.warnings);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("skipped 1 point/line primitive")),
        "{:?}",
        s.warnings
    );
    // the floor scaled by 2 and lifted by 1
    assert!(s.positions.contains(&[2.0, 1.0, 2.0]), "{:?}", s.positions);
    // the light: rotated 180 degrees about x (winding reversed by the rotation itself, not flipped)
    let lamp = s.materials.iter().position(|m| m.name == "lamp").unwrap();
    let m = &s.materials[lamp];
    assert_eq!(m.emission, [8.0, 4.0, 2.0]);
    assert!(m.two_sided);
    assert_eq!(s.materials[0].diffuse, [0.5, 0.6, 0.7]);
    assert_eq!(s.materials[0].mirror, [0.0; 3]);
    let cam = s.camera(Some("cam")).unwrap();
    assert_eq!(cam.eye, [0.5, 2.0, 4.0]);
    assert_eq!(cam.target, [0.5, 2.0, 3.0]);
    assert_eq!(cam.size, [1536, 768]);
    assert!((cam.fov_y_deg - 0.8f32.to_degrees()).abs() < 1e-4);
    // faces of the floor carry the texture coordinates, v flipped
    let floor = s
        .triangles
        .iter()
        .find(|t| t.material == 0 && t.uv.is_some());
    assert!(
        floor.is_none(),
        "an untextured material carries no coordinates"
    );
}

#[test]
fn material_rules_and_their_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let png = {
        let mut b = Vec::new();
        let img = image::RgbImage::from_pixel(4, 4, image::Rgb([255, 128, 0]));
        img.write_to(&mut std::io::Cursor::new(&mut b), image::ImageFormat::Png)
            .unwrap();
        b
    };
    write(dir.path(), "orange image.png", &png);
    let materials = serde_json::json!([
        {"name": "floor", "alphaMode": "MASK", "normalTexture": {"index": 0},
         "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.9,
            "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [2.0, 2.0]}}}}},
        {"name": "chrome", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.05,
            "baseColorTexture": {"index": 0}}}
    ]);
    let nodes = serde_json::json!([{"children": [1, 2, 3]}, {"mesh": 0}, {"mesh": 1},
        {"extensions": {"KHR_lights_punctual": {"light": 0}}}]);
    let extra = serde_json::json!({
        "images": [{"uri": "orange%20image.png"}],
        "textures": [{"source": 0}],
        "extensionsUsed": ["KHR_texture_transform", "KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "name": "bulb"}]}}
    });
    let path = write(dir.path(), "m.glb", &gltf_model(materials, nodes, extra));
    let s = Scene::load(&path).unwrap();
    let w = s.warnings.join("\n");
    // alpha MASK is a cut-out now (tests/cutouts.rs), not an approximation
    assert!(w.contains("glTF material \"floor\": approximated: metallic 1 roughness 0.9: a rough metal, taken as diffuse of the base colour"), "{w}");
    assert!(
        !w.contains("normal map"),
        "a normal map is read, not approximated: {w}"
    );
    assert!(
        w.contains("KHR_lights_punctual light(s) \"bulb\" cannot be represented"),
        "{w}"
    );
    // a textured metal is split per texel (tests/glossy.rs); chrome's triangles carry no texture
    // coordinates, so its texture is ignored (said once) and its factors decide
    assert!(
        w.contains("\"chrome\" have no texture coordinates: their textures are ignored"),
        "{w}"
    );
    assert!(!w.contains("glTF material \"chrome\": approximated"), "{w}");
    let floor = &s.materials[0];
    assert_eq!(floor.diffuse, [0.8; 3]);
    assert_eq!(floor.diffuse_texture, Some(0));
    let cut = floor.cutout.expect("alpha MASK: a cut-out");
    assert_eq!((cut.texture, cut.cutoff), (0, 0.5));
    // normalTexture: a normal map (scale 1 by default), its image read raw as a texture of its own
    let map = floor.normal_map.expect("normalTexture: a normal map");
    assert_eq!(map.scale, 1.0);
    assert_ne!(map.texture, 0);
    let t = &s.textures[map.texture as usize];
    assert!(
        (t.texels[0][1] - 128.0 / 255.0).abs() < 1e-6,
        "{:?}",
        t.texels[0]
    );
    let chrome = &s.materials[1];
    assert_eq!(chrome.diffuse, [0.0; 3]);
    assert_eq!((chrome.mirror, chrome.roughness), ([0.9; 3], 0.0));
    assert_eq!(chrome.specular_texture, None);
    // KHR_texture_transform: u' = 2u + 0.5, v' = 2v; then v flipped for the scene
    let t = s
        .triangles
        .iter()
        .find(|t| t.material == 0 && t.uv.is_some())
        .unwrap();
    let p = s.positions[t.vertices[2] as usize];
    let expect_u = 2.0 * p[0] + 0.5;
    let expect_v = 1.0 - 2.0 * p[2];
    assert_eq!(t.uv.unwrap()[2], [expect_u, expect_v], "corner {p:?}");
    // the framing camera, as the model has none
    assert_eq!(s.cameras.len(), 1);
    assert_eq!(s.cameras[0].name, "view");
    assert_eq!(
        s.textures.len(),
        2,
        "the base colour and the normal map: the mirror's texture is averaged, not kept"
    );
    // a scene.toml that gives the metal's specular part replaces the glTF's kind: it is not
    // reported as an approximation of the glTF's values
    write(dir.path(), "scene.toml", b"name = \"t\"\nmesh = \"m.glb\"\n[materials.chrome]\nmirror = [0.5, 0.5, 0.5]\nroughness = 0.1\n");
    let s = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let w = s.warnings.join("\n");
    assert!(!w.contains("\"chrome\": approximated"), "{w}");
    assert!(w.contains("\"floor\": approximated"), "{w}");
    // (the override's specular colour still times the base colour texture's mean: red is 1)
    let chrome = &s.materials[1];
    assert_eq!((chrome.mirror[0], chrome.roughness), (0.5, 0.1));
}

fn simple_nodes() -> serde_json::Value {
    serde_json::json!([{"children": [1, 2]}, {"mesh": 0}, {"mesh": 1}])
}

fn load_err(path: &Path) -> String {
    Scene::load(path).unwrap_err().to_string()
}

#[test]
fn bad_gltf_files_get_errors_naming_file_and_fault() {
    let dir = tempfile::tempdir().unwrap();
    let good = gltf_model(
        gltf_basic_materials(),
        simple_nodes(),
        serde_json::json!({}),
    );
    let ok = write(dir.path(), "ok.glb", &good);
    assert!(Scene::load(&ok).is_ok());
    // truncated
    let p = write(dir.path(), "cut.glb", &good[..good.len() - 40]);
    let e = load_err(&p);
    assert!(e.contains("cut.glb") && e.contains("binary glTF"), "{e}");
    // broken JSON
    let p = write(
        dir.path(),
        "broken.gltf",
        b"{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [",
    );
    let e = load_err(&p);
    assert!(
        e.contains("broken.gltf") && e.contains("not valid glTF JSON"),
        "{e}"
    );
    // an accessor reaching past its buffer view
    let mut json: serde_json::Value = {
        let len = u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize;
        serde_json::from_slice(&good[20..20 + len]).unwrap()
    };
    let bin_at = 20 + u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize + 8;
    let bin = good[bin_at..].to_vec();
    json["accessors"][0]["count"] = serde_json::json!(9);
    let p = write(dir.path(), "overrun.glb", &glb(&json, &bin));
    let e = load_err(&p);
    assert!(
        e.contains("overrun.glb")
            && e.contains("mesh 0 primitive 0: POSITION (accessor 0)")
            && e.contains("overrun its buffer view"),
        "{e}"
    );
    // an index past the vertices
    json["accessors"][0]["count"] = serde_json::json!(2);
    let p = write(dir.path(), "index.glb", &glb(&json, &bin));
    let e = load_err(&p);
    assert!(
        e.contains("index.glb") && e.contains("index 2 is out of range (2 vertices)"),
        "{e}"
    );
    // an index to an accessor that is not there
    json["accessors"][0]["count"] = serde_json::json!(8);
    json["meshes"][0]["primitives"][0]["indices"] = serde_json::json!(42);
    let p = write(dir.path(), "ref.glb", &glb(&json, &bin));
    let e = load_err(&p);
    assert!(
        e.contains("ref.glb") && e.contains("not a valid glTF 2.0 file") && e.contains("indices"),
        "{e}"
    );
    // a missing image, and a missing buffer file
    json["meshes"][0]["primitives"][0]["indices"] = serde_json::json!(2);
    json["images"] = serde_json::json!([{"uri": "gone.png"}]);
    json["textures"] = serde_json::json!([{"source": 0}]);
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] =
        serde_json::json!({"index": 0});
    let p = write(dir.path(), "noimage.glb", &glb(&json, &bin));
    let e = load_err(&p);
    assert!(
        e.contains("noimage.glb")
            && e.contains("image 0")
            && e.contains("gone.png")
            && e.contains("cannot read"),
        "{e}"
    );
    json["buffers"][0]["uri"] = serde_json::json!("gone.bin");
    let p = write(
        dir.path(),
        "nobuffer.gltf",
        &serde_json::to_vec(&json).unwrap(),
    );
    let e = load_err(&p);
    assert!(
        e.contains("nobuffer.gltf") && e.contains("buffer 0") && e.contains("gone.bin"),
        "{e}"
    );
    // a required extension vlf cannot read
    json["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    json["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    let p = write(
        dir.path(),
        "draco.gltf",
        &serde_json::to_vec(&json).unwrap(),
    );
    let e = load_err(&p);
    assert!(
        e.contains("draco.gltf") && e.contains("KHR_draco_mesh_compression"),
        "{e}"
    );
}

#[test]
fn a_scene_toml_can_name_a_gltf_and_override_its_materials() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "m.glb",
        &gltf_model(
            gltf_basic_materials(),
            simple_nodes(),
            serde_json::json!({}),
        ),
    );
    write(dir.path(), "scene.toml", b"name = \"t\"\nmesh = \"m.glb\"\n[sky]\nradiance = [1, 1, 1]\n[materials.floor]\nmirror = [0.5, 0.5, 0.5]\ndiffuse = [0.2, 0.2, 0.2]\n");
    for path in [dir.path().join("scene.toml"), dir.path().join("m.glb")] {
        let s = Scene::load(&path).unwrap();
        assert_eq!(s.name, "t");
        assert_eq!(s.sky, Some([1.0; 3]));
        assert_eq!(s.materials[0].mirror, [0.5; 3]);
        assert_eq!(s.cameras[0].name, "view");
    }
    write(
        dir.path(),
        "scene.toml",
        b"name = \"t\"\nmesh = \"m.glb\"\n[materials.nosuch]\ntwo_sided = true\n",
    );
    let e = load_err(&dir.path().join("scene.toml"));
    assert!(
        e.contains("scene.toml") && e.contains("nosuch") && e.contains("floor, lamp"),
        "{e}"
    );
}

/// 120 panels, each with its own 4096 x 4096 texture: kept whole that is 24 GB of linear RGB;
/// resolved to texel density on the way in it is a few MB, and the scene propagates.
#[test]
fn a_hundred_and_twenty_4k_textures_are_resolved_to_texel_density() {
    const N: usize = 120;
    let dir = tempfile::tempdir().unwrap();
    let png = {
        let img = image::RgbImage::from_fn(4096, 4096, |x, y| {
            if (x / 512 + y / 512) % 2 == 0 {
                image::Rgb([230, 200, 120])
            } else {
                image::Rgb([40, 60, 90])
            }
        });
        let mut b = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut b), image::ImageFormat::Png)
            .unwrap();
        b
    };
    // a floor of 12 x 10 panels (each its own material and image) under a light
    let (mut pos, mut uv, mut idx) = (Vec::<f32>::new(), Vec::<f32>::new(), Vec::<u32>::new());
    let mut prims = Vec::new();
    let mut materials = Vec::new();
    let mut images = Vec::new();
    for k in 0..N {
        let (x, z) = ((k % 12) as f32 * 0.25, (k / 12) as f32 * 0.25);
        let first = (pos.len() / 3) as u32;
        for (dx, dz) in [(0.0, 0.0), (0.0, 0.25), (0.25, 0.25), (0.25, 0.0)] {
            pos.extend([x + dx, 0.0, z + dz]);
            uv.extend([dx * 4.0, dz * 4.0]);
        }
        idx.extend([first, first + 1, first + 2, first, first + 2, first + 3]);
        prims.push(serde_json::json!({"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": k + 2, "material": k}));
        materials.push(serde_json::json!({"name": format!("panel{k}"), "pbrMetallicRoughness": {"baseColorTexture": {"index": k}, "metallicFactor": 0.0}}));
        images.push(serde_json::json!({"uri": format!("t{k}.png")}));
        std::fs::write(dir.path().join(format!("t{k}.png")), &png).unwrap();
    }
    let first = (pos.len() / 3) as u32;
    for (x, z) in [(1.0, 1.0), (2.0, 1.0), (2.0, 1.5), (1.0, 1.5)] {
        pos.extend([x, 1.5, z]);
        uv.extend([0.0, 0.0]);
    }
    idx.extend([first, first + 1, first + 2, first, first + 2, first + 3]);
    prims.push(serde_json::json!({"attributes": {"POSITION": 0}, "indices": N + 2, "material": N}));
    materials.push(
        serde_json::json!({"name": "light", "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5.0}}}),
    );
    let mut bin: Vec<u8> = pos.iter().flat_map(|x| x.to_le_bytes()).collect();
    let uv_at = bin.len();
    bin.extend(uv.iter().flat_map(|x| x.to_le_bytes()));
    let idx_at = bin.len();
    bin.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
    let vertices = pos.len() / 3;
    let mut accessors = vec![
        serde_json::json!({"bufferView": 0, "componentType": 5126, "count": vertices, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [3.0, 1.5, 2.5]}),
        serde_json::json!({"bufferView": 1, "componentType": 5126, "count": vertices, "type": "VEC2"}),
    ];
    for k in 0..=N {
        accessors.push(serde_json::json!({"bufferView": 2, "byteOffset": k * 24, "componentType": 5125, "count": 6, "type": "SCALAR"}));
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": uv_at},
            {"buffer": 0, "byteOffset": uv_at, "byteLength": idx_at - uv_at},
            {"buffer": 0, "byteOffset": idx_at, "byteLength": bin.len() - idx_at}
        ],
        "accessors": accessors,
        "meshes": [{"primitives": prims}],
        "materials": materials,
        "images": images,
        "textures": (0..N).map(|k| serde_json::json!({"source": k})).collect::<Vec<_>>(),
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}]
    });
    let path = write(dir.path(), "many.glb", &glb(&json, &bin));
    let t0 = std::time::Instant::now();
    let scene = Scene::load(&path).unwrap();
    eprintln!(
        "loaded {} textures in {:.1} s: {:?}",
        scene.textures.len(),
        t0.elapsed().as_secs_f64(),
        scene.texture_memory
    );
    let m = scene.texture_memory;
    assert_eq!(m.textures as usize, N);
    assert_eq!(m.reduced as usize, N);
    assert_eq!(m.full_bytes, N as u64 * 4096 * 4096 * 12);
    assert!(m.kept_bytes < 64 << 20, "{m:?}");
    // still at least TEXTURE_TEXELS_PER_UNIT texels per unit length of the normalised scene
    let scale = vlf::prepare::normalise(&scene.positions).scale;
    let texels_per_unit = scene.textures[0].width as f64 / (0.25 * scale);
    assert!(
        texels_per_unit >= vlf::scene::texels::TEXTURE_TEXELS_PER_UNIT,
        "{texels_per_unit}"
    );
    let (_, _, report) = vlf::propagate::propagate(gpu(), &scene, &small(), &Silent).unwrap();
    assert_eq!(report.host_textures, m);
    assert!(report.texture_bytes > 0);
    assert!(
        report.table().contains("reduced to texel density"),
        "{}",
        report.table()
    );
}

/// `vlf generate --format gltf` writes the scene its OBJ is: the same light field.
#[cfg(feature = "lab")] // the classroom comes from the lab's generator
#[test]
fn generated_classroom_as_gltf_gives_the_obj_light_field() {
    use vlf::lab::generate::{generate_as, GenerateOptions, MeshFormat, SceneKind};
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let options = GenerateOptions {
        kind: SceneKind::Classroom,
        size: 1000,
        mirrors: true,
        glossy: false,
    };
    let obj = generate_as(&options, a.path(), MeshFormat::Obj).unwrap();
    let gltf = generate_as(&options, b.path(), MeshFormat::Gltf).unwrap();
    assert!(b.path().join("scene.gltf").exists() && b.path().join("scene.bin").exists());
    let (so, sg) = (
        Scene::load(&obj.scene).unwrap(),
        Scene::load(&gltf.scene).unwrap(),
    );
    assert_eq!(
        sg.materials
            .iter()
            .find(|m| m.name == "mirror")
            .unwrap()
            .mirror,
        [0.85; 3]
    );
    assert_same_light_field(&so, &sg);
}

/// A metallic-roughness texture decides per texel with the factors (roughness from green,
/// metallic from blue, linear): factors 1 and 1 with a texture of roughness 0.4 and metallic 1
/// everywhere are a glossy metal of GGX alpha 0.16 (its specular texture 1 everywhere); the
/// light, whose triangles carry no texture coordinates, is decided by its factors alone
/// (metallic 1, roughness 1: a rough metal, diffuse), said once.
#[test]
fn a_metallic_roughness_texture_decides_per_texel() {
    let dir = tempfile::tempdir().unwrap();
    let png = |rgb: [u8; 3]| {
        let mut b = Vec::new();
        let img = image::RgbImage::from_pixel(4, 4, image::Rgb(rgb));
        img.write_to(&mut std::io::Cursor::new(&mut b), image::ImageFormat::Png)
            .unwrap();
        b
    };
    write(dir.path(), "metal.png", &png([0, 102, 255]));
    write(dir.path(), "plastic.png", &png([0, 102, 0]));
    let materials = serde_json::json!([
        {"name": "brushed", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.7, 1.0],
            "metallicFactor": 1.0, "roughnessFactor": 1.0, "metallicRoughnessTexture": {"index": 0}}},
        {"name": "plastic", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
            "metallicFactor": 1.0, "roughnessFactor": 1.0, "metallicRoughnessTexture": {"index": 1}}}
    ]);
    let nodes = serde_json::json!([{"children": [1, 2]}, {"mesh": 0}, {"mesh": 1}]);
    let extra = serde_json::json!({
        "images": [{"uri": "metal.png"}, {"uri": "plastic.png"}],
        "textures": [{"source": 0}, {"source": 1}]
    });
    let path = write(dir.path(), "m.glb", &gltf_model(materials, nodes, extra));
    let s = Scene::load(&path).unwrap();
    let w = s.warnings.join("\n");
    println!("{w}");
    let brushed = &s.materials[0];
    assert_eq!(brushed.diffuse, [0.0; 3]);
    assert_eq!(brushed.mirror, [0.9, 0.8, 0.7]);
    assert!(
        (brushed.roughness - 0.16).abs() < 1e-6,
        "GGX alpha {} (roughness 0.4 squared)",
        brushed.roughness
    );
    let t = &s.textures[brushed.specular_texture.expect("a specular texture") as usize];
    assert!(t.texels.iter().all(|&c| c == [1.0; 3]), "{:?}", t.texels);
    assert!(
        t.alpha.iter().all(|&a| (a - 0.16).abs() < 1e-6),
        "{:?}",
        t.alpha
    );
    assert!(!w.contains("brushed"), "nothing approximated: {w}");
    let plastic = &s.materials[1];
    assert_eq!(plastic.diffuse, [0.5; 3]);
    assert_eq!(plastic.mirror, [0.0; 3]);
    assert!(
        w.contains("\"plastic\" have no texture coordinates: their textures are ignored"),
        "{w}"
    );
}
