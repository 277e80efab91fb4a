//! Surface detail finer than a texel: the scene's diffuse textures at full resolution, read per
//! pixel when a view is drawn. The atlas holds one radiosity per texel, B = albedo x
//! texture(texel) x E, so a wallpaper or a parquet floor drawn from it alone is blurred to texel
//! size. With the detail the renderer shows, at a point x of a textured face,
//! (B / texture(texel)) x texture(x), per tap of the bilinear lookup: the texel's irradiance times
//! the material at the point, what a path tracer shows up to the irradiance's own resolution
//! (`shaders/common/light_field.wgsl`: `atlas_radiance_detailed`; textures sampled by
//! `shaders/common/textures.wgsl`, which the path tracer uses too).
//!
//! A light field keeps the detail only when some face has a diffuse texture (the rest pay
//! nothing): the textures, which face uses which, each render triangle's texture coordinates and
//! each atlas texel's texture factor, the value propagation multiplied its radiosity by. Emitting
//! faces keep their texel radiance (their atlas holds emission too).

use crate::gpu::types::NO_FACE;
use crate::gpu::{GpuContext, MemoryLedger, STORAGE};
use crate::material::Material;
use crate::prepare::PreparedScene;
use crate::scene::{Scene, Texture};

/// The textures as the GPU samples them (`shaders/common/textures.wgsl`): texel arrays back to
/// back, and per face which of them it uses.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceTextures {
    /// per texture: (first texel, width, height, 0)
    pub info: Vec<[u32; 4]>,
    /// every texture's texels (linear rgb, w = 1), row by row from the image's top
    pub texels: Vec<[f32; 4]>,
    /// per face: (diffuse texture, emission texture, coverage texture, cutoff bits), NO_FACE
    /// for no texture, 0 and 0 for no cut-out
    pub face_textures: Vec<[u32; 4]>,
    /// per face its specular texture (`Material::specular_texture`: rgb a multiple of the
    /// mirror colour, w the GGX alpha), NO_FACE for none; empty where no face has one
    pub face_specular: Vec<u32>,
}

impl SurfaceTextures {
    /// The scene's textures and the faces that use them. A face is textured where the light
    /// field's atlas textures it: only when every one of its triangles has texture coordinates
    /// (`prepare::atlas`), else it shows its material's colour.
    pub fn of(scene: &Scene, prepared: &PreparedScene) -> SurfaceTextures {
        Self::with_textures(&scene.textures, &scene.materials, prepared)
    }

    /// The same for the stages that only test surfaces (propagation's visibility, direct
    /// light, rim rays), from what a prepared scene keeps: None where no face cuts holes.
    pub fn cutouts(prepared: &PreparedScene) -> Option<SurfaceTextures> {
        let t = Self::with_textures(&prepared.cutout_textures, &prepared.materials, prepared);
        t.any_cutout().then_some(t)
    }

    fn with_textures(
        textures: &[Texture],
        materials: &[Material],
        prepared: &PreparedScene,
    ) -> SurfaceTextures {
        let mut info: Vec<[u32; 4]> = Vec::new();
        let mut texels: Vec<[f32; 4]> = Vec::new();
        for t in textures {
            info.push([texels.len() as u32, t.width, t.height, 0]);
            let alpha = |i: usize| t.alpha.get(i).copied().unwrap_or(1.0);
            texels.extend((t.texels.iter().enumerate()).map(|(i, c)| [c[0], c[1], c[2], alpha(i)]));
        }
        let mut has_uv = vec![true; prepared.faces.len()];
        for t in &prepared.triangles {
            has_uv[t.face as usize] &= t.uv.is_some();
        }
        let face_textures = (prepared.faces.iter().zip(&has_uv))
            .map(|(f, &uv)| {
                let m = &materials[f.material as usize];
                let texture = |which: Option<u32>| which.filter(|_| uv).unwrap_or(NO_FACE);
                // a cut-out: its coverage texture and cutoff (0, 0: none, never a hole)
                let cut = m
                    .cutout
                    .filter(|c| uv && (c.texture as usize) < textures.len());
                [
                    texture(m.diffuse_texture),
                    texture(m.emission_texture),
                    cut.map_or(0, |c| c.texture),
                    cut.map_or(0, |c| c.cutoff.to_bits()),
                ]
            })
            .collect();
        let face_specular: Vec<u32> = (prepared.faces.iter().zip(&has_uv))
            .map(|(f, &uv)| {
                let m = &materials[f.material as usize];
                (m.specular_texture)
                    .filter(|&t| uv && (t as usize) < textures.len())
                    .unwrap_or(NO_FACE)
            })
            .collect();
        SurfaceTextures {
            info,
            texels,
            face_textures,
            face_specular: match face_specular.iter().any(|&t| t != NO_FACE) {
                true => face_specular,
                false => Vec::new(),
            },
        }
    }

    /// Whether some face has a diffuse texture.
    pub fn any_diffuse(&self) -> bool {
        self.face_textures.iter().any(|t| t[0] != NO_FACE)
    }

    /// Whether some face has a specular texture.
    pub fn any_specular(&self) -> bool {
        !self.face_specular.is_empty()
    }

    /// Per face its specular texture as the stages bind it: `face_specular`, or one NO_FACE where
    /// no face has one (a binding is never empty).
    pub fn specular_records(&self) -> Vec<u32> {
        match self.any_specular() {
            true => self.face_specular.clone(),
            false => vec![NO_FACE],
        }
    }

    /// The cut-outs as propagation binds them, one array (`shaders/common/packed_cutouts.wgsl`):
    /// the face and texture counts, per face its coverage texture and cutoff bits, per texture
    /// its first texel, width and height, then every texel's coverage as f32 bits.
    pub fn packed_cutouts(&self) -> Vec<u32> {
        let mut words = vec![self.face_textures.len() as u32, self.info.len() as u32];
        words.extend(self.face_textures.iter().flat_map(|t| [t[2], t[3]]));
        words.extend(self.info.iter().flat_map(|i| [i[0], i[1], i[2]]));
        words.extend(self.texels.iter().map(|t| t[3].to_bits()));
        words
    }

    /// Whether some face cuts holes (a cutoff above 0: `shaders/common/coverage.wgsl`).
    pub fn any_cutout(&self) -> bool {
        self.face_textures
            .iter()
            .any(|t| f32::from_bits(t[3]) > 0.0)
    }
}

/// Per face its normal texture and the scale's bits ([NO_FACE, 0] for none; a face without
/// texture coordinates has none); empty where no face has a normal map.
pub fn normal_maps(scene: &Scene, prepared: &PreparedScene) -> Vec<[u32; 2]> {
    let mut has_uv = vec![true; prepared.faces.len()];
    for t in &prepared.triangles {
        has_uv[t.face as usize] &= t.uv.is_some();
    }
    let records: Vec<[u32; 2]> = (prepared.faces.iter().zip(&has_uv))
        .map(|(f, &uv)| {
            let m = &scene.materials[f.material as usize];
            match m
                .normal_map
                .filter(|n| uv && (n.texture as usize) < scene.textures.len())
            {
                Some(n) => [n.texture, n.scale.to_bits()],
                None => [NO_FACE, 0],
            }
        })
        .collect();
    match records.iter().any(|r| r[0] != NO_FACE) {
        true => records,
        false => Vec::new(),
    }
}

/// What a light field keeps to draw textures per pixel (see the module's header).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceDetail {
    pub textures: SurfaceTextures,
    /// per render triangle (`LightField::render_vertices`, three at a time): its corners'
    /// texture coordinates (zero where it has none)
    pub triangle_uv: Vec<[f32; 6]>,
    /// per atlas texel: the texture factor propagation multiplied its radiosity by (rgb as half
    /// floats: r | g << 16, b), 1 on untextured faces
    pub texel_albedo: Vec<[u32; 2]>,
    /// normal maps (empty where no face has one): per face its normal texture (NO_FACE for
    /// none) and the scale's f32 bits (`material::NormalMap`)
    pub face_normal_maps: Vec<[u32; 2]>,
    /// with normal maps: per atlas texel two records, the direction of its emitters' light v
    /// (their irradiance vector, `direct_vector` in shaders/direct.wgsl) and the tangential
    /// moment m of the rest of its light (`rest_vector`), each divided by the texel's whole
    /// irradiance (luminance), as half floats (`lightfield::normal_map`)
    pub texel_directions: Vec<[u32; 2]>,
}

/// Three floats as half floats, two to a word (`half_float` in common/light_field.wgsl reads
/// them back).
pub fn pack_half_rgb(c: [f32; 4]) -> [u32; 2] {
    let h = |x: f32| half::f16::from_f32(x).to_bits() as u32;
    [h(c[0]) | (h(c[1]) << 16), h(c[2])]
}

impl SurfaceDetail {
    /// The detail of a prepared scene, or None where no face has a diffuse texture or cuts
    /// holes (the renderer's eye and mirror rays read the coverage here).
    pub fn of(scene: &Scene, prepared: &PreparedScene) -> Option<SurfaceDetail> {
        // no texture factors, cut-outs or normal maps: no face has a texture (nothing to copy)
        let albedo = prepared.atlas.texture_albedo.as_ref();
        let mapped = (scene.materials.iter())
            .any(|m| m.normal_map.is_some() || m.specular_texture.is_some());
        if albedo.is_none() && prepared.cutout_textures.is_empty() && !mapped {
            return None;
        }
        let textures = SurfaceTextures::of(scene, prepared);
        let face_normal_maps = normal_maps(scene, prepared);
        if !textures.any_diffuse()
            && !textures.any_cutout()
            && !textures.any_specular()
            && face_normal_maps.is_empty()
        {
            return None;
        }
        let texel_albedo = match albedo {
            Some(albedo) => albedo.iter().map(|&a| pack_half_rgb(a)).collect(),
            None => vec![pack_half_rgb([1.0; 4]); prepared.atlas.points.len()],
        };
        let triangle_uv = (prepared.triangles.iter())
            .filter(|t| !prepared.faces[t.face as usize].is_back)
            .map(|t| {
                let uv = t.uv.unwrap_or([[0.0; 2]; 3]);
                [uv[0][0], uv[0][1], uv[1][0], uv[1][1], uv[2][0], uv[2][1]]
            })
            .collect();
        Some(SurfaceDetail {
            textures,
            triangle_uv,
            texel_albedo,
            face_normal_maps,
            texel_directions: Vec::new(),
        })
    }

    /// What the renderer binds as `texel_albedo` (common/light_field.wgsl): the texel factors,
    /// then with normal maps the faces' normal-map records and the texels' light directions,
    /// then with specular textures the faces' specular texture ([texture, 0] per face); and where
    /// those three start in it (0: none), for `GpuField`.
    pub fn detail_words(&self) -> (Vec<[u32; 2]>, [u32; 3]) {
        let mut words = self.texel_albedo.clone();
        let mut starts = [0u32; 3];
        if !self.face_normal_maps.is_empty() {
            starts[0] = words.len() as u32;
            words.extend(&self.face_normal_maps);
            starts[1] = words.len() as u32;
            words.extend(&self.texel_directions);
        }
        if self.textures.any_specular() {
            starts[2] = words.len() as u32;
            words.extend(self.textures.face_specular.iter().map(|&t| [t, 0]));
        }
        (words, starts)
    }

    /// Texture coordinates of render triangle `i`'s corners.
    pub fn corners_uv(&self, i: usize) -> [[f32; 2]; 3] {
        let t = self.triangle_uv.get(i).copied().unwrap_or([0.0; 6]);
        [[t[0], t[1]], [t[2], t[3]], [t[4], t[5]]]
    }

    /// Upload what the renderer binds (the render triangles carry their texture coordinates
    /// themselves, `render::Renderer`). None, with the reason, where one array would exceed a
    /// storage binding of this device: the view is then drawn at texel resolution.
    pub fn upload(
        &self,
        ctx: &GpuContext,
        ledger: &MemoryLedger,
    ) -> std::result::Result<ResidentDetail, String> {
        let limits = ctx.limits();
        let max = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let (words, _) = self.detail_words();
        let arrays: [(&str, &[u8]); 4] = [
            ("texture detail: texel albedo", bytemuck::cast_slice(&words)),
            (
                "texture detail: face textures",
                bytemuck::cast_slice(&self.textures.face_textures),
            ),
            (
                "texture detail: texture info",
                bytemuck::cast_slice(&self.textures.info),
            ),
            (
                "texture detail: texels",
                bytemuck::cast_slice(&self.textures.texels),
            ),
        ];
        if let Some((name, bytes)) = arrays.iter().find(|(_, b)| b.len() as u64 > max) {
            return Err(format!(
                "{name} takes {} MiB, more than one storage binding of this device holds ({} MiB)",
                bytes.len() >> 20,
                max >> 20
            ));
        }
        let [albedo, faces, info, texels] =
            arrays.map(|(name, bytes)| ctx.buffer_init(ledger, name, bytes, STORAGE));
        Ok(ResidentDetail {
            texel_albedo: albedo,
            face_textures: faces,
            texture_info: info,
            texels,
        })
    }

    /// Check the detail against the light field it belongs to: one texture coordinate record
    /// per render triangle, one factor per atlas texel, one texture record per face, texel
    /// ranges inside the texel array.
    pub fn check(
        &self,
        triangles: usize,
        texels: usize,
        faces: usize,
    ) -> std::result::Result<(), String> {
        let bad = |message: String| Err(message);
        if self.triangle_uv.len() != triangles {
            return bad(format!(
                "texture detail: {} triangle records for {triangles} render triangles",
                self.triangle_uv.len()
            ));
        }
        if self.texel_albedo.len() != texels {
            return bad(format!(
                "texture detail: {} texel factors for {texels} atlas texels",
                self.texel_albedo.len()
            ));
        }
        if self.textures.face_textures.len() != faces {
            return bad(format!(
                "texture detail: {} face records for {faces} faces",
                self.textures.face_textures.len()
            ));
        }
        let n = self.textures.texels.len() as u64;
        for (k, i) in self.textures.info.iter().enumerate() {
            if i[0] as u64 + i[1] as u64 * i[2] as u64 > n || i[1] == 0 || i[2] == 0 {
                return bad(format!(
                    "texture detail: texture {k} lies outside its texels"
                ));
            }
        }
        if !self.face_normal_maps.is_empty()
            && (self.face_normal_maps.len() != faces || self.texel_directions.len() != 2 * texels)
        {
            return bad(format!(
                "normal maps: {} face records and {} texel directions for {faces} faces and {texels} texels",
                self.face_normal_maps.len(),
                self.texel_directions.len()
            ));
        }
        let specular = &self.textures.face_specular;
        if !specular.is_empty() && specular.len() != faces {
            return bad(format!(
                "specular textures: {} face records for {faces} faces",
                specular.len()
            ));
        }
        let textures = self.textures.info.len() as u32;
        if (self.textures.face_textures.iter().flat_map(|t| &t[..2]))
            .chain(self.face_normal_maps.iter().map(|n| &n[0]))
            .chain(specular)
            .any(|&t| t != NO_FACE && t >= textures)
        {
            return bad("texture detail: a face names a texture that is not there".into());
        }
        Ok(())
    }
}

/// The detail on the GPU, in the order `shaders/common/light_field.wgsl` binds it.
pub struct ResidentDetail {
    pub texel_albedo: wgpu::Buffer,
    pub face_textures: wgpu::Buffer,
    pub texture_info: wgpu::Buffer,
    pub texels: wgpu::Buffer,
}
