//! Moving objects on the GPU (`shaders/moving.wgsl`): their rest-pose mesh (`crate::dynamic`)
//! uploaded once with a tree built over it, and every frame the joint matrices, then three
//! passes: skin the vertices, write each triangle's affine map and shading record, refit the
//! tree level by level. The renderer's triangle and pair buffers hold the scene's first and the
//! moving objects' after them, so its ray casting reaches both (`common/scene_cast.wgsl`).

use crate::bvh::{bvh_pairs, GpuBvhPair, GpuTriangle};
use crate::dynamic::MovingMesh;
use crate::error::{Result, VlfError};
use crate::gpu::types::{
    GpuMovingMaterial, GpuMovingParams, GpuMovingTriangle, GpuMovingVertex, GpuRayTriangle,
};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use crate::prepare::Normalisation;
use glam::{DMat4, DVec3, Mat4, Vec3};

/// The face id the renderer's triangle records give moving triangles (`MOVING_FACE` in
/// common/scene_cast.wgsl).
pub const MOVING_FACE: u32 = 0xffff_fff0;

/// A box no ray enters (bvh::bvh_pairs' "never"; `NEVER` in moving.wgsl).
const NEVER: [f32; 3] = [f32::MAX / 2.0; 3];

/// The moving part of the renderer's buffers, planned before they are made: the tree's pairs
/// (references already counted from `first_pair` and `first_triangle`), each triangle's corners
/// and material in the tree's order, and the refit's order.
pub struct MovingPlan {
    pub first_triangle: u32,
    pub first_pair: u32,
    pub pairs: Vec<GpuBvhPair>,
    /// the records the renderer's `triangles` buffer gets for them (face MOVING_FACE)
    pub records: Vec<GpuTriangle>,
    /// affine maps no ray meets, until the first frame poses them
    pub maps: Vec<GpuRayTriangle>,
    /// [corner, corner, corner, material] per triangle, tree order
    corners: Vec<[u32; 4]>,
    /// pair indices, deepest level first, and each level's [first, count]
    refit_order: Vec<u32>,
    levels: Vec<[u32; 2]>,
    /// the most pairs from the root to a leaf (the traversal's stack)
    pub depth: u32,
}

impl MovingPlan {
    /// The tree over `mesh`'s rest pose, each object moved far from the others first so that the
    /// tree's top splits them apart (they move independently; a refit keeps the topology).
    pub fn new(mesh: &MovingMesh, first_triangle: u32, first_pair: u32) -> Result<MovingPlan> {
        let apart = |i: usize| Vec3::X * 1.0e4 * mesh.triangle_object[i] as f32;
        let corners: Vec<[Vec3; 3]> = (mesh.corners().into_iter().enumerate())
            .map(|(i, c)| c.map(|p| p + apart(i)))
            .collect();
        let total = first_triangle as usize + corners.len();
        if total >= crate::bvh::MAX_PAIR_REFERENCE {
            return Err(VlfError::Parameter {
                name: "objects",
                message: format!("{total} triangles with the moving objects' : the renderer casts through at most {}", crate::bvh::MAX_PAIR_REFERENCE - 1),
            });
        }
        let (nodes, order) = crate::bvh::build_bvh(&corners);
        let tree = bvh_pairs(&nodes).ok_or_else(|| VlfError::Parameter {
            name: "objects",
            message: "the moving objects have no triangle".into(),
        })?;
        let shift = |r: u32| -> u32 {
            if r & 31 == 0 {
                ((r >> 5) + first_pair) << 5
            } else {
                (((r >> 5) + first_triangle) << 5) | (r & 31)
            }
        };
        let pairs: Vec<GpuBvhPair> = (tree.pairs.iter())
            .map(|p| GpuBvhPair {
                left: shift(p.left),
                right: shift(p.right),
                lo_left: NEVER,
                hi_left: NEVER,
                lo_right: NEVER,
                hi_right: NEVER,
                ..Default::default()
            })
            .collect();
        let (refit_order, levels) = refit_levels(&tree.pairs, first_pair);
        let corners = (order.iter())
            .map(|&t| {
                let [a, b, c] = mesh.triangles[t as usize];
                [a, b, c, mesh.triangle_material[t as usize]]
            })
            .collect::<Vec<_>>();
        let unused = GpuRayTriangle {
            u: [0.0, 0.0, 0.0, -1.0],
            v: [0.0; 4],
            w: [0.0, 0.0, 0.0, 1.0],
        };
        Ok(MovingPlan {
            first_triangle,
            first_pair,
            records: vec![
                GpuTriangle {
                    face: MOVING_FACE,
                    ..Default::default()
                };
                corners.len()
            ],
            maps: vec![unused; corners.len()],
            pairs,
            corners,
            refit_order,
            levels,
            depth: tree.depth,
        })
    }
}

/// The pairs of a tree grouped by level, deepest first (a pair's children are refitted before
/// it), as global pair indices, and each level's [first, count] in that order.
fn refit_levels(pairs: &[GpuBvhPair], first_pair: u32) -> (Vec<u32>, Vec<[u32; 2]>) {
    let mut by_level: Vec<Vec<u32>> = vec![vec![0]];
    loop {
        let next: Vec<u32> = (by_level.last().into_iter().flatten())
            .flat_map(|&p| [pairs[p as usize].left, pairs[p as usize].right])
            .filter(|r| r & 31 == 0)
            .map(|r| r >> 5)
            .collect();
        if next.is_empty() {
            break;
        }
        by_level.push(next);
    }
    let mut order = Vec::new();
    let mut levels = Vec::new();
    for level in by_level.iter().rev() {
        levels.push([order.len() as u32, level.len() as u32]);
        order.extend(level.iter().map(|p| p + first_pair));
    }
    (order, levels)
}

/// The moving objects' GPU state: pipelines, buffers, the refit's levels.
pub struct MovingObjects {
    skin: wgpu::ComputePipeline,
    triangles: wgpu::ComputePipeline,
    refit: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    /// one bind group per level of the tree (its [first, count]), deepest first
    levels: Vec<(wgpu::BindGroup, u32)>,
    joints: wgpu::Buffer,
    joint_count: u32,
    pub vertex_count: u32,
    triangle_count: u32,
    normalisation: Normalisation,
    /// what the renderer's shading group reads: each triangle's normals and material, the table,
    /// each triangle's corners and material (tree order)
    pub shading: wgpu::Buffer,
    pub materials: wgpu::Buffer,
    pub corners: wgpu::Buffer,
    /// the skinned vertices and normals (the vertices' light pass reads them)
    pub posed: wgpu::Buffer,
    pub posed_normals: wgpu::Buffer,
    pub root_pair: u32,
    pub first_triangle: u32,
}

impl MovingObjects {
    /// Upload `mesh` as `plan` placed it in the renderer's `ray_triangles` and `pairs`.
    pub fn new(
        ctx: &GpuContext,
        ledger: &MemoryLedger,
        mesh: &MovingMesh,
        plan: &MovingPlan,
        (ray_triangles, pairs): (&wgpu::Buffer, &wgpu::Buffer),
        normalisation: Normalisation,
    ) -> Result<MovingObjects> {
        let device = &ctx.device;
        let module = shaders::module(device, "moving.wgsl")?;
        let layout = reflect::layout(device, "moving.wgsl", 0)?;
        let level_layout = reflect::layout(device, "moving.wgsl", 1)?;
        let pipeline = |entry| ctx.compute_pipeline(&module, entry, &[&layout, &level_layout]);
        let vertices: Vec<GpuMovingVertex> = (mesh.vertices.iter())
            .map(|v| GpuMovingVertex {
                position: v.position.extend(1.0).into(),
                normal: v.normal.extend(0.0).into(),
                joints: v.joints,
                weights: v.weights,
            })
            .collect();
        let params = GpuMovingParams {
            vertex_count: vertices.len() as u32,
            triangle_count: plan.corners.len() as u32,
            first_triangle: plan.first_triangle,
            first_pair: plan.first_pair,
        };
        let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let params_buffer = ctx.buffer_init(
            ledger,
            "moving: counts",
            bytemuck::bytes_of(&params),
            uniform,
        );
        let init = |name, bytes: &[u8]| ctx.buffer_init(ledger, name, bytes, STORAGE);
        let rest = init("moving: rest pose", bytemuck::cast_slice(&vertices));
        let joint_count = mesh.joint_count.max(1);
        let joints = init(
            "moving: joint matrices",
            bytemuck::cast_slice(&vec![[0f32; 16]; joint_count as usize]),
        );
        let posed = init("moving: posed", &vec![0u8; vertices.len() * 16]);
        let normals = init("moving: posed normals", &vec![0u8; vertices.len() * 16]);
        let corners = init("moving: corners", bytemuck::cast_slice(&plan.corners));
        let shading = init(
            "moving: triangle normals",
            bytemuck::cast_slice(&vec![GpuMovingTriangle::default(); plan.corners.len()]),
        );
        let table: Vec<GpuMovingMaterial> = (mesh.materials.iter())
            .map(|m| GpuMovingMaterial {
                albedo: [m.albedo[0], m.albedo[1], m.albedo[2], 0.0],
                emission: [m.emission[0], m.emission[1], m.emission[2], 0.0],
            })
            .collect();
        let materials = init("moving: materials", bytemuck::cast_slice(&table));
        let order = init(
            "moving: refit order",
            bytemuck::cast_slice(&plan.refit_order),
        );
        let group = ctx.bind_group(
            &layout,
            &[
                &params_buffer,
                &rest,
                &joints,
                &posed,
                &normals,
                &corners,
                ray_triangles,
                &shading,
                pairs,
                &order,
            ],
        );
        let levels = (plan.levels.iter())
            .map(|&[first, count]| {
                let range = [first, count, 0, 0];
                let b =
                    ctx.buffer_init(ledger, "moving: level", bytemuck::bytes_of(&range), uniform);
                (ctx.bind_group(&level_layout, &[&b]), count)
            })
            .collect();
        Ok(MovingObjects {
            skin: pipeline("skin"),
            triangles: pipeline("triangles"),
            refit: pipeline("refit"),
            levels,
            group,
            joints,
            joint_count,
            vertex_count: params.vertex_count,
            triangle_count: params.triangle_count,
            normalisation,
            shading,
            materials,
            corners,
            posed,
            posed_normals: normals,
            root_pair: plan.first_pair,
            first_triangle: plan.first_triangle,
        })
    }

    /// This frame's joint matrices (world metres from rest; zero for a hidden object's), moved
    /// into the light field's normalised space.
    pub fn set_joints(&self, queue: &wgpu::Queue, world: &[Mat4]) {
        let n = &self.normalisation;
        let to_unit = DMat4::from_scale(DVec3::splat(n.scale))
            * DMat4::from_translation(-DVec3::from(n.center));
        let unit: Vec<[f32; 16]> = (0..self.joint_count as usize)
            .map(|i| {
                let m = world.get(i).copied().unwrap_or(Mat4::ZERO);
                if m == Mat4::ZERO {
                    [0.0; 16]
                } else {
                    (to_unit * m.as_dmat4()).as_mat4().to_cols_array()
                }
            })
            .collect();
        queue.write_buffer(&self.joints, 0, bytemuck::cast_slice(&unit));
    }

    /// Skin, write the triangles and refit: one compute pass of 2 + levels dispatches, and
    /// `then` what follows in the same pass (the shadow atlas, `render::shadow_atlas`).
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<&mut crate::gpu::Timestamps>,
        then: Option<impl FnOnce(&mut wgpu::ComputePass<'_>)>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("moving objects"),
            timestamp_writes: timestamps.and_then(|t| t.compute_writes()),
        });
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_bind_group(1, &self.levels[0].0, &[]);
        pass.set_pipeline(&self.skin);
        pass.dispatch_workgroups(self.vertex_count.div_ceil(64), 1, 1);
        pass.set_pipeline(&self.triangles);
        pass.dispatch_workgroups(self.triangle_count.div_ceil(64), 1, 1);
        pass.set_pipeline(&self.refit);
        for (group, count) in &self.levels {
            pass.set_bind_group(1, group, &[]);
            pass.dispatch_workgroups(count.div_ceil(64), 1, 1);
        }
        if let Some(then) = then {
            then(&mut pass);
        }
    }
}
