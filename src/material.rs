//! The material model: one `Material` for every surface, whichever importer made it (MTL, glTF,
//! scene.toml overrides, the generator), and what a surface does with light (the BSDF), in one
//! place, as pbrt-v4's `bxdf.h` keeps it. A material has a diffuse (Lambertian) part, an ideal
//! mirror part and emission; a glossy lobe (roughness) is a new field here, a new flag in
//! `GpuMaterial` and a new helper in `shaders/common/bsdf.wgsl`. A cut-out ([`Cutout`]) is a
//! property of the surface's texture coordinates rather than of the BSDF: it travels with the
//! surface textures (`lightfield::textures::SurfaceTextures`) and one WGSL function decides it
//! (`shaders/common/coverage.wgsl`).
//!
//! On the GPU the materials are a table (`GpuMaterial`, one per scene material) apart from the
//! face records, which hold an index into it (`GpuFace::material`). `shaders/common/bsdf.wgsl`
//! reads the table and holds the BSDF helpers every stage uses (propagation, direct light, the
//! renderer, the path tracer); the functions below are their CPU twins, written like the WGSL.

use crate::gpu::types::{GpuFace, GpuMaterial, FACE_EMITTER};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// `GpuMaterial::flags`: the material has an ideal mirror part (a delta lobe: mirror chains,
/// tiles and virtual emitters follow it).
pub const MATERIAL_DELTA: u32 = 1;
/// `GpuMaterial::flags`: the material has a diffuse part.
pub const MATERIAL_DIFFUSE: u32 = 2;

/// A material after MTL and overrides are combined.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub name: String,
    pub diffuse: [f32; 3],
    pub mirror: [f32; 3],
    pub emission: [f32; 3],
    pub two_sided: bool,
    /// `map_Kd`, multiplying `diffuse` (index into Scene::textures)
    #[serde(default)]
    pub diffuse_texture: Option<u32>,
    /// `map_Ke`, multiplying `emission`
    #[serde(default)]
    pub emission_texture: Option<u32>,
    /// a cut-out (glTF alphaMode MASK or BLEND, MTL `map_d`): holes where the coverage is
    /// below the cutoff
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cutout: Option<Cutout>,
}

/// A cut-out: the surface is a hole wherever its coverage texture's alpha
/// (`scene::Texture::alpha`, point-sampled bilinearly at the texture coordinates) is below
/// `cutoff`. Every test of the surface takes it: propagation's cell lines, direct light's shadow
/// rays, eye and mirror rays, the path tracer (`shaders/common/coverage.wgsl`, `is_hole`). A
/// coverage factor (glTF's base colour alpha) is folded into `cutoff` (alpha x factor < c is
/// alpha < c / factor); a material covered or open everywhere has no cut-out (the importers keep
/// it opaque or leave its triangles out).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cutout {
    /// index into Scene::textures (a texture with an alpha channel)
    pub texture: u32,
    pub cutoff: f32,
}

impl Material {
    /// What faces without a material get: grey diffuse (0.5), from every importer.
    pub fn default_grey() -> Material {
        Material {
            name: "(default)".into(),
            diffuse: [0.5; 3],
            mirror: [0.0; 3],
            emission: [0.0; 3],
            two_sided: false,
            diffuse_texture: None,
            emission_texture: None,
            cutout: None,
        }
    }

    /// Why the material would create energy (diffuse + mirror above 1 in a channel), if it would:
    /// every importer refuses such a material with this message.
    pub fn energy_error(&self) -> Option<String> {
        (0..3)
            .find(|&c| self.diffuse[c] + self.mirror[c] > 1.0 + 1e-6)
            .map(|c| {
                format!(
                    "diffuse {:?} + mirror {:?} exceeds 1 in channel {c}: the surface would create energy",
                    self.diffuse, self.mirror
                )
            })
    }

    /// Whether the surface has an ideal mirror part (its light leaves along one direction).
    pub fn is_delta(&self) -> bool {
        self.mirror.iter().any(|&m| m > 0.0)
    }

    /// Whether the surface emits.
    pub fn emits(&self) -> bool {
        self.emission.iter().any(|&e| e > 0.0)
    }

    /// The material's row of the GPU table.
    pub fn gpu(&self) -> GpuMaterial {
        GpuMaterial::new(self.diffuse, self.mirror, self.emission)
    }
}

impl GpuMaterial {
    /// A row of the table: its flags follow from the parts.
    pub fn new(diffuse: [f32; 3], mirror: [f32; 3], emission: [f32; 3]) -> GpuMaterial {
        let delta = mirror.iter().any(|&m| m > 0.0);
        let diffuse_part = diffuse.iter().any(|&d| d > 0.0);
        GpuMaterial {
            diffuse,
            flags: if delta { MATERIAL_DELTA } else { 0 }
                | if diffuse_part { MATERIAL_DIFFUSE } else { 0 },
            mirror,
            _pad0: 0.0,
            emission,
            _pad1: 0.0,
        }
    }

    /// bsdf.wgsl's `is_delta`: an ideal mirror part.
    pub fn is_delta(&self) -> bool {
        self.flags & MATERIAL_DELTA != 0
    }

    /// bsdf.wgsl's `diffuse_reflectance`: the Lambertian part's albedo.
    pub fn diffuse_reflectance(&self) -> Vec3 {
        Vec3::from(self.diffuse)
    }

    /// bsdf.wgsl's `mirror_reflectance`: the ideal mirror part's reflectance.
    pub fn mirror_reflectance(&self) -> Vec3 {
        Vec3::from(self.mirror)
    }
}

/// The GPU table of `materials`, in their order (a face's `material` indexes it).
pub fn material_table(materials: &[Material]) -> Vec<GpuMaterial> {
    let mut table: Vec<GpuMaterial> = materials.iter().map(Material::gpu).collect();
    if table.is_empty() {
        // a binding may not be empty; no face refers to this row
        table.push(Material::default_grey().gpu());
    }
    table
}

/// bsdf.wgsl's `material_of`: face `f`'s material.
pub fn material_of<'a>(materials: &'a [GpuMaterial], f: &GpuFace) -> &'a GpuMaterial {
    &materials[f.material as usize]
}

/// bsdf.wgsl's `emitted`: the radiance face `f` emits (its material's, on an emitting side).
pub fn emitted(materials: &[GpuMaterial], f: &GpuFace) -> Vec3 {
    match f.flags & FACE_EMITTER != 0 {
        true => Vec3::from(material_of(materials, f).emission),
        false => Vec3::ZERO,
    }
}

/// bsdf.wgsl's `mirror_direction`: `ray` reflected about the plane of normal `n` (the ideal
/// mirror's one reflection tap).
pub fn mirror_direction(ray: Vec3, n: Vec3) -> Vec3 {
    ray - 2.0 * ray.dot(n) * n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_follow_the_parts() {
        let m = GpuMaterial::new([0.5; 3], [0.0; 3], [0.0; 3]);
        assert!(!m.is_delta() && m.flags & MATERIAL_DIFFUSE != 0);
        let mirror = GpuMaterial::new([0.0; 3], [0.8, 0.0, 0.0], [0.0; 3]);
        assert!(mirror.is_delta() && mirror.flags & MATERIAL_DIFFUSE == 0);
    }

    #[test]
    fn a_mirror_direction_keeps_the_tangent_part_and_flips_the_normal_part() {
        let n = Vec3::Y;
        let r = mirror_direction(Vec3::new(0.6, -0.8, 0.0), n);
        assert!((r - Vec3::new(0.6, 0.8, 0.0)).length() < 1e-6);
    }
}
