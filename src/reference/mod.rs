//! The reference: a GPU path tracer (`shaders/reference.wgsl`) over a BVH built here on the
//! CPU, with exactly the scene semantics the light field uses, so that `vlf compare` measures
//! the light field's error and nothing else. Seeded and repeatable; running sums of radiance and
//! of its square give the mean image and, per pixel, the variance of that mean.

use crate::error::{Result, VlfError};
use crate::gpu::types::NO_FACE;
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use crate::prepare::PreparedScene;
use crate::render::Frame;
use crate::scene::{Camera, Scene};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::sync::Arc;

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

/// Mirrors WGSL `Triangle` (shaders/common/bvh.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub face: u32,
    pub e1: [f32; 3],
    pub _pad0: u32,
    pub e2: [f32; 3],
    pub _pad1: u32,
    pub uv01: [f32; 4],
    pub uv2: [f32; 4],
}

/// Mirrors WGSL `BvhNode` (shaders/common/bvh.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuBvhNode {
    pub lo: [f32; 3],
    pub index: u32,
    pub hi: [f32; 3],
    pub count: u32,
}

const LEAF_SIZE: usize = 4;
/// A leaf never holds more than this many triangles, whatever the cost model says.
const MAX_LEAF_SIZE: usize = 16;
/// Below this depth splits follow the surface area heuristic; deeper, median splits, which
/// halve every level: 32 + log2(triangles) stays within the GPU's 64-entry traversal stack.
const SAH_DEPTH: u32 = 32;
const SAH_BINS: usize = 16;

#[derive(Clone, Copy)]
struct Bounds {
    lo: Vec3,
    hi: Vec3,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, other: Bounds) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
    }
    fn area(&self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// The best surface-area split of `order` into bins along one of the three axes: (axis, the
/// centroid coordinate below which a triangle goes left, cost) where the cost counts one unit
/// per triangle tested, in proportion to the probability of reaching each child.
fn sah_split(
    order: &[u32],
    boxes: &[Bounds],
    centroids: &[Vec3],
    clo: Vec3,
    chi: Vec3,
    parent_area: f32,
) -> Option<(usize, f32, f32)> {
    let mut best: Option<(usize, f32, f32)> = None;
    for axis in 0..3 {
        let (lo, hi) = (clo[axis], chi[axis]);
        if hi <= lo {
            continue;
        }
        let scale = SAH_BINS as f32 / (hi - lo);
        let bin_of = |c: f32| (((c - lo) * scale) as usize).min(SAH_BINS - 1);
        let mut bins = [(Bounds::EMPTY, 0usize); SAH_BINS];
        for &t in order {
            let b = &mut bins[bin_of(centroids[t as usize][axis])];
            b.0.grow(boxes[t as usize]);
            b.1 += 1;
        }
        // sweep from the right, then from the left: cost of every boundary between bins
        let mut right_area = [0.0f32; SAH_BINS];
        let mut right_count = [0usize; SAH_BINS];
        let (mut acc, mut n) = (Bounds::EMPTY, 0);
        for i in (1..SAH_BINS).rev() {
            acc.grow(bins[i].0);
            n += bins[i].1;
            right_area[i] = acc.area();
            right_count[i] = n;
        }
        let (mut acc, mut n) = (Bounds::EMPTY, 0);
        for i in 1..SAH_BINS {
            acc.grow(bins[i - 1].0);
            n += bins[i - 1].1;
            if n == 0 || right_count[i] == 0 {
                continue;
            }
            let cost = 1.0
                + (acc.area() * n as f32 + right_area[i] * right_count[i] as f32)
                    / parent_area.max(1e-30);
            if best.is_none_or(|b| cost < b.2) {
                best = Some((axis, lo + i as f32 / scale, cost));
            }
        }
    }
    best
}

/// A bounding volume hierarchy over `triangles`: binned surface-area-heuristic splits (median
/// splits past depth SAH_DEPTH); returns the nodes and the triangle order the leaves refer to.
/// The left child of an internal node is the node after it; `index` holds the right child.
pub fn build_bvh(triangles: &[[Vec3; 3]]) -> (Vec<GpuBvhNode>, Vec<u32>) {
    let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
    let centroids: Vec<Vec3> = triangles
        .iter()
        .map(|t| (t[0] + t[1] + t[2]) / 3.0)
        .collect();
    let boxes: Vec<Bounds> = triangles
        .iter()
        .map(|t| Bounds {
            lo: t[0].min(t[1]).min(t[2]),
            hi: t[0].max(t[1]).max(t[2]),
        })
        .collect();
    let mut nodes = Vec::with_capacity(triangles.len() * 2 / LEAF_SIZE + 1);
    struct Input<'a> {
        boxes: &'a [Bounds],
        centroids: &'a [Vec3],
    }
    fn build(
        nodes: &mut Vec<GpuBvhNode>,
        order: &mut [u32],
        first: usize,
        depth: u32,
        input: &Input,
    ) -> u32 {
        let mut bounds = Bounds::EMPTY;
        let (mut clo, mut chi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &t in order.iter() {
            bounds.grow(input.boxes[t as usize]);
            clo = clo.min(input.centroids[t as usize]);
            chi = chi.max(input.centroids[t as usize]);
        }
        let me = nodes.len();
        nodes.push(GpuBvhNode {
            lo: bounds.lo.into(),
            hi: bounds.hi.into(),
            index: first as u32,
            count: order.len() as u32,
        });
        let extent = chi - clo;
        if order.len() <= LEAF_SIZE || extent.max_element() <= 0.0 {
            return me as u32;
        }
        let by_sah = if depth < SAH_DEPTH {
            sah_split(order, input.boxes, input.centroids, clo, chi, bounds.area())
        } else {
            None
        };
        let mid = match by_sah {
            // a leaf is cheaper than any split: keep it, if it is small enough
            Some((_, _, cost)) if cost >= order.len() as f32 && order.len() <= MAX_LEAF_SIZE => {
                return me as u32
            }
            Some((axis, boundary, _)) => {
                let mut left = 0;
                for i in 0..order.len() {
                    if input.centroids[order[i] as usize][axis] < boundary {
                        order.swap(i, left);
                        left += 1;
                    }
                }
                left
            }
            None => 0,
        };
        let mid = if mid == 0 || mid == order.len() {
            // no useful area split (or too deep): halve along the widest centroid axis
            let axis = if extent.x >= extent.y && extent.x >= extent.z {
                0
            } else if extent.y >= extent.z {
                1
            } else {
                2
            };
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |a, b| {
                input.centroids[*a as usize][axis].total_cmp(&input.centroids[*b as usize][axis])
            });
            mid
        } else {
            mid
        };
        let (left, right) = order.split_at_mut(mid);
        build(nodes, left, first, depth + 1, input);
        let r = build(nodes, right, first + mid, depth + 1, input);
        nodes[me].index = r;
        nodes[me].count = 0;
        me as u32
    }
    if !triangles.is_empty() {
        build(
            &mut nodes,
            &mut order,
            0,
            0,
            &Input {
                boxes: &boxes,
                centroids: &centroids,
            },
        );
    }
    (nodes, order)
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

/// Path-trace one view with `spp` samples per pixel.
pub fn render(
    ctx: Arc<GpuContext>,
    scene: &Scene,
    camera: &Camera,
    size: [u32; 2],
    spp: u32,
    seed: u32,
    progress: bool,
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
    let faces = crate::propagate::gpu_faces(&prepared, &vec![NO_FACE; prepared.faces.len()]);
    let front: Vec<&crate::prepare::PreparedTriangle> = prepared
        .triangles
        .iter()
        .filter(|t| !prepared.faces[t.face as usize].is_back)
        .collect();
    let corners: Vec<[Vec3; 3]> = front
        .iter()
        .map(|t| t.vertices.map(|v| prepared.positions[v as usize].as_vec3()))
        .collect();
    let (nodes, order) = build_bvh(&corners);
    let triangles: Vec<GpuTriangle> = order
        .iter()
        .map(|&i| {
            let [a, b, c] = corners[i as usize];
            let uv = front[i as usize].uv.unwrap_or([[0.0; 2]; 3]);
            GpuTriangle {
                v0: a.into(),
                face: front[i as usize].face,
                e1: (b - a).into(),
                e2: (c - a).into(),
                uv01: [uv[0][0], uv[0][1], uv[1][0], uv[1][1]],
                uv2: [uv[2][0], uv[2][1], 0.0, 0.0],
                ..Default::default()
            }
        })
        .collect();
    // emitters: front triangles of emitting faces, weighted by luminance x area
    let mut lights: Vec<[f32; 2]> = Vec::new();
    let mut total = 0.0f32;
    for (i, t) in triangles.iter().enumerate() {
        let le = luminance(faces[t.face as usize].emission);
        let area = 0.5 * Vec3::from(t.e1).cross(Vec3::from(t.e2)).length();
        if le > 0.0 && area > 0.0 {
            total += le * area;
            lights.push([f32::from_bits(i as u32), total]);
        }
    }
    // textures, texel arrays back to back
    let mut texture_info: Vec<[u32; 4]> = Vec::new();
    let mut texels: Vec<[f32; 4]> = Vec::new();
    for t in &scene.textures {
        texture_info.push([texels.len() as u32, t.width, t.height, 0]);
        texels.extend(t.texels.iter().map(|c| [c[0], c[1], c[2], 1.0]));
    }
    let face_textures: Vec<[u32; 4]> = prepared
        .faces
        .iter()
        .map(|f| {
            let m = &scene.materials[f.material as usize];
            [
                m.diffuse_texture.unwrap_or(NO_FACE),
                m.emission_texture.unwrap_or(NO_FACE),
                0,
                0,
            ]
        })
        .collect();
    let [width, height] = size;
    let vp = crate::render::view_projection(camera, &prepared.normalisation, width, height);
    let eye = prepared.normalisation.to_unit(camera.eye).as_vec3();
    let sky = scene.sky.unwrap_or([0.0; 3]);
    let samples_per_pass = 4u32.min(spp);
    let passes = spp.div_ceil(samples_per_pass);
    let spp = passes * samples_per_pass;

    let ledger = MemoryLedger::default();
    let device = &ctx.device;
    let params_buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("trace parameters"),
        size: std::mem::size_of::<GpuTraceParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let buffers = [
        ctx.buffer_init(
            &ledger,
            "triangles",
            bytemuck::cast_slice(&triangles),
            STORAGE,
        ),
        ctx.buffer_init(&ledger, "bvh", bytemuck::cast_slice(&nodes), STORAGE),
        ctx.buffer_init(&ledger, "faces", bytemuck::cast_slice(&faces), STORAGE),
        ctx.buffer_init(
            &ledger,
            "face textures",
            bytemuck::cast_slice(&face_textures),
            STORAGE,
        ),
        ctx.buffer_init(
            &ledger,
            "texture info",
            bytemuck::cast_slice(&texture_info),
            STORAGE,
        ),
        ctx.buffer_init(&ledger, "texels", bytemuck::cast_slice(&texels), STORAGE),
        ctx.buffer_init(&ledger, "lights", bytemuck::cast_slice(&lights), STORAGE),
        ctx.buffer_zeroed(&ledger, "sums", width as u64 * height as u64 * 32, STORAGE),
    ];
    let layout = reflect::layout(device, "reference.wgsl", 0)?;
    let module = shaders::module(device, "reference.wgsl")?;
    let pipeline = ctx.compute_pipeline(&module, "trace_pass", &[&layout]);
    let mut all: Vec<&wgpu::Buffer> = vec![&params_buffer];
    all.extend(buffers.iter());
    let bind_group = ctx.bind_group(&layout, &all);

    let bar = if progress {
        indicatif::ProgressBar::new(passes as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {elapsed_precise} [{bar:40}] {pos}/{len} passes ({msg})",
        )
        .unwrap()
        .progress_chars("=> "),
    );
    bar.set_message(format!("{spp} spp at {width}x{height}"));
    let setup_seconds = started.elapsed().as_secs_f64();
    let tracing = std::time::Instant::now();
    for pass_index in 0..passes {
        let params = GpuTraceParams {
            inv_view_proj: vp.inverse().to_cols_array_2d(),
            eye: eye.into(),
            width,
            sky,
            height,
            samples_per_pass,
            pass_index,
            seed,
            light_count: lights.len() as u32,
            light_weight_total: total.max(1e-30),
            _pad: [0; 3],
        };
        ctx.queue
            .write_buffer(&params_buffer, 0, bytemuck::bytes_of(&params));
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait()?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let sums: Vec<[f32; 4]> = ctx.read_buffer(&buffers[7], width as u64 * height as u64 * 32)?;
    let n = spp as f32;
    let mut mean = Vec::with_capacity((width * height) as usize);
    let mut variance = Vec::with_capacity((width * height) as usize);
    for px in sums.chunks(2) {
        let m: [f32; 3] = std::array::from_fn(|c| px[0][c] / n);
        let v: [f32; 3] = std::array::from_fn(|c| ((px[1][c] / n - m[c] * m[c]).max(0.0)) / n);
        mean.push([m[0], m[1], m[2], 1.0]);
        variance.push([v[0], v[1], v[2], 1.0]);
    }
    Ok(Reference {
        mean: Frame {
            width,
            height,
            pixels: mean,
        },
        variance: Frame {
            width,
            height,
            pixels: variance,
        },
        spp,
        seconds: tracing.elapsed().as_secs_f64(),
        setup_seconds,
    })
}
