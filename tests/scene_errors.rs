//! Bad scene input gives a clear error naming the file and the cause; repairs are reported.

use crate::common;
use common::*;
use glam::DVec3;
use vlf::scene::Scene;

fn tiny(dir: &std::path::Path) -> std::path::PathBuf {
    let mut obj = ObjBuilder::default();
    obj.quad("white", DVec3::ZERO, DVec3::Z, [1.0, 1.0], 0.0);
    write_scene(
        dir,
        &obj,
        &[Mat {
            name: "white",
            kd: [0.5; 3],
            ke: [0.0; 3],
        }],
        "",
    )
}

fn load_err(path: &std::path::Path) -> String {
    match Scene::load(path) {
        Ok(_) => panic!("{} loaded, but should have failed", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_valid_scene_loads() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&tiny(dir.path())).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

#[test]
fn missing_obj_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    std::fs::remove_file(dir.path().join("scene.obj")).unwrap();
    let e = load_err(&path);
    assert!(e.contains("scene.obj") && e.contains("cannot read"), "{e}");
}

#[test]
fn missing_mtl_names_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    std::fs::remove_file(dir.path().join("scene.mtl")).unwrap();
    let e = load_err(&path);
    assert!(
        e.contains("scene.mtl") && e.contains("material library"),
        "{e}"
    );
}

#[test]
fn nan_vertex_names_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    let obj = std::fs::read_to_string(dir.path().join("scene.obj"))
        .unwrap()
        .replacen("v -0.5", "v nan", 1);
    std::fs::write(dir.path().join("scene.obj"), obj).unwrap();
    let e = load_err(&path);
    assert!(
        e.contains("scene.obj") && e.contains("line 3") && e.contains("non-finite"),
        "{e}"
    );
}

#[test]
fn face_index_out_of_range_names_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    let obj = std::fs::read_to_string(dir.path().join("scene.obj")).unwrap() + "f 1 2 9\n";
    std::fs::write(dir.path().join("scene.obj"), obj).unwrap();
    let e = load_err(&path);
    assert!(
        e.contains("scene.obj") && e.contains("line 8") && e.contains("out of range"),
        "{e}"
    );
}

#[test]
fn albedo_outside_zero_one_is_refused() {
    for bad in ["1.2 0.5 0.5", "-0.1 0.5 0.5"] {
        let dir = tempfile::tempdir().unwrap();
        let path = tiny(dir.path());
        let mtl = std::fs::read_to_string(dir.path().join("scene.mtl"))
            .unwrap()
            .replace("Kd 0.5 0.5 0.5", &format!("Kd {bad}"));
        std::fs::write(dir.path().join("scene.mtl"), mtl).unwrap();
        let e = load_err(&path);
        assert!(
            e.contains("scene.mtl") && e.contains("\"white\"") && e.contains("Kd"),
            "{e}"
        );
    }
    // the same through a scene override
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    let toml = std::fs::read_to_string(&path).unwrap()
        + "\n[materials.white]\ndiffuse = [1.5, 0.0, 0.0]\n";
    std::fs::write(&path, toml).unwrap();
    let e = load_err(&path);
    assert!(
        e.contains("scene.toml") && e.contains("materials.white.diffuse"),
        "{e}"
    );
}

#[test]
fn diffuse_plus_mirror_above_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    let toml =
        std::fs::read_to_string(&path).unwrap() + "\n[materials.white]\nmirror = [0.8, 0.8, 0.8]\n";
    std::fs::write(&path, toml).unwrap();
    let e = load_err(&path);
    assert!(e.contains("exceeds 1"), "{e}");
}

#[test]
fn unknown_toml_key_names_the_key_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    let toml = std::fs::read_to_string(&path)
        .unwrap()
        .replace("mesh =", "colour = 3\nmesh =");
    std::fs::write(&path, toml).unwrap();
    let e = load_err(&path);
    assert!(
        e.contains("scene.toml") && e.contains("colour") && e.contains("line 2"),
        "{e}"
    );
}

#[test]
fn zero_area_triangles_are_dropped_with_a_count() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    let obj = std::fs::read_to_string(dir.path().join("scene.obj")).unwrap()
        + "v 0 0 0\nv 1 1 1\nv 2 2 2\nf -3 -2 -1\nf -3 -3 -1\n";
    std::fs::write(dir.path().join("scene.obj"), obj).unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("dropped 2 zero-area")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn duplicated_triangles_are_dropped_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let path = tiny(dir.path());
    // the quad's two triangles again (same corners, same winding; one of them rotated)
    let obj = std::fs::read_to_string(dir.path().join("scene.obj")).unwrap();
    let faces: Vec<&str> = obj.lines().filter(|l| l.starts_with("f ")).collect();
    let again = faces.join("\n");
    std::fs::write(dir.path().join("scene.obj"), format!("{obj}\n{again}\n")).unwrap();
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.triangles.len(), 2);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("dropped 2 duplicated")),
        "{:?}",
        scene.warnings
    );
}

#[test]
fn the_shipped_cornell_box_loads_without_a_warning() {
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let cam = scene.camera(Some("front")).unwrap();
    assert_eq!(
        (cam.eye, cam.target, cam.up, cam.fov_y_deg, cam.size),
        (
            [0.0, 1.0, 3.9],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            39.3,
            [512, 512]
        )
    );
}

/// scenes/small-things is what tools/make-small-things.py writes, and its detail is what the
/// accuracy suite says it is: smaller than a texel and a grid cell at default settings.
#[test]
fn the_small_things_scene_is_its_scripts_and_its_detail_is_below_a_texel() {
    let dir = tempfile::tempdir().unwrap();
    let run = std::process::Command::new("python3")
        .arg(repo_path("tools/make-small-things.py"))
        .arg(dir.path())
        .output()
        .expect("python3 runs tools/make-small-things.py");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for file in ["room.obj", "room.mtl", "scene.toml"] {
        let shipped = std::fs::read(repo_path(&format!("scenes/small-things/{file}"))).unwrap();
        let written = std::fs::read(dir.path().join(file)).unwrap();
        assert!(
            shipped == written,
            "scenes/small-things/{file} differs from what tools/make-small-things.py writes"
        );
    }
    let scene = Scene::load(&repo_path("scenes/small-things/scene.toml")).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let density = vlf::params::PropagationParams::default().texel_density;
    let prepared = vlf::prepare::PreparedScene::new(&scene, density).unwrap();
    let small = prepared
        .warnings
        .iter()
        .any(|w| w.contains("smaller than one texel"));
    assert!(
        small,
        "no face below a texel at density {density}: {:?}",
        prepared.warnings
    );
}

#[test]
fn cornell_groups_into_planar_faces_with_a_padded_atlas() {
    let scene = Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let prepared = vlf::prepare::PreparedScene::new(&scene, 16.0).unwrap();
    // 5 walls, light, 5 + 5 box faces: the non-planar walls still make one face each
    assert_eq!(prepared.faces.len(), 16);
    for p in &prepared.positions {
        assert!(p.length() <= 0.99 + 1e-9, "not in the unit sphere: {p}");
    }
    for f in &prepared.faces {
        // one padding texel on each side
        assert!(f.atlas.w >= 3 && f.atlas.h >= 3);
    }
    // charts do not overlap
    for (i, a) in prepared.faces.iter().enumerate() {
        for b in &prepared.faces[i + 1..] {
            let (ra, rb) = (a.atlas, b.atlas);
            let disjoint = ra.x + ra.w <= rb.x
                || rb.x + rb.w <= ra.x
                || ra.y + ra.h <= rb.y
                || rb.y + rb.h <= ra.y;
            assert!(disjoint, "charts {ra:?} and {rb:?} overlap");
        }
    }
}

/// Every shipped scene loads, and the glossy ones carry their lobes: the Cornell box's tall box a
/// rough metal (alpha 0.1, no diffuse part), the glossy-floor room's floor a Lambert base under a
/// lobe of reflectance 0.1 and alpha 0.05.
#[test]
fn every_shipped_scene_loads_and_the_glossy_ones_carry_their_lobes() {
    let mut names = Vec::new();
    for entry in std::fs::read_dir(repo_path("scenes")).unwrap() {
        let path = entry.unwrap().path().join("scene.toml");
        if path.exists() {
            let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            names.push((scene.name.clone(), scene));
        }
    }
    let find = |name: &str, material: &str| -> vlf::material::Material {
        let (_, scene) = (names.iter().find(|(n, _)| n == name))
            .unwrap_or_else(|| panic!("scenes/{name} is not shipped"));
        (scene.materials.iter().find(|m| m.name == material))
            .unwrap_or_else(|| panic!("{name} has no material {material}"))
            .clone()
    };
    let metal = find("cornell-glossy", "tallBox");
    assert_eq!(
        (metal.roughness, metal.mirror, metal.diffuse),
        (0.1, [0.8; 3], [0.0; 3])
    );
    let floor = find("glossy-floor", "floor");
    assert_eq!((floor.roughness, floor.mirror), (0.05, [0.1; 3]));
    assert!(
        floor.diffuse.iter().all(|&d| d > 0.4 && d < 0.5),
        "{floor:?}"
    );
    assert!(names.len() >= 9, "{} scenes", names.len());
}

/// MTL's PBR extension by glTF's rules: `Pm` >= 0.5 makes `Kd` the specular part of a metal (an
/// ideal mirror up to `Pr` 0.2, a GGX lobe of alpha Pr² up to 0.6, diffuse when rougher); a
/// dielectric keeps `Kd` diffuse and `Ks` with alpha Pr²; a metal's `map_Kd` is not read, warned.
#[test]
fn mtl_metallic_and_roughness_follow_gltfs_rules() {
    let dir = tempfile::tempdir().unwrap();
    let mut obj = String::from("mtllib m.mtl\n");
    let names = ["chrome", "brushed", "rough", "varnish"];
    for (k, name) in names.iter().enumerate() {
        let x = k as f32 * 2.0;
        obj += &format!(
            "v {x} 0 0\nv {} 0 0\nv {} 0 1\nv {x} 0 1\nusemtl {name}\nf {} {} {} {}\n",
            x + 1.0,
            x + 1.0,
            4 * k + 1,
            4 * k + 4,
            4 * k + 3,
            4 * k + 2
        );
    }
    std::fs::write(dir.path().join("m.obj"), obj).unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl chrome\nKd 0.9 0.8 0.7\nPm 1\nPr 0.1\n\
         newmtl brushed\nKd 0.9 0.8 0.7\nPm 0.8\nPr 0.5\nmap_Kd missing.png\n\
         newmtl rough\nKd 0.9 0.8 0.7\nPm 1\nPr 0.9\n\
         newmtl varnish\nKd 0.5 0.5 0.5\nKs 0.04 0.04 0.04\nPm 0\nPr 0.5\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("scene.toml"),
        "name = \"metals\"\nmesh = \"m.obj\"\n",
    )
    .unwrap();
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap();
    let m = |name: &str| {
        let m = scene.materials.iter().find(|m| m.name == name).unwrap();
        (m.diffuse, m.mirror, m.roughness)
    };
    assert_eq!(m("chrome"), ([0.0; 3], [0.9, 0.8, 0.7], 0.0));
    assert_eq!(m("brushed"), ([0.0; 3], [0.9, 0.8, 0.7], 0.25));
    assert_eq!(m("rough"), ([0.9, 0.8, 0.7], [0.0; 3], 0.0));
    assert_eq!(m("varnish"), ([0.5; 3], [0.04; 3], 0.25));
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("brushed") && w.contains("map_Kd")),
        "{:?}",
        scene.warnings
    );
}
