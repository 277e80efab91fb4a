//! Helpers shared by the integration tests: the GPU (never a silent skip), and scenes written
//! to temporary folders as real scene.toml + OBJ + MTL files, loaded through the real importer.
#![allow(dead_code)]

use glam::DVec3;
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

/// An OBJ built from quads, each with a material.
#[derive(Default)]
pub struct ObjBuilder {
    obj: String,
    vertices: usize,
}

impl ObjBuilder {
    /// A square of side `size` centred at `c`, facing `normal` (counter-clockwise seen from the
    /// front). `spin` rotates it in its plane.
    pub fn quad(&mut self, material: &str, c: DVec3, normal: DVec3, size: [f64; 2], spin: f64) -> &mut Self {
        let n = normal.normalize();
        let helper = if n.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
        let t1 = (helper - n * n.dot(helper)).normalize();
        let t2 = n.cross(t1);
        let (s, co) = spin.sin_cos();
        let (t1, t2) = (t1 * co + t2 * s, -t1 * s + t2 * co);
        let (a, b) = (t1 * size[0] * 0.5, t2 * size[1] * 0.5);
        self.obj.push_str(&format!("usemtl {material}\n"));
        for p in [c - a - b, c + a - b, c + a + b, c - a + b] {
            self.obj.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
        }
        self.vertices += 4;
        self.obj.push_str("f -4 -3 -2 -1\n");
        self
    }

    /// A closed axis-aligned box of half-size `h` at `c`; faces inward when `inward`.
    pub fn cube(&mut self, material: &str, c: DVec3, h: f64, inward: bool) -> &mut Self {
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            for sign in [1.0, -1.0] {
                let outward = axis * sign;
                let normal = if inward { -outward } else { outward };
                self.quad(material, c + outward * h, normal, [2.0 * h, 2.0 * h], 0.0);
            }
        }
        self
    }

    pub fn text(&self) -> String {
        format!("mtllib scene.mtl\n{}", self.obj)
    }
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
    std::fs::write(dir.join("scene.obj"), obj.text()).unwrap();
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
