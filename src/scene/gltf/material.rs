//! glTF materials to the light field's: what a metallic-roughness material becomes, by the rules
//! docs/guide/gltf.md states. The light field holds a diffuse reflectance (with a texture), a
//! specular reflectance (an ideal mirror or a glossy GGX lobe, with a texture of its colour and
//! alpha) and an emitted radiance (with a texture):
//! - metallic >= 0.5 and roughness <= 0.2: an ideal mirror of the base colour (factor times
//!   texture), no diffuse;
//! - metallic >= 0.5 and 0.2 < roughness <= 0.6: a glossy metal of the base colour (the same),
//!   GGX alpha = roughness² (glTF's convention);
//! - everything else (rougher metals, dielectrics): diffuse of the base colour (factor x
//!   texture);
//! - emission: emissiveFactor x emissiveTexture x KHR_materials_emissive_strength;
//! - doubleSided: two-sided;
//! - alphaMode MASK: a cut-out (`Material::cutout`): a hole where base colour alpha (factor x
//!   texture alpha) is below alphaCutoff (0.5 by default); without a texture the surface is
//!   covered (kept opaque) or open (its faces left out) everywhere; BLEND with a base colour
//!   texture: MASK at 0.5, warned; BLEND without one (glass): opaque, warned;
//!
//! - normalTexture (with its scale): a normal map (`Material::normal_map`), read with the base
//!   colour's texture coordinates;
//!
//! - metallicRoughnessTexture (roughness from green, metallic from blue, times the factors): the
//!   rules above per texel (`metal_rough::split`): a diffuse texture and a specular texture of
//!   the base colour, each where its texels are; a metal with a base colour texture is split the
//!   same way (every texel a metal). The texture is read with the base colour's coordinates;
//!
//! and what cannot be represented (transmission, occlusion maps, clamped wrapping) is named in
//! one warning per material.

use super::super::{check_color, Material, MaterialOverride};
use crate::error::{Result, VlfError};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

pub use crate::material::{GLOSSY_ROUGHNESS, MIRROR_METALLIC, MIRROR_ROUGHNESS};

/// `KHR_texture_transform` as a 2x3 matrix on texture coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform(pub [[f32; 3]; 2]);

impl UvTransform {
    pub const IDENTITY: UvTransform = UvTransform([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);

    fn of(info: &::gltf::texture::Info) -> UvTransform {
        let Some(t) = info.texture_transform() else {
            return UvTransform::IDENTITY;
        };
        // T * R * S, as the extension defines it
        let ([ox, oy], r, [sx, sy]) = (t.offset(), t.rotation(), t.scale());
        let (s, c) = r.sin_cos();
        UvTransform([[c * sx, s * sy, ox], [-s * sx, c * sy, oy]])
    }

    pub fn apply(&self, [u, v]: [f32; 2]) -> [f32; 2] {
        if *self == UvTransform::IDENTITY {
            return [u, v];
        }
        let m = &self.0;
        [
            m[0][0] * u + m[0][1] * v + m[0][2],
            m[1][0] * u + m[1][1] * v + m[1][2],
        ]
    }
}

/// A material as planned before its images are read.
pub struct Plan {
    pub name: String,
    material: Material,
    diffuse_image: Option<usize>,
    emission_image: Option<usize>,
    /// a material split per texel into its diffuse and specular parts (`metal_rough`)
    split: Option<SplitPlan>,
    /// the base colour texture of a cut-out (its alpha), with the cutoff its factor is folded in
    alpha_image: Option<usize>,
    alpha_cutoff: f32,
    /// the normal texture (read raw, at full resolution) and its scale
    normal_image: Option<(usize, f32)>,
    /// a cut-out open everywhere: its faces are left out
    pub open: bool,
    uv_set: Option<u32>,
    pub uv_transform: UvTransform,
    notes: Vec<String>,
}

impl Plan {
    /// The texture-coordinate set the triangles carry (the base colour's, else the emissive's).
    pub fn uv_set(&self) -> Option<u32> {
        self.uv_set
    }

    /// The images this material lays on its surfaces.
    pub fn images(&self) -> Vec<usize> {
        [self.diffuse_image, self.emission_image, self.alpha_image]
            .into_iter()
            .flatten()
            .collect()
    }

    /// The normal texture's image and its scale, if any.
    pub fn normal_image(&self) -> Option<(usize, f32)> {
        self.normal_image
    }

    /// The base colour image whose alpha cuts holes, if any.
    pub fn alpha_image(&self) -> Option<usize> {
        self.alpha_image
    }

    /// How the material is split per texel, if it is.
    pub fn split(&self) -> Option<&SplitPlan> {
        self.split.as_ref()
    }
}

/// A material whose metal varies over its surface, or a textured metal: split per texel once
/// its images are read (`metal_rough::split`; its base colour image is its `diffuse_image`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitPlan {
    /// the metallic-roughness texture's image (None: a metal everywhere)
    pub image: Option<usize>,
    pub metallic: f32,
    pub roughness: f32,
    pub base_factor: [f32; 3],
}

fn image_of(info: &::gltf::texture::Info) -> usize {
    info.texture().source().index()
}

/// Every material of the document, in its order, with the scene.toml overrides applied.
pub fn plan_all(
    doc: &::gltf::Document,
    overrides: &BTreeMap<String, MaterialOverride>,
    path: &Path,
) -> Result<Vec<Plan>> {
    let mut names = HashMap::new();
    let mut plans = Vec::new();
    for m in doc.materials() {
        let index = m.index().unwrap_or(plans.len());
        let base = m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material{index}"));
        let count = names.entry(base.clone()).or_insert(0);
        *count += 1;
        let name = if *count > 1 {
            format!("{base}#{index}")
        } else {
            base
        };
        plans.push(plan(&m, name, overrides, path)?);
    }
    Ok(plans)
}

/// The metallic-roughness texture of a material, the texture coordinates it shares with the
/// base colour texture noted where they differ.
fn metal_rough_texture<'a>(
    pbr: &::gltf::material::PbrMetallicRoughness<'a>,
    base: Option<&::gltf::texture::Info>,
    notes: &mut Vec<String>,
) -> Option<::gltf::texture::Info<'a>> {
    let info = pbr.metallic_roughness_texture()?;
    let differs = base.is_some_and(|b| {
        b.tex_coord() != info.tex_coord() || UvTransform::of(b) != UvTransform::of(&info)
    });
    if differs {
        notes.push(
            "metallic-roughness texture read with the base colour texture's coordinates".into(),
        );
    }
    Some(info)
}

fn plan(
    m: &::gltf::Material,
    name: String,
    overrides: &BTreeMap<String, MaterialOverride>,
    path: &Path,
) -> Result<Plan> {
    let err = |message: String| VlfError::Material {
        path: path.to_path_buf(),
        material: name.clone(),
        message,
    };
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, alpha_factor] = pbr.base_color_factor();
    let base = [r, g, b];
    check_color(&base, true).map_err(|e| err(format!("baseColorFactor {e}")))?;
    let mut notes = Vec::new();
    let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emission = m.emissive_factor().map(|e| e * strength);
    check_color(&emission, false)
        .map_err(|e| err(format!("emissiveFactor x emissive_strength {e}")))?;
    let mirror = metallic >= MIRROR_METALLIC && roughness <= GLOSSY_ROUGHNESS;
    // a metal's lobe; a dielectric's specular part (a scene.toml `mirror` override) stays an
    // ideal mirror unless the override gives a roughness
    let alpha = match mirror && roughness > MIRROR_ROUGHNESS {
        true => roughness * roughness,
        false => 0.0,
    };
    let base_tex = pbr.base_color_texture();
    let emit_tex = m.emissive_texture();
    let o = overrides.get(&name).cloned().unwrap_or_default();
    // what scene.toml gives for the specular part or the diffuse colour replaces the glTF's
    // kind, so the glTF's is not reported as an approximation
    let kept = o.mirror.is_none() && o.roughness.is_none() && o.diffuse.is_none();
    let mr_info = match kept {
        true => metal_rough_texture(&pbr, base_tex.as_ref(), &mut notes),
        false => None,
    };
    let mr_image = mr_info.as_ref().map(image_of);
    // a metal that varies over its surface, or a textured one: split per texel
    let split =
        (mr_image.is_some() || (mirror && base_tex.is_some() && kept)).then_some(SplitPlan {
            image: mr_image,
            metallic,
            roughness,
            base_factor: base,
        });
    if kept && split.is_none() {
        describe_kind((metallic, roughness), (mirror, alpha), &mut notes);
    }
    // a split material's base colour texture is read as a diffuse one, then split
    let mirror = mirror && split.is_none();
    describe_losses(m, &mut notes);
    let cut = cutout(m, alpha_factor, base_tex.as_ref(), &mut notes);
    // the triangles carry one set of texture coordinates: the base colour's decides
    let diffuse_info = base_tex.as_ref().filter(|_| !mirror);
    let alpha_info = base_tex.as_ref().filter(|_| cut.image.is_some());
    let coords = (diffuse_info.or(alpha_info).or(emit_tex.as_ref())).or(mr_info.as_ref());
    let uv_set = coords.map(|i| {
        i.texture_transform()
            .and_then(|t| t.tex_coord())
            .unwrap_or(i.tex_coord())
    });
    let uv_transform = coords.map_or(UvTransform::IDENTITY, UvTransform::of);
    // the normal texture is read with the same coordinates
    let normal = m.normal_texture();
    if let Some(n) = &normal {
        if coords.is_some_and(|c| c.tex_coord() != n.tex_coord()) {
            notes.push("normal texture read with the base colour texture's coordinates".into());
        }
    }
    let uv_set = uv_set.or(normal.as_ref().map(|n| n.tex_coord()));
    if let (Some(d), Some(e)) = (diffuse_info, emit_tex.as_ref()) {
        if UvTransform::of(d) != UvTransform::of(e) || d.tex_coord() != e.tex_coord() {
            notes.push("emissive texture read with the base colour texture's coordinates".into());
        }
    }
    for info in [base_tex.as_ref(), emit_tex.as_ref()].into_iter().flatten() {
        use ::gltf::texture::WrappingMode::Repeat;
        let s = info.texture().sampler();
        if s.wrap_s() != Repeat || s.wrap_t() != Repeat {
            notes.push("clamped or mirrored texture wrapping treated as repeat".into());
            break;
        }
    }
    let material = Material {
        name: name.clone(),
        diffuse: o.diffuse.unwrap_or(if mirror { [0.0; 3] } else { base }),
        mirror: o.mirror.unwrap_or(if mirror { base } else { [0.0; 3] }),
        roughness: o.roughness.unwrap_or(alpha),
        emission: o.emission.unwrap_or(emission),
        two_sided: o.two_sided.unwrap_or(m.double_sided()),
        diffuse_texture: None,
        emission_texture: None,
        cutout: None,
        normal_map: None,
        specular_texture: None,
    };
    if let Some(message) = material
        .energy_error()
        .or_else(|| material.roughness_error())
    {
        return Err(err(message));
    }
    Ok(Plan {
        name,
        diffuse_image: diffuse_info.map(image_of),
        emission_image: emit_tex.as_ref().map(image_of),
        split,
        alpha_image: cut.image,
        alpha_cutoff: cut.cutoff,
        normal_image: normal.map(|n| (n.texture().source().index(), n.scale())),
        open: cut.open,
        material,
        uv_set,
        uv_transform,
        notes,
    })
}

/// The cut-out of a material: the image whose alpha decides, the cutoff with the factor folded
/// in, or open everywhere.
struct Cut {
    image: Option<usize>,
    cutoff: f32,
    open: bool,
}

/// The cutoff BLEND is taken as a MASK with.
pub const BLEND_CUTOFF: f32 = 0.5;

/// alphaMode MASK (alphaCutoff, 0.5 by default) over the base colour's alpha, factor x texture.
/// BLEND with a base colour texture (foliage, fences exported as BLEND) is taken as MASK at
/// [`BLEND_CUTOFF`]; BLEND without one (glass: one alpha everywhere, neither a hole nor a
/// cover) stays opaque. Both are noted.
fn cutout(
    m: &::gltf::Material,
    factor: f32,
    texture: Option<&::gltf::texture::Info>,
    notes: &mut Vec<String>,
) -> Cut {
    use ::gltf::material::AlphaMode;
    let none = Cut {
        image: None,
        cutoff: 0.0,
        open: false,
    };
    let cutoff = match (m.alpha_mode(), texture) {
        (AlphaMode::Opaque, _) => return none,
        (AlphaMode::Mask, _) => m.alpha_cutoff().unwrap_or(0.5),
        (AlphaMode::Blend, None) => {
            notes.push("alpha BLEND treated as opaque".into());
            return none;
        }
        (AlphaMode::Blend, Some(_)) => {
            notes.push(format!(
                "alpha BLEND taken as a cut-out (MASK) at {BLEND_CUTOFF}"
            ));
            BLEND_CUTOFF
        }
    };
    if factor <= 0.0 || (texture.is_none() && factor < cutoff) {
        notes.push(format!(
            "base colour alpha {factor} below the cutoff {cutoff} everywhere: its faces are left out"
        ));
        return Cut { open: true, ..none };
    }
    match texture {
        None => none,
        Some(info) => Cut {
            image: Some(image_of(info)),
            cutoff: cutoff / factor,
            open: false,
        },
    }
}

/// What a metallic-roughness material of `metallic` and `roughness` became, where it is not a
/// plain dielectric: an ideal `mirror` or glossy metal (GGX `alpha`) of the base colour, or a
/// rough metal taken as diffuse.
fn describe_kind(
    (metallic, roughness): (f32, f32),
    (mirror, alpha): (bool, f32),
    notes: &mut Vec<String>,
) {
    let what = match (mirror, alpha > 0.0) {
        (true, true) => format!("a glossy metal of the base colour (GGX alpha {alpha})"),
        (true, false) => "an ideal mirror of the base colour".to_string(),
        (false, _) if metallic > 0.0 => "a rough metal, taken as diffuse of the base colour".into(),
        (false, _) => return,
    };
    notes.push(format!("metallic {metallic} roughness {roughness}: {what}"));
}

/// What the material has that the light field drops.
fn describe_losses(m: &::gltf::Material, notes: &mut Vec<String>) {
    if let Some(t) = m.transmission() {
        if t.transmission_factor() > 0.0 {
            notes.push(format!(
                "transmission {} treated as opaque",
                t.transmission_factor()
            ));
        }
    }
    if m.occlusion_texture().is_some() {
        notes.push("occlusion map ignored (the light field computes occlusion)".into());
    }
}

/// The materials, with their textures attached once the images are read, and one warning per
/// material that was approximated.
pub fn finish(
    plans: &[Plan],
    texture_of_image: &HashMap<usize, u32>,
    normal_of_image: &HashMap<usize, u32>,
    warnings: &mut Vec<String>,
) -> Vec<Material> {
    plans
        .iter()
        .map(|p| {
            let mut m = p.material.clone();
            let tex = |i: Option<usize>| i.and_then(|i| texture_of_image.get(&i).copied());
            m.diffuse_texture = tex(p.diffuse_image);
            m.emission_texture = tex(p.emission_image);
            m.normal_map = (p.normal_image)
                .and_then(|(i, scale)| Some((normal_of_image.get(&i).copied()?, scale)))
                .map(|(texture, scale)| crate::material::NormalMap { texture, scale });
            m.cutout = tex(p.alpha_image).map(|texture| crate::material::Cutout {
                texture,
                cutoff: p.alpha_cutoff,
            });
            if !p.notes.is_empty() {
                warnings.push(format!(
                    "glTF material {:?}: approximated: {}",
                    p.name,
                    p.notes.join("; ")
                ));
            }
            m
        })
        .collect()
}
