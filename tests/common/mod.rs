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
