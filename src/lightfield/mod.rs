//! The light field: converged outgoing radiance of every diffuse element, the face records
//! that say where each face's texels are, and what rendering needs besides (the render mesh,
//! cameras, normalisation). `LightField` is the CPU copy that `.vlf` files hold (`file.rs`);
//! `ResidentLightField` is the GPU-resident one that views are drawn from.

pub mod atlas_lookup;
pub mod directions;
pub mod file;

use crate::gpu::types::{GpuFace, RenderVertex};
use crate::gpu::{GpuContext, MemoryLedger, STORAGE};
use crate::prepare::{Normalisation, PreparedScene};
use crate::propagate::PropagationParams;
use crate::scene::Camera;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LightFieldMeta {
    pub vlf_version: String,
    pub scene_name: String,
    pub scene_hash: String,
    pub params: PropagationParams,
    pub direction_count: u32,
    pub normalisation: Normalisation,
    pub sky: Option<[f32; 3]>,
    pub cameras: Vec<Camera>,
    pub atlas_width: u32,
    pub atlas_height: u32,
    pub iterations: u32,
    pub residual: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct LightField {
    pub meta: LightFieldMeta,
    pub faces: Vec<GpuFace>,
    pub render_vertices: Vec<RenderVertex>,
    /// outgoing radiance per texel (rgb, w unused)
    pub total: Vec<[f32; 4]>,
}

/// Front-side triangles, three vertices each; back sides of two-sided faces are drawn through
/// their twin when a fragment is back-facing.
pub fn render_vertices(prepared: &PreparedScene) -> Vec<RenderVertex> {
    let mut out = Vec::with_capacity(prepared.triangles.len() * 3);
    for t in &prepared.triangles {
        if prepared.faces[t.face as usize].is_back {
            continue;
        }
        for v in t.vertices {
            let p = prepared.positions[v as usize];
            out.push(RenderVertex { position: [p.x as f32, p.y as f32, p.z as f32], face: t.face });
        }
    }
    out
}

impl LightField {
    pub fn camera(&self, name: Option<&str>) -> crate::error::Result<&Camera> {
        let err = |n: &str| crate::error::VlfError::UnknownCamera {
            name: n.to_string(),
            available: self.meta.cameras.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", "),
        };
        match name {
            None => self.meta.cameras.first().ok_or_else(|| err("(default)")),
            Some(n) => self.meta.cameras.iter().find(|c| c.name == n).ok_or_else(|| err(n)),
        }
    }

    /// Upload for rendering.
    pub fn upload(&self, ctx: Arc<GpuContext>) -> ResidentLightField {
        let ledger = MemoryLedger::default();
        let faces = ctx.buffer_init(&ledger, "faces", bytemuck::cast_slice(&self.faces), STORAGE);
        let total = ctx.buffer_init(&ledger, "total radiance", bytemuck::cast_slice(&self.total), STORAGE);
        ResidentLightField { ctx, faces, total, ledger }
    }
}

/// The light field on the GPU: all that rendering binds.
pub struct ResidentLightField {
    pub ctx: Arc<GpuContext>,
    pub faces: wgpu::Buffer,
    pub total: wgpu::Buffer,
    pub ledger: MemoryLedger,
}
