//! The moving objects' own light, once per frame at their vertices
//! (`shaders/moving_light.wgsl`): after the refit and in the same compute pass, each shown
//! skinned vertex takes `vertex_shadow_samples` shadow rays to the emitters and
//! `vertex_sky_shadow_samples` to the sky, against the scene and the moving objects themselves
//! (its direct light); then `occlusion_rays` rays against the moving objects alone correct the
//! irradiance probes' light there for what the objects hide of it (the probes know the static
//! scene only: an armpit would get the room's light unoccluded) and send instead, one bounce
//! within them. Every view's moving surfaces interpolate both over their triangles
//! (`common/moving_surface.wgsl`, moving_radiance). Its cost follows the objects' vertices, not
//! the views or their pixels: a CAVE's floor views that look down on the body no longer cast a
//! dozen shadow rays per eye ray that meets it. `[object_lighting] direct_light = "per_pixel"`
//! keeps the shadow rays per eye ray instead (and the probes' light as it is), and this module
//! is not used.

use super::moving::MovingObjects;
use super::probes::{BakeInputs, ObjectLighting, Probes};
use super::shadow_atlas::ShadowAtlas;
use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuMovingLight, GpuView};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use crate::lightfield::bindings::FieldLayout;

/// Threads per vertex (`LANES` in moving_light.wgsl), each casting a share of its rays.
const LANES: u64 = 8;

/// The pass's two pipelines (the direct light, then the probes' correction), its layouts, the
/// vertices' light (what the views read) and the group that writes it.
pub struct MovingLight {
    pipeline: wgpu::ComputePipeline,
    occlusion: wgpu::ComputePipeline,
    scene_layout: wgpu::BindGroupLayout,
    field_layout: FieldLayout,
    moving_layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
    /// per moving vertex two entries (rgb): its direct irradiance, then the probes' correction
    /// (the renderer's moving group, binding 6)
    pub lit: wgpu::Buffer,
    params: GpuMovingLight,
}

/// One light field's groups for the pass: the scene, the light field, and the moving objects'
/// shading group with that field's probes and emitters.
pub struct MovingLightField {
    scene: wgpu::BindGroup,
    field: wgpu::BindGroup,
    moving: wgpu::BindGroup,
}

impl MovingLight {
    /// The pass for `objects` with `settings`' rays per vertex; `stack` is the traversal's
    /// stack and `cutouts` whether a face cuts holes (as the renderer's pipelines are made).
    pub fn new(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        (settings, objects): (&ObjectLighting, &MovingObjects),
        (stack, cutouts): (u32, bool),
    ) -> Result<MovingLight> {
        let device = &ctx.device;
        let stage = "moving_light.wgsl";
        let module = shaders::module_with(
            device,
            stage,
            &[("PAIR_STACK", stack), ("ALPHA_MASKS", u32::from(cutouts))],
        )?;
        let scene_layout = reflect::layout(device, stage, 0)?;
        let field_layout = crate::lightfield::bindings::layout(device, stage)?;
        let moving_layout = reflect::layout(device, stage, 2)?;
        let light_layout = reflect::layout(device, stage, 3)?;
        if field_layout.group != 1 {
            return Err(VlfError::Gpu(format!(
                "shaders/{stage} binds the light field at group {}; the renderer binds it at 1",
                field_layout.group
            )));
        }
        let layouts = [
            &scene_layout,
            &field_layout.layout,
            &moving_layout,
            &light_layout,
        ];
        let pipeline = ctx.compute_pipeline(&module, "light_vertices", &layouts);
        let occlusion = ctx.compute_pipeline(&module, "occlude_vertices", &layouts);
        let lit = ctx.buffer_init(
            ledger,
            "moving objects: vertices' light",
            &vec![0u8; objects.vertex_count.max(1) as usize * 32],
            STORAGE,
        );
        let group = ctx.bind_group(
            &light_layout,
            &[&objects.posed, &objects.posed_normals, &lit],
        );
        let [emitters, sky] = settings.direct_samples();
        let configured = [emitters, sky, settings.occlusion_rays];
        let [emitter_samples, sky_samples, occlusion_rays] =
            rays_per_vertex(configured, objects.vertex_count, settings);
        Ok(MovingLight {
            pipeline,
            occlusion,
            scene_layout,
            field_layout,
            moving_layout,
            group,
            lit,
            params: GpuMovingLight {
                vertex_count: objects.vertex_count,
                emitter_samples,
                sky_samples,
                occlusion_rays,
            },
        })
    }

    /// The groups that light the vertices in the light field `inputs` binds (the probes' bake
    /// inputs: the same scene buffers), with that field's probes and emitters, and the shadow
    /// atlas where the objects' shadows are drawn in one (its pass runs before this one).
    pub fn field(
        &self,
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        inputs: &BakeInputs,
        (objects, probes): (&MovingObjects, &Probes),
        atlas: Option<&ShadowAtlas>,
    ) -> MovingLightField {
        let uniform = wgpu::BufferUsages::UNIFORM;
        let view = ctx.buffer_init(
            ledger,
            "moving objects' light: view",
            bytemuck::bytes_of::<GpuView>(inputs.view),
            uniform,
        );
        let params = ctx.buffer_init(
            ledger,
            "moving objects' light: settings",
            bytemuck::bytes_of(&self.params),
            uniform,
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
            ],
        );
        MovingLightField {
            scene,
            field: inputs.resident.bind_group(&self.field_layout, inputs.field),
            // the vertices' light itself is this pass's own group's (group 3), not read here
            moving: super::moving_group(ctx, &self.moving_layout, (objects, probes), (atlas, None)),
        }
    }

    /// This frame's direct light at every vertex for `field`, in the moving objects' pass after
    /// their refit (the shadow atlas reads it next, for what the objects send back of the
    /// indirect light they block).
    pub fn encode_direct(&self, pass: &mut wgpu::ComputePass<'_>, field: &MovingLightField) {
        self.dispatch(pass, field, &self.pipeline);
    }

    /// Then the probes' correction at every vertex (reading the direct light where the objects
    /// meet themselves, and the shadow atlas where they shade the scene). wgpu orders the
    /// dispatches: the buffer is written by both.
    pub fn encode_occlusion(&self, pass: &mut wgpu::ComputePass<'_>, field: &MovingLightField) {
        if self.params.occlusion_rays > 0 {
            self.dispatch(pass, field, &self.occlusion);
        }
    }

    fn dispatch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        field: &MovingLightField,
        pipeline: &wgpu::ComputePipeline,
    ) {
        pass.set_bind_group(0, &field.scene, &[]);
        pass.set_bind_group(1, &field.field, &[]);
        pass.set_bind_group(2, &field.moving, &[]);
        pass.set_bind_group(3, &self.group, &[]);
        let groups = (self.params.vertex_count as u64 * LANES)
            .div_ceil(64)
            .max(1) as u32;
        pass.set_pipeline(pipeline);
        pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
    }
}

/// The rays each vertex takes (shadow rays to the emitters and to the sky, occlusion rays):
/// `configured`, scaled down alike where `vertices` would take more than `vertex_light_rays` a
/// frame (a 200K-triangle prop would take 6 million), keeping at least one of each kind asked
/// for.
fn rays_per_vertex(configured: [u32; 3], vertices: u32, settings: &ObjectLighting) -> [u32; 3] {
    let asked = vertices as u64 * configured.iter().map(|&n| n as u64).sum::<u64>();
    let cap = settings.vertex_light_rays as u64;
    if asked <= cap {
        return configured;
    }
    configured.map(|n| match n {
        0 => 0,
        n => ((n as u64 * cap / asked) as u32).max(1),
    })
}

#[cfg(test)]
mod tests {
    use super::rays_per_vertex;
    use crate::render::probes::ObjectLighting;

    /// The mannequin's few thousand vertices keep the configured rays; a 100K-vertex prop is
    /// scaled to the frame's cap, each kind alike and never to none.
    #[test]
    fn rays_per_vertex_keep_the_frames_rays_under_the_cap() {
        let settings = ObjectLighting::default();
        assert_eq!(
            rays_per_vertex([32, 16, 16], 6_792, &settings),
            [32, 16, 16]
        );
        let scaled = rays_per_vertex([32, 16, 16], 100_000, &settings);
        assert_eq!(scaled, [5, 2, 2]);
        let sum: u32 = scaled.iter().sum();
        assert!(100_000 * sum as u64 <= settings.vertex_light_rays as u64);
        assert_eq!(
            rays_per_vertex([32, 0, 0], 10_000_000, &settings),
            [1, 0, 0]
        );
    }
}
