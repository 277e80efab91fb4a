//! Drives `shaders/direct.wgsl`: the first bounce onto every diffuse texel, from the emitters
//! (closed-form unoccluded irradiance, stratified shadow rays for visibility) and the sky
//! (stratified shadow rays), replacing the first iteration's gather for texels. Direct light is
//! the sharpest part of the solution: through the fixed directions a small emitter aliases into
//! a ripple on every wall, here it does not depend on them. Mirror tile cells still receive the
//! emitters through the light field (they carry mirror -> mirror chains). What a mirror first
//! reflects of the sky reaches the texels here too; what it first reflects of the emitters
//! (virtual emitters) reaches them in the second iteration (`mirror_light`), the bounce it
//! belongs to, so that every iteration's texels and tiles hold paths of the same length. That
//! iteration's texel gather leaves mirror senders out.

use crate::error::Result;
use crate::gpu::types::{
    GpuDirectParams, GpuEmitter, GpuFace, GpuMaterial, GpuMirrorTriangle, NO_FACE,
};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use crate::material::material_of;
use crate::prepare::PreparedScene;

/// The emitting triangles of a scene, with each face's mean emitted radiance (over its texels:
/// map_Ke varies it) and whether it varies. `initial` is the texels' initial unshot radiosity.
pub fn emitters(
    prepared: &PreparedScene,
    faces: &[GpuFace],
    initial: &[[f32; 4]],
) -> Vec<GpuEmitter> {
    // per face: sum of radiance, texel count, min and max of r+g+b
    let mut stats = vec![([0.0f64; 3], 0u64, f32::INFINITY, 0.0f32); faces.len()];
    for (point, value) in prepared.atlas.points.iter().zip(initial) {
        let face = point[3].to_bits();
        if face == NO_FACE {
            continue;
        }
        let s = &mut stats[face as usize];
        for (sum, v) in s.0.iter_mut().zip(value) {
            *sum += *v as f64 / std::f64::consts::PI;
        }
        s.1 += 1;
        let sum = (value[0] + value[1] + value[2]) / std::f32::consts::PI;
        s.2 = s.2.min(sum);
        s.3 = s.3.max(sum);
    }
    let mut out = Vec::new();
    for t in &prepared.triangles {
        let f = t.face as usize;
        let (sum, n, lo, hi) = stats[f];
        if n == 0 || hi <= 0.0 {
            continue;
        }
        let mean = sum.map(|s| (s / n as f64) as f32);
        let [a, b, c] = t.vertices.map(|v| prepared.positions[v as usize].as_vec3());
        out.push(GpuEmitter {
            v0: a.into(),
            face: t.face,
            e1: (b - a).into(),
            textured: u32::from(hi - lo > 1e-6 * hi),
            e2: (c - a).into(),
            chance: 0.0,
            radiance: [mean[0], mean[1], mean[2], mean[0] + mean[1] + mean[2]],
        });
    }
    out
}

/// The triangles of faces with an ideal mirror part and tiles: emitters seen in them are virtual
/// emitters (a glossy lobe's light reaches other surfaces through its tiles, which gather the
/// lobe; a tile-less face's as diffuse light, `prepare::packing::SPECULAR_TILES_MIN_AREA`).
pub fn mirror_triangles(
    prepared: &PreparedScene,
    faces: &[GpuFace],
    materials: &[GpuMaterial],
) -> Vec<GpuMirrorTriangle> {
    prepared
        .triangles
        .iter()
        .filter(|t| {
            let f = &faces[t.face as usize];
            let m = material_of(materials, f);
            m.is_delta() && !m.is_glossy() && f.tile_slot != crate::gpu::types::NO_FACE
        })
        .map(|t| {
            let [a, b, c] = t.vertices.map(|v| prepared.positions[v as usize].as_vec3());
            GpuMirrorTriangle {
                v0: a.into(),
                face: t.face,
                e1: (b - a).into(),
                e2: (c - a).into(),
                ..Default::default()
            }
        })
        .collect()
}

/// The direct-light stage: its pipeline, emitters, and the scene's BVH for shadow rays.
pub struct DirectLight {
    pipeline: wgpu::ComputePipeline,
    /// the second iteration's pass over the texels (`mirror_light`), when there are mirrors
    mirror_pipeline: Option<wgpu::ComputePipeline>,
    /// marks the texels inside closed geometry (`texel_validity`), run once on the totals
    validity_pipeline: wgpu::ComputePipeline,
    /// each texel's emitter irradiance vector (`direct_vector`), for normal maps
    vector_pipeline: wgpu::ComputePipeline,
    /// each texel's tangential moment of the rest of its light (`rest_vector`), for normal maps
    rest_pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    pub emitter_count: u32,
    /// mirror triangles: when there are any, the second iteration's texel gather leaves mirror
    /// senders out and `mirror_light` adds what they first reflect of the emitters
    pub mirror_count: u32,
}

impl DirectLight {
    /// `layout0` and `layout1` are the transport's scene and texel-page layouts
    /// (shaders/common/upstream.wgsl), which the stage shares; `alpha_masks` compiles the
    /// cut-outs' test in where the scene has one (`SceneBuffers::alpha_masks`).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        emitters: &[GpuEmitter],
        mirrors: &[GpuMirrorTriangle],
        emitter_samples: u32,
        sky_samples: u32,
        layout0: &wgpu::BindGroupLayout,
        layout1: &wgpu::BindGroupLayout,
        alpha_masks: &[(&str, u32)],
    ) -> Result<DirectLight> {
        let device = &ctx.device;
        let params = GpuDirectParams {
            emitter_count: emitters.len() as u32,
            emitter_samples: emitter_samples.max(1),
            sky_samples,
            mirror_count: mirrors.len() as u32,
        };
        let no_mirror = [GpuMirrorTriangle::default()];
        let mirror_buffer = ctx.buffer_init(
            ledger,
            "direct light: mirror triangles",
            bytemuck::cast_slice(if mirrors.is_empty() {
                &no_mirror
            } else {
                mirrors
            }),
            STORAGE,
        );
        let placeholder = [GpuEmitter::default()];
        let emitter_data: &[GpuEmitter] = if emitters.is_empty() {
            &placeholder
        } else {
            emitters
        };
        let params_buffer = ctx.buffer_init(
            ledger,
            "direct light: parameters",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::UNIFORM,
        );
        let emitter_buffer = ctx.buffer_init(
            ledger,
            "direct light: emitters",
            bytemuck::cast_slice(emitter_data),
            STORAGE,
        );
        let layout2 = reflect::layout(device, "direct.wgsl", 2)?;
        let module = shaders::module_with(device, "direct.wgsl", alpha_masks)?;
        let pipeline = ctx.compute_pipeline(&module, "direct_light", &[layout0, layout1, &layout2]);
        let validity_pipeline =
            ctx.compute_pipeline(&module, "texel_validity", &[layout0, layout1, &layout2]);
        let vector_pipeline =
            ctx.compute_pipeline(&module, "direct_vector", &[layout0, layout1, &layout2]);
        let rest_pipeline =
            ctx.compute_pipeline(&module, "rest_vector", &[layout0, layout1, &layout2]);
        let mirror_pipeline = (!mirrors.is_empty())
            .then(|| ctx.compute_pipeline(&module, "mirror_light", &[layout0, layout1, &layout2]));
        let bind_group =
            ctx.bind_group(&layout2, &[&params_buffer, &emitter_buffer, &mirror_buffer]);
        Ok(DirectLight {
            pipeline,
            mirror_pipeline,
            validity_pipeline,
            vector_pipeline,
            rest_pipeline,
            bind_group,
            emitter_count: emitters.len() as u32,
            mirror_count: mirrors.len() as u32,
        })
    }

    /// Record the pass: one thread per texel of each page, writing the page's `next`. `mirrors`:
    /// the second iteration's pass (virtual emitters), which reads what the gather left there;
    /// otherwise the first iteration's (emitters and sky), which replaces it.
    pub fn encode(
        &self,
        pass: &mut wgpu::ComputePass,
        bg0: &wgpu::BindGroup,
        pages: &[(&wgpu::BindGroup, u32)],
        mirrors: bool,
    ) {
        let pipeline = match (&self.mirror_pipeline, mirrors) {
            (Some(p), true) => p,
            (None, true) => return,
            (_, false) => &self.pipeline,
        };
        self.dispatch(pipeline, pass, bg0, pages);
    }

    /// Record the validity marks (`texel_validity`): `pages` bind each page's total radiance
    /// where the other passes bind `next`; it sets w of every texel (1 visible, 0 inside).
    pub fn encode_validity(
        &self,
        pass: &mut wgpu::ComputePass,
        bg0: &wgpu::BindGroup,
        pages: &[(&wgpu::BindGroup, u32)],
    ) {
        self.dispatch(&self.validity_pipeline, pass, bg0, pages);
    }

    /// Record the light directions for normal maps (`direct_vector`): `pages` bind the
    /// buffers that take each texel's emitter irradiance vector where the others bind `next`.
    /// `rest`: the moments of the rest of the light (`rest_vector`) instead, with `pages`
    /// binding the converged radiance where the unshot radiosity was.
    pub fn encode_vectors(
        &self,
        pass: &mut wgpu::ComputePass,
        bg0: &wgpu::BindGroup,
        pages: &[(&wgpu::BindGroup, u32)],
        rest: bool,
    ) {
        let pipeline = match rest {
            true => &self.rest_pipeline,
            false => &self.vector_pipeline,
        };
        self.dispatch(pipeline, pass, bg0, pages);
    }

    fn dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        pass: &mut wgpu::ComputePass,
        bg0: &wgpu::BindGroup,
        pages: &[(&wgpu::BindGroup, u32)],
    ) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bg0, &[]);
        pass.set_bind_group(2, &self.bind_group, &[]);
        for &(bg1, count) in pages {
            pass.set_bind_group(1, bg1, &[]);
            let groups = count.div_ceil(64);
            let x = groups.clamp(1, 65535);
            pass.dispatch_workgroups(x, groups.div_ceil(x).max(1), 1);
        }
    }
}
