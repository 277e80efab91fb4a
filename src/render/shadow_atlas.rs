//! The moving objects' shadows on the static scene as a per-frame atlas
//! (`shaders/shadow_atlas.wgsl`): once per frame, after the refit and in the same compute pass,
//! the direct irradiance the moving objects take from the texels of the static faces they can
//! shadow (culled per face on the GPU against the objects' boxes, the emitters' boxes and, under
//! a sky, a reach), which every view then reads with the light field's bilinear lookup
//! (`shaders/common/moving_shadow.wgsl`). Its cost follows the texels near the objects, not the
//! views or their pixels: the 8 views of a CAVE and both eyes of a headset share it. The texels
//! take a fixed sample pattern each (a hash of face and texel), so a still scene does not
//! flicker. `[object_lighting] shadows = "per_pixel"` keeps the shadow rays per pair of eye rays
//! instead, and this module is not used.

use super::moving::MovingObjects;
use super::probes::{BakeInputs, ObjectLighting, Probes};
use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuEmitter, GpuFace, GpuShadowAtlas, GpuView};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use crate::lightfield::bindings::FieldLayout;
use glam::Vec3;

/// The evaluation's workgroups (`EVALUATION_GROUPS` in shadow_atlas.wgsl): about as many as an
/// H100 keeps resident at once.
const EVALUATION_GROUPS: u32 = 4096;

/// The texels of one item of the evaluation (`ITEM_TEXELS` in shadow_atlas.wgsl: a workgroup
/// evaluates an item, 8 threads a texel).
const ITEM_TEXELS: u32 = 8;

/// The most groups of emitting triangles whose boxes the cull tests a face against (more
/// emitting triangles share boxes, in their order: the triangles of one light lie together).
pub const EMITTER_BOXES: usize = 64;

/// The atlas's pipelines, its buffers (shared by every light field of the renderer) and layouts.
pub struct ShadowAtlas {
    reset: wgpu::ComputePipeline,
    cull: wgpu::ComputePipeline,
    evaluate: wgpu::ComputePipeline,
    scene_layout: wgpu::BindGroupLayout,
    field_layout: FieldLayout,
    moving_layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
    /// per face its first texel this frame (`u32::MAX`: none), and the texels: what the views
    /// read (the renderer's moving group, bindings 6 and 7)
    pub slots: wgpu::Buffer,
    pub texels: wgpu::Buffer,
    /// the settings every field's uniform starts from (its emitter boxes its own)
    params: GpuShadowAtlas,
}

/// One light field's groups for the atlas's pass: the scene with its emitters' boxes, the light
/// field, and the moving objects' shading group with that field's probes and emitters.
pub struct ShadowField {
    scene: wgpu::BindGroup,
    field: wgpu::BindGroup,
    moving: wgpu::BindGroup,
}

/// What the atlas is made for: the light field's faces, the traversal's stack, whether a face
/// cuts holes, and the scene's scale (metres to the normalised space).
pub struct AtlasScene<'a> {
    pub faces: &'a [GpuFace],
    pub stack: u32,
    pub cutouts: bool,
    pub scale: f64,
}

impl ShadowAtlas {
    /// The atlas for `scene`'s faces with `settings`: its texels (at most
    /// `shadow_atlas_texels`, no more than the faces have), rays per texel and the sky's reach.
    pub fn new(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        settings: &ObjectLighting,
        scene: &AtlasScene,
    ) -> Result<ShadowAtlas> {
        let device = &ctx.device;
        let module = shaders::module_with(
            device,
            "shadow_atlas.wgsl",
            &[
                ("PAIR_STACK", scene.stack),
                ("ALPHA_MASKS", u32::from(scene.cutouts)),
            ],
        )?;
        let scene_layout = reflect::layout(device, "shadow_atlas.wgsl", 0)?;
        let field_layout = crate::lightfield::bindings::layout(device, "shadow_atlas.wgsl")?;
        let moving_layout = reflect::layout(device, "shadow_atlas.wgsl", 2)?;
        let atlas_layout = reflect::layout(device, "shadow_atlas.wgsl", 3)?;
        if field_layout.group != 1 {
            return Err(VlfError::Gpu(format!(
                "shaders/shadow_atlas.wgsl binds the light field at group {}; the renderer binds it at 1",
                field_layout.group
            )));
        }
        let layouts = [
            &scene_layout,
            &field_layout.layout,
            &moving_layout,
            &atlas_layout,
        ];
        let pipeline = |entry| ctx.compute_pipeline(&module, entry, &layouts);
        let face_count = scene.faces.len() as u32;
        let s = settings.shadow_atlas_subdivision as u64;
        let all: u64 = (scene.faces.iter())
            .map(|f| f.atlas_w as u64 * f.atlas_h as u64 * s * s)
            .sum();
        let texel_capacity = (settings.shadow_atlas_texels as u64).min(all).max(1) as u32;
        let item_capacity = texel_capacity.div_ceil(ITEM_TEXELS) + face_count.min(texel_capacity);
        let buffer = |name: &str, bytes: u64, usage| {
            ledger.record(name, bytes);
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(name),
                size: bytes.max(16),
                usage,
                mapped_at_creation: false,
            })
        };
        // no face shadowed until the first frame fills them
        let slots = ctx.buffer_init(
            ledger,
            "shadow atlas: face slots",
            &vec![0xffu8; face_count.max(1) as usize * 4],
            STORAGE,
        );
        let texels = buffer("shadow atlas: texels", texel_capacity as u64 * 16, STORAGE);
        let counters = buffer("shadow atlas: counters", 16, STORAGE);
        let items = buffer("shadow atlas: items", item_capacity as u64 * 8, STORAGE);
        let group = ctx.bind_group(&atlas_layout, &[&slots, &texels, &counters, &items]);
        Ok(ShadowAtlas {
            reset: pipeline("reset"),
            cull: pipeline("cull"),
            evaluate: pipeline("evaluate"),
            scene_layout,
            field_layout,
            moving_layout,
            group,
            slots,
            texels,
            params: GpuShadowAtlas {
                face_count,
                texel_capacity,
                item_capacity,
                box_count: 0,
                samples: [
                    settings.atlas_shadow_samples,
                    settings.atlas_sky_shadow_samples,
                ],
                sky_reach: (settings.sky_shadow_reach as f64 * scene.scale) as f32,
                indirect_rays: indirect_rays(settings),
                indirect_reach: (settings.indirect_shadow_reach as f64 * scene.scale) as f32,
                ..Default::default()
            },
        })
    }

    /// The groups that evaluate the atlas in the light field `inputs` binds (the probes' bake
    /// inputs: the same scene buffers), with that field's probes and emitters, and the
    /// vertices' light where the moving objects carry it (what they send back of the indirect
    /// light they block: `render::moving_light`, whose direct step runs before the atlas).
    pub fn field(
        &self,
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        inputs: &BakeInputs,
        (objects, probes, vertex_light): (&MovingObjects, &Probes, Option<&wgpu::Buffer>),
    ) -> ShadowField {
        let boxes = emitter_boxes(inputs.emitters);
        let params = GpuShadowAtlas {
            box_count: (boxes.len() / 2) as u32,
            ..self.params
        };
        let uniform = wgpu::BufferUsages::UNIFORM;
        let view = ctx.buffer_init(
            ledger,
            "shadow atlas: view",
            bytemuck::bytes_of::<GpuView>(inputs.view),
            uniform,
        );
        let params = ctx.buffer_init(
            ledger,
            "shadow atlas: settings",
            bytemuck::bytes_of(&params),
            uniform,
        );
        let boxes = ctx.buffer_init(
            ledger,
            "shadow atlas: emitter boxes",
            bytemuck::cast_slice(&boxes),
            STORAGE,
        );
        let scene = ctx.bind_group(
            &self.scene_layout,
            &[
                &view,
                inputs.faces,
                inputs.triangles,
                inputs.pairs,
                inputs.ray_triangles,
                inputs.materials,
                &params,
                &boxes,
            ],
        );
        ShadowField {
            scene,
            field: inputs.resident.bind_group(&self.field_layout, inputs.field),
            moving: probes.moving_group(ctx, &self.moving_layout, objects, vertex_light),
        }
    }

    /// This frame's atlas for `field`, in the moving objects' pass after their refit: reset the
    /// counters, cull the faces, evaluate the candidates' texels (`EVALUATION_GROUPS`
    /// workgroups, each looping over its share of the items).
    pub fn encode(&self, pass: &mut wgpu::ComputePass<'_>, field: &ShadowField) {
        pass.set_bind_group(0, &field.scene, &[]);
        pass.set_bind_group(1, &field.field, &[]);
        pass.set_bind_group(2, &field.moving, &[]);
        pass.set_bind_group(3, &self.group, &[]);
        pass.set_pipeline(&self.reset);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(&self.cull);
        let groups = self.params.face_count.div_ceil(64).max(1);
        pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
        pass.set_pipeline(&self.evaluate);
        pass.dispatch_workgroups(EVALUATION_GROUPS, 1, 1);
    }
}

/// The rays per texel for the indirect light the objects block: as configured where the probes
/// leave out the direct light the atlas samples itself (else a blocked emitter's or sky's light
/// would be taken twice, once by the shadow rays and once through the probes), else none.
fn indirect_rays(settings: &ObjectLighting) -> u32 {
    use crate::gpu::types::{DIRECT_EMITTERS, DIRECT_SKY};
    let left_out = settings.direct_sampled();
    let emitters = settings.atlas_shadow_samples == 0 || left_out & DIRECT_EMITTERS != 0;
    let sky = settings.atlas_sky_shadow_samples == 0 || left_out & DIRECT_SKY != 0;
    match emitters && sky {
        true => settings.atlas_indirect_rays,
        false => 0,
    }
}

/// The boxes of the emitting triangles in at most `EMITTER_BOXES` groups of consecutive ones, as
/// [lo, hi] pairs of vec4 (one empty box where there is none: never met).
pub fn emitter_boxes(emitters: &[GpuEmitter]) -> Vec<[f32; 4]> {
    let per = emitters.len().div_ceil(EMITTER_BOXES).max(1);
    let mut out: Vec<[f32; 4]> = (emitters.chunks(per))
        .flat_map(|group| {
            let (lo, hi) = group.iter().fold(
                (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
                |(lo, hi), e| {
                    let a = Vec3::from(e.v0);
                    let (b, c) = (a + Vec3::from(e.e1), a + Vec3::from(e.e2));
                    (lo.min(a).min(b).min(c), hi.max(a).max(b).max(c))
                },
            );
            [lo.extend(0.0).into(), hi.extend(0.0).into()]
        })
        .collect();
    if out.is_empty() {
        out = vec![[f32::MAX / 2.0; 4], [f32::MAX / 2.0; 4]];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 130 emitting triangles make no more than 64 boxes: 44 groups of 3 consecutive ones (the
    /// last of 1), each box holding its triangles' corners; none makes one box no face meets.
    #[test]
    fn emitter_boxes_group_consecutive_triangles_and_hold_their_corners() {
        let emitters: Vec<GpuEmitter> = (0..130)
            .map(|i| GpuEmitter {
                v0: [i as f32, 1.0, 0.0],
                e1: [0.5, 0.0, 0.0],
                e2: [0.0, 0.0, 0.25],
                ..Default::default()
            })
            .collect();
        let boxes = emitter_boxes(&emitters);
        assert_eq!(boxes.len(), 2 * 130usize.div_ceil(3));
        assert_eq!(boxes[0], [0.0, 1.0, 0.0, 0.0]);
        assert_eq!(boxes[1], [2.5, 1.0, 0.25, 0.0]);
        let last = boxes.len() - 2;
        assert_eq!(boxes[last], [129.0, 1.0, 0.0, 0.0]);
        assert_eq!(emitter_boxes(&[]).len(), 2);
    }
}
