//! The reference: a GPU path tracer (`shaders/reference.wgsl`) over a BVH built here on the
//! CPU, with exactly the scene semantics the light field uses, so that `vlf compare` measures
//! the light field's error and nothing else. Seeded and repeatable; running sums of radiance and
//! of its square give the mean image and, per pixel, the variance of that mean.

use crate::error::{Result, VlfError};
use crate::gpu::types::NO_FACE;
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use crate::prepare::PreparedScene;
use crate::progress::Progress;
use crate::render::Frame;
use crate::scene::{Camera, Scene};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::sync::Arc;

pub use crate::bvh::{build_bvh, GpuBvhNode, GpuTriangle};

/// Mirrors WGSL `TraceParams` (shaders/reference.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuTraceParams {
    pub inv_view_proj: [[f32; 4]; 4],
    pub eye: [f32; 3],
    pub width: u32,
    pub sky: [f32; 3],
    pub height: u32,
    pub samples_per_pass: u32,
    pub pass_index: u32,
    pub seed: u32,
    pub light_count: u32,
    pub light_weight_total: f32,
    pub _pad: [u32; 3],
}

/// What `vlf reference` produced.
pub struct Reference {
    pub mean: Frame,
    /// per-pixel variance of the mean estimate
    pub variance: Frame,
    pub spp: u32,
    /// tracing the samples and reading the image back: what each further frame would cost
    pub seconds: f64,
    /// the one-off part before it: scene preparation, BVH, buffers, pipeline
    pub setup_seconds: f64,
}

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The scene as the path tracer reads it: the light field's faces, the front triangles in BVH
/// order, the emitters weighted by luminance x area, and the textures back to back.
struct TraceScene {
    faces: Vec<crate::gpu::types::GpuFace>,
    /// the material table the faces index (`crate::material`)
    materials: Vec<crate::gpu::types::GpuMaterial>,
    triangles: Vec<GpuTriangle>,
    nodes: Vec<GpuBvhNode>,
    /// (triangle index as f32 bits, running weight)
    lights: Vec<[f32; 2]>,
    light_weight_total: f32,
    /// the textures back to back, and which face uses which
    textures: crate::lightfield::textures::SurfaceTextures,
    /// per face its normal map (`SurfaceDetail::face_normal_maps`; empty: none)
    normal_maps: Vec<[u32; 2]>,
}

impl TraceScene {
    fn new(scene: &Scene, prepared: &PreparedScene) -> TraceScene {
        let faces =
            crate::prepare::packing::gpu_faces(prepared, &vec![NO_FACE; prepared.faces.len()]);
        let materials = crate::prepare::packing::gpu_materials(prepared);
        let front: Vec<&crate::prepare::PreparedTriangle> = prepared
            .triangles
            .iter()
            .filter(|t| !prepared.faces[t.face as usize].is_back)
            .collect();
        let corners: Vec<[Vec3; 3]> = front
            .iter()
            .map(|t| t.vertices.map(|v| prepared.positions[v as usize].as_vec3()))
            .collect();
        let (nodes, triangles) = crate::bvh::bvh_triangles(
            &corners,
            |i| front[i].face,
            |i| front[i].uv.unwrap_or([[0.0; 2]; 3]),
        );
        // emitters: front triangles of emitting faces, weighted by luminance x area
        let mut lights: Vec<[f32; 2]> = Vec::new();
        let mut total = 0.0f32;
        for (i, t) in triangles.iter().enumerate() {
            let le =
                luminance(crate::material::emitted(&materials, &faces[t.face as usize]).into());
            let area = 0.5 * Vec3::from(t.e1).cross(Vec3::from(t.e2)).length();
            if le > 0.0 && area > 0.0 {
                total += le * area;
                lights.push([f32::from_bits(i as u32), total]);
            }
        }
        let textures = crate::lightfield::textures::SurfaceTextures::of(scene, prepared);
        TraceScene {
            faces,
            materials,
            triangles,
            nodes,
            lights,
            light_weight_total: total,
            textures,
            normal_maps: crate::lightfield::textures::normal_maps(scene, prepared),
        }
    }
}

/// The path tracer on the GPU: its parameters, the scene's buffers (the running sums last),
/// the pipeline and its bind group.
struct Tracer {
    params: wgpu::Buffer,
    sums: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// kept alive while the bind group refers to them
    _buffers: Vec<wgpu::Buffer>,
}

impl Tracer {
    fn new(ctx: &GpuContext, t: &TraceScene, [width, height]: [u32; 2]) -> Result<Tracer> {
        let ledger = MemoryLedger::default();
        let device = &ctx.device;
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace parameters"),
            size: std::mem::size_of::<GpuTraceParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let buffers = vec![
            ctx.buffer_init(
                &ledger,
                "triangles",
                bytemuck::cast_slice(&t.triangles),
                STORAGE,
            ),
            ctx.buffer_init(&ledger, "bvh", bytemuck::cast_slice(&t.nodes), STORAGE),
            ctx.buffer_init(&ledger, "faces", bytemuck::cast_slice(&t.faces), STORAGE),
            ctx.buffer_init(
                &ledger,
                "face textures",
                bytemuck::cast_slice(&t.textures.face_textures),
                STORAGE,
            ),
            ctx.buffer_init(
                &ledger,
                "texture info",
                bytemuck::cast_slice(&t.textures.info),
                STORAGE,
            ),
            ctx.buffer_init(
                &ledger,
                "texels",
                bytemuck::cast_slice(&t.textures.texels),
                STORAGE,
            ),
            ctx.buffer_init(&ledger, "lights", bytemuck::cast_slice(&t.lights), STORAGE),
        ];
        let sums = ctx.buffer_zeroed(&ledger, "sums", width as u64 * height as u64 * 32, STORAGE);
        let layout = reflect::layout(device, "reference.wgsl", 0)?;
        // a scene without cut-outs compiles their test out (common/coverage.wgsl)
        let cutouts = u32::from(t.textures.any_cutout());
        // and one without normal maps theirs (common/normal_map.wgsl)
        let normal_maps = u32::from(!t.normal_maps.is_empty());
        let module = shaders::module_with(
            device,
            "reference.wgsl",
            &[("ALPHA_MASKS", cutouts), ("NORMAL_MAPS", normal_maps)],
        )?;
        let pipeline = ctx.compute_pipeline(&module, "trace_pass", &[&layout]);
        let mut all: Vec<&wgpu::Buffer> = vec![&params];
        all.extend(buffers.iter());
        all.push(&sums);
        let materials = ctx.buffer_init(
            &ledger,
            "materials",
            bytemuck::cast_slice(&t.materials),
            STORAGE,
        );
        all.push(&materials);
        let placeholder = [[NO_FACE, 0]];
        let normal_maps = ctx.buffer_init(
            &ledger,
            "normal maps",
            bytemuck::cast_slice(match t.normal_maps.is_empty() {
                true => &placeholder[..],
                false => &t.normal_maps,
            }),
            STORAGE,
        );
        all.push(&normal_maps);
        let specular = ctx.buffer_init(
            &ledger,
            "specular textures",
            bytemuck::cast_slice(&t.textures.specular_records()),
            STORAGE,
        );
        all.push(&specular);
        let bind_group = ctx.bind_group(&layout, &all);
        Ok(Tracer {
            params,
            sums,
            pipeline,
            bind_group,
            _buffers: buffers,
        })
    }

    /// One pass of `params.samples_per_pass` samples per pixel, waited for.
    fn pass(&self, ctx: &GpuContext, params: &GpuTraceParams) -> Result<()> {
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(params.width.div_ceil(8), params.height.div_ceil(8), 1);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()
    }
}

/// The mean image and the per-pixel variance of the mean from the running sums of radiance
/// and of its square.
fn mean_and_variance(sums: &[[f32; 4]], spp: u32, [width, height]: [u32; 2]) -> (Frame, Frame) {
    let n = spp as f32;
    let mut mean = Vec::with_capacity((width * height) as usize);
    let mut variance = Vec::with_capacity((width * height) as usize);
    for px in sums.chunks(2) {
        let m: [f32; 3] = std::array::from_fn(|c| px[0][c] / n);
        let v: [f32; 3] = std::array::from_fn(|c| ((px[1][c] / n - m[c] * m[c]).max(0.0)) / n);
        mean.push([m[0], m[1], m[2], 1.0]);
        variance.push([v[0], v[1], v[2], 1.0]);
    }
    let frame = |pixels| Frame {
        width,
        height,
        pixels,
    };
    (frame(mean), frame(variance))
}

/// Path-trace one view with `spp` samples per pixel, reporting its passes to `progress`.
pub fn render(
    ctx: Arc<GpuContext>,
    scene: &Scene,
    camera: &Camera,
    size: [u32; 2],
    spp: u32,
    seed: u32,
    progress: &dyn Progress,
) -> Result<Reference> {
    if spp == 0 {
        return Err(VlfError::Parameter {
            name: "spp",
            message: "at least 1 sample per pixel".into(),
        });
    }
    let started = std::time::Instant::now();
    // the light field's own preparation: same normalisation, faces, twins and materials
    let prepared = PreparedScene::new(scene, 1.0)?;
    let trace_scene = TraceScene::new(scene, &prepared);
    let [width, height] = size;
    let vp = crate::render::view_projection(camera, &prepared.normalisation, width, height);
    let eye = prepared.normalisation.to_unit(camera.eye).as_vec3();
    let samples_per_pass = 4u32.min(spp);
    let passes = spp.div_ceil(samples_per_pass);
    let spp = passes * samples_per_pass;
    let tracer = Tracer::new(&ctx, &trace_scene, size)?;

    let what = format!("{spp} spp at {width}x{height}");
    progress.begin(passes as u64, "passes", &what);
    let setup_seconds = started.elapsed().as_secs_f64();
    let tracing = std::time::Instant::now();
    for pass_index in 0..passes {
        let params = GpuTraceParams {
            inv_view_proj: vp.inverse().to_cols_array_2d(),
            eye: eye.into(),
            width,
            sky: scene.sky.unwrap_or([0.0; 3]),
            height,
            samples_per_pass,
            pass_index,
            seed,
            light_count: trace_scene.lights.len() as u32,
            light_weight_total: trace_scene.light_weight_total.max(1e-30),
            _pad: [0; 3],
        };
        tracer.pass(&ctx, &params)?;
        progress.advance_to(pass_index as u64 + 1, &what);
    }
    progress.finish();
    let sums: Vec<[f32; 4]> = ctx.read_buffer(&tracer.sums, width as u64 * height as u64 * 32)?;
    let (mean, variance) = mean_and_variance(&sums, spp, size);
    Ok(Reference {
        mean,
        variance,
        spp,
        seconds: tracing.elapsed().as_secs_f64(),
        setup_seconds,
    })
}
