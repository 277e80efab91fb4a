//! Helpers shared by the integration tests: the GPU (never a silent skip), and scenes written
//! to temporary folders as real scene.toml + OBJ + MTL files, loaded through the real importer.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use vlf::gpu::GpuContext;

/// The test GPU. Without an adapter this fails, saying how to get one.
pub fn gpu() -> Arc<GpuContext> {
    static CTX: OnceLock<Arc<GpuContext>> = OnceLock::new();
    CTX.get_or_init(|| match GpuContext::new() {
        Ok(ctx) => ctx,
        Err(e) => panic!(
            "GPU tests need a wgpu adapter and found none: {e}\n\
             On Debian/Ubuntu run `sudo apt-get install mesa-vulkan-drivers` (software Vulkan, lavapipe), \
             or `bash tools/test.sh`, which installs it."
        ),
    })
    .clone()
}

/// A material line for the MTL file.
pub struct Mat {
    pub name: &'static str,
    pub kd: [f32; 3],
    pub ke: [f32; 3],
}

/// An OBJ built from quads, each with a material (the library's, shared with `vlf stress`).
pub use vlf::scene::builder::QuadMesh as ObjBuilder;

/// Write the scene (as `write_scene`) and load it through the real importer.
pub fn load_scene(
    dir: &Path,
    obj: &ObjBuilder,
    materials: &[Mat],
    extra_toml: &str,
) -> vlf::scene::Scene {
    vlf::scene::Scene::load(&write_scene(dir, obj, materials, extra_toml)).unwrap()
}

/// A closed box of side 2 (inward walls, material "wall") with a floating block ("block") that
/// shadows part of the floor and an emitter ("light") under the ceiling: light far from
/// uniform, several bounces deep (the two-sided and power-balance tests).
pub fn closed_box_with_block() -> ObjBuilder {
    let mut obj = ObjBuilder::default();
    obj.cube("wall", glam::DVec3::ZERO, 1.0, true);
    obj.cube("block", glam::DVec3::new(0.2, -0.4, 0.1), 0.3, false);
    obj.quad(
        "light",
        glam::DVec3::new(0.0, 0.98, 0.0),
        -glam::DVec3::Y,
        [0.5, 0.5],
        0.0,
    );
    obj
}

/// Write scene.toml + scene.obj + scene.mtl into `dir` and return the scene.toml path.
pub fn write_scene(dir: &Path, obj: &ObjBuilder, materials: &[Mat], extra_toml: &str) -> PathBuf {
    let mut mtl = String::new();
    for m in materials {
        mtl.push_str(&format!(
            "newmtl {}\nKd {} {} {}\nKe {} {} {}\nKs 0 0 0\n\n",
            m.name, m.kd[0], m.kd[1], m.kd[2], m.ke[0], m.ke[1], m.ke[2]
        ));
    }
    std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    std::fs::write(dir.join("scene.obj"), obj.text("scene.mtl")).unwrap();
    let toml = format!(
        "name = \"test\"\nmesh = \"scene.obj\"\n{extra_toml}\n[[camera]]\nname = \"front\"\neye = [0.0, 0.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]\nfov_y_deg = 40.0\nsize = [64, 64]\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, toml).unwrap();
    path
}

pub fn repo_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// Coverage-weighted mean of `values` over the texels of the faces that satisfy `pick`.
pub fn face_mean(
    prepared: &vlf::prepare::PreparedScene,
    values: &[[f32; 4]],
    pick: impl Fn(usize) -> bool,
    channel: usize,
) -> f64 {
    let (mut sum, mut weight) = (0.0, 0.0);
    for (i, p) in prepared.atlas.points.iter().enumerate() {
        let face = p[3].to_bits();
        if face == u32::MAX || !pick(face as usize) {
            continue;
        }
        let c = prepared.atlas.coverage[i] as f64;
        sum += values[i][channel] as f64 * c;
        weight += c;
    }
    sum / weight
}

/// A binary glTF from its JSON and BIN chunk.
pub fn glb(json: &serde_json::Value, bin: &[u8]) -> Vec<u8> {
    let mut j = serde_json::to_vec(json).unwrap();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(0x4E4F534Au32.to_le_bytes());
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(0x004E4942u32.to_le_bytes());
    out.extend(b);
    out
}

/// A glTF (binary) model for the tests: a floor (1 x 1 at y = 0, facing up) and a light above it (facing down), as a list, a strip
/// and a fan, plus a point primitive; materials and nodes from the caller.
pub fn gltf_model(
    materials: serde_json::Value,
    nodes: serde_json::Value,
    extra: serde_json::Value,
) -> Vec<u8> {
    let pos: [[f32; 3]; 8] = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.25, 1.0, 0.25],
        [0.75, 1.0, 0.25],
        [0.75, 1.0, 0.75],
        [0.25, 1.0, 0.75],
    ];
    let uv: [[f32; 2]; 8] = [
        [0.0, 0.0],
        [0.0, 1.0],
        [1.0, 1.0],
        [1.0, 0.0],
        [0.0; 2],
        [0.0; 2],
        [0.0; 2],
        [0.0; 2],
    ];
    let idx: [u16; 20] = [0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 4, 5, 7, 6, 4, 5, 6, 7];
    let mut bin: Vec<u8> = pos.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    bin.extend(uv.iter().flatten().flat_map(|x| x.to_le_bytes()));
    bin.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
    let mut json = serde_json::json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 96},
            {"buffer": 0, "byteOffset": 96, "byteLength": 64},
            {"buffer": 0, "byteOffset": 160, "byteLength": 40}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [0,0,0], "max": [1,1,1]},
            {"bufferView": 1, "componentType": 5126, "count": 8, "type": "VEC2"},
            {"bufferView": 2, "byteOffset": 0, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 2, "byteOffset": 12, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 2, "byteOffset": 24, "componentType": 5123, "count": 4, "type": "SCALAR"},
            {"bufferView": 2, "byteOffset": 32, "componentType": 5123, "count": 4, "type": "SCALAR"}
        ],
        "meshes": [
            {"name": "floor", "primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]},
            {"name": "light", "primitives": [{"attributes": {"POSITION": 0}, "indices": 3, "material": 1}]},
            {"name": "strip", "primitives": [
                {"attributes": {"POSITION": 0}, "indices": 4, "mode": 5, "material": 0},
                {"attributes": {"POSITION": 0}, "indices": 5, "mode": 6, "material": 0},
                {"attributes": {"POSITION": 0}, "mode": 0}
            ]}
        ],
        "materials": materials,
        "nodes": nodes,
        "scenes": [{"nodes": [0]}],
        "scene": 0
    });
    for (k, v) in extra.as_object().unwrap() {
        json[k] = v.clone();
    }
    glb(&json, &bin)
}

pub fn gltf_basic_materials() -> serde_json::Value {
    serde_json::json!([
        {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 1.0], "metallicFactor": 0.0}},
        {"name": "lamp", "emissiveFactor": [1.0, 0.5, 0.25], "doubleSided": true,
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}}}
    ])
}

/// Sutherland-Hodgman: the part of convex `subject` inside convex `clip` (both counter-clockwise
/// in the xz-plane seen from +y, or both clockwise).
pub fn clip_convex(subject: &[glam::DVec2], clip: &[glam::DVec2]) -> Vec<glam::DVec2> {
    let orientation = |p: &[glam::DVec2]| {
        (0..p.len())
            .map(|i| p[i].perp_dot(p[(i + 1) % p.len()]))
            .sum::<f64>()
            .signum()
    };
    let sign = orientation(clip);
    let mut out = subject.to_vec();
    for i in 0..clip.len() {
        let (a, b) = (clip[i], clip[(i + 1) % clip.len()]);
        let inside = |p: glam::DVec2| sign * (b - a).perp_dot(p - a) >= 0.0;
        let input = std::mem::take(&mut out);
        for j in 0..input.len() {
            let (p, q) = (input[j], input[(j + 1) % input.len()]);
            if inside(p) {
                out.push(p);
            }
            if inside(p) != inside(q) {
                let (dp, dq) = ((b - a).perp_dot(p - a), (b - a).perp_dot(q - a));
                out.push(p + (q - p) * (dp / (dp - dq)));
            }
        }
        if out.is_empty() {
            break;
        }
    }
    out
}

/// Irradiance at x (normal n) from a convex polygon of unit radiance wholly above x's horizon:
/// Lambert's formula, in f64 (the closed form the direct-light tests compare with).
pub fn polygon_irradiance(x: glam::DVec3, n: glam::DVec3, corners: &[glam::DVec3]) -> f64 {
    let mut sum = 0.0;
    for k in 0..corners.len() {
        let a = (corners[k] - x).normalize();
        let b = (corners[(k + 1) % corners.len()] - x).normalize();
        let c = a.cross(b);
        if c.length() > 0.0 {
            sum += c.length().atan2(a.dot(b)) * n.dot(c.normalize());
        }
    }
    sum.abs() * 0.5
}

/// The distinct corners of the (planar, convex) face made of material `material`, in normalised
/// space, in order around their centre; `normal` is the face's plane normal.
pub fn face_corners(
    prepared: &vlf::prepare::PreparedScene,
    material: u32,
    normal: glam::DVec3,
) -> Vec<glam::DVec3> {
    let face = (0..prepared.faces.len())
        .find(|&f| prepared.faces[f].material == material)
        .expect("a face of that material");
    let mut corners: Vec<glam::DVec3> = Vec::new();
    for t in prepared
        .triangles
        .iter()
        .filter(|t| t.face as usize == face)
    {
        for v in t.vertices {
            let q = prepared.positions[v as usize];
            if !corners.iter().any(|c| c.distance(q) < 1e-9) {
                corners.push(q);
            }
        }
    }
    let centre = corners.iter().sum::<glam::DVec3>() / corners.len() as f64;
    let a = (corners[0] - centre).normalize();
    let b = normal.cross(a);
    corners.sort_by(|p, q| {
        let angle = |v: &glam::DVec3| (*v - centre).dot(b).atan2((*v - centre).dot(a));
        angle(p).total_cmp(&angle(q))
    });
    corners
}

/// `[object_lighting]` keys for tests whose moving objects' lighting is not what they check
/// (logging, replay, poses, hands on grips): 6 light probes along the scene's longest side with
/// 256 rays each, and no occlusion rays. The default (24 with 1,024 rays, 14 million rays
/// through the light field) takes about 25 s to bake on a software adapter, in every process
/// that draws objects; the occlusion rays (16 per vertex, a quarter of a million rays a frame
/// for the avatar) cost every frame drawn.
pub const LIGHT_PROBE_KEYS: &str = "probe_resolution = 6\nprobe_rays = 256\nocclusion_rays = 0\n";

/// Small propagation settings for GPU tests on the software adapter (21 directions, a 32 x 32
/// grid, 8 texels per unit, tolerance 1e-2, direct light with 16 samples).
pub fn draft_params() -> vlf::propagate::PropagationParams {
    vlf::propagate::PropagationParams {
        geodesic_frequency: 3,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 8.0,
        tolerance: 1e-2,
        max_iterations: 20,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 16,
        mirror_direct: false,
        rim_rays: false,
    }
}

/// An OBJ cube of half-size `h` at `c` with one material, as `name`.obj + .mtl in `dir` (a
/// moving object's mesh).
pub fn cube_object(dir: &Path, name: &str, c: glam::DVec3, h: f64, kd: f32, ke: f32) {
    let mut obj = ObjBuilder::default();
    obj.cube("thing", c, h, false);
    std::fs::write(
        dir.join(format!("{name}.obj")),
        obj.text(&format!("{name}.mtl")),
    )
    .unwrap();
    let mtl = format!("newmtl thing\nKd {kd} {kd} {kd}\nKe {ke} {ke} {ke}\nKs 0 0 0\n");
    std::fs::write(dir.join(format!("{name}.mtl")), mtl).unwrap();
}

/// The furnace of side 1 around the origin (walls emitting Le = 1 with albedo 0.5) with a mirror
/// of reflectance 0.9 for its back wall (z = -0.5), written to `dir` and loaded.
pub fn mirror_furnace(dir: &Path) -> vlf::scene::Scene {
    use glam::DVec3;
    let mut obj = ObjBuilder::default();
    for (axis, sign) in [
        (DVec3::X, 1.0),
        (DVec3::X, -1.0),
        (DVec3::Y, 1.0),
        (DVec3::Y, -1.0),
        (DVec3::Z, 1.0),
    ] {
        let outward = axis * sign;
        obj.quad("wall", outward * 0.5, -outward, [1.0, 1.0], 0.0);
    }
    obj.quad(
        "mirror",
        DVec3::new(0.0, 0.0, -0.5),
        DVec3::Z,
        [1.0, 1.0],
        0.0,
    );
    let materials = [
        Mat {
            name: "wall",
            kd: [0.5; 3],
            ke: [1.0; 3],
        },
        Mat {
            name: "mirror",
            kd: [0.0; 3],
            ke: [0.0; 3],
        },
    ];
    load_scene(
        dir,
        &obj,
        &materials,
        "[materials.mirror]\nmirror = [0.9, 0.9, 0.9]\n",
    )
}

/// A UDP port free on this machine now (bound and let go: a tracker binds it after).
pub fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// What the tests that run Mitsuba or tools/mitsuba/reference.py say is missing when Python
/// cannot run them.
pub const HOW_TO_GET_MITSUBA: &str = "these tests need Python 3.11+ with Mitsuba 3, numpy and \
     pygltflib: `pip install mitsuba numpy pygltflib` (`bash tools/setup.sh test` installs them)";

/// Runs `python3 SCRIPT ARGS...` (a repository script), failing with its stderr and how to get
/// what it needs. Returns its stderr.
pub fn python(script: &str, args: &[&std::ffi::OsStr]) -> String {
    let run = std::process::Command::new("python3")
        .arg(repo_path(script))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run python3 ({e}); {HOW_TO_GET_MITSUBA}"));
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(
        run.status.success(),
        "{script} failed:\n{stderr}\n{HOW_TO_GET_MITSUBA}"
    );
    stderr
}

/// The shipped Python example `script` run against the `vlf cave --control` child listening on
/// `addr`, which its `stop` ends cleanly: the replies it printed, in order.
pub fn script_replies(
    script: &str,
    addr: &str,
    child: &mut std::process::Child,
) -> Vec<serde_json::Value> {
    let out = std::process::Command::new("python3")
        .arg(repo_path(script))
        .arg(addr)
        .output()
        .unwrap_or_else(|e| {
            panic!("python3 runs {script} ({e}); install Python 3 (tools/setup.sh test does)")
        });
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(child.wait().unwrap().success(), "stop ends the run cleanly");
    (String::from_utf8(out.stdout).unwrap().lines())
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["reply"].clone())
        .collect()
}

/// The address a `vlf cave --control` child says it listens on (its stderr, drained after).
pub fn control_address(child: &mut std::process::Child) -> String {
    use std::io::BufRead;
    let mut stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    while stderr.read_line(&mut line).unwrap() > 0 {
        if let Some(a) = line.strip_prefix("control: listening on ") {
            let addr = a.trim().to_string();
            std::thread::spawn(move || for _ in stderr.lines() {});
            return addr;
        }
        line.clear();
    }
    panic!("vlf cave never said where it listens");
}
