//! The light field: converged outgoing radiance of every diffuse element, the face records
//! that say where each face's texels are, and what rendering needs besides (the render mesh,
//! cameras, normalisation). `LightField` is the CPU copy that `.vlf` files hold (`file.rs`);
//! `ResidentLightField` is the GPU-resident one that views are drawn from.

pub mod atlas_lookup;
pub mod bindings;
pub mod directions;
pub mod file;
pub mod normal_map;
pub mod textures;
pub mod tiles;

use crate::gpu::types::{GpuFace, GpuMaterial, RenderVertex};
use crate::gpu::{GpuContext, MemoryLedger, STORAGE};
use crate::params::PropagationParams;
use crate::prepare::{Normalisation, PreparedScene};
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
    /// the material table the faces index (`crate::material`)
    pub materials: Vec<GpuMaterial>,
    pub render_vertices: Vec<RenderVertex>,
    /// outgoing radiance per texel (rgb, w unused)
    pub total: Vec<[f32; 4]>,
    /// mirror radiance, for scenes with non-diffuse faces
    pub tiles: Option<TileField>,
    /// the diffuse textures at full resolution, for scenes that have them (`textures`)
    pub detail: Option<textures::SurfaceDetail>,
}

/// The view-dependent part: tile tables and converged mirror radiance per tile cell.
#[derive(Clone, Debug, PartialEq)]
pub struct TileField {
    pub rects: Vec<[u32; 4]>,
    pub index: Vec<u32>,
    pub total: Vec<[f32; 4]>,
    /// number of non-diffuse faces (rects hold one entry per direction and such face)
    pub face_count: u32,
}

impl TileField {
    pub fn bytes(&self) -> u64 {
        (self.rects.len() * 16 + self.index.len() * 4 + self.total.len() * 16) as u64
    }
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
            out.push(RenderVertex {
                position: [p.x as f32, p.y as f32, p.z as f32],
                face: t.face,
            });
        }
    }
    out
}

/// How rendering treats mirrors (shaders/render.wgsl): it follows each eye ray through `bounces`
/// reflections by ray tracing; where a chain of mirrors can be longer than that (mirrors that
/// face each other), the chain ends in the mirror tiles, which then stay resident.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct MirrorChains {
    pub bounces: u32,
    pub tiles_needed: bool,
}

/// Reflections traced per eye ray where mirrors face each other (then the tiles end the chain).
pub const FACING_MIRROR_BOUNCES: u32 = 2;
/// Above this many mirror faces the pairwise test is skipped and mirrors are taken to face
/// each other.
const MIRROR_PAIR_LIMIT: usize = 4096;

impl MirrorChains {
    /// From the faces and the render mesh: a reflected ray can reach mirror B from mirror A only
    /// if part of B lies in front of A and part of A in front of B. Without such a pair one
    /// reflection is exact, and the tiles are not needed to render.
    pub fn of(
        faces: &[GpuFace],
        materials: &[GpuMaterial],
        vertices: &[RenderVertex],
    ) -> MirrorChains {
        let mirror = |f: &GpuFace| crate::material::material_of(materials, f).is_delta();
        let mirrors: Vec<usize> = (0..faces.len()).filter(|&i| mirror(&faces[i])).collect();
        if mirrors.is_empty() {
            return MirrorChains {
                bounces: 0,
                tiles_needed: false,
            };
        }
        let facing = MirrorChains {
            bounces: FACING_MIRROR_BOUNCES,
            tiles_needed: true,
        };
        if mirrors.len() > MIRROR_PAIR_LIMIT {
            return facing;
        }
        // corners per face (a two-sided surface's back shares its front's)
        let mut corners: Vec<Vec<glam::Vec3>> = vec![Vec::new(); faces.len()];
        for v in vertices {
            corners[v.face as usize].push(glam::Vec3::from(v.position));
        }
        for (i, f) in faces.iter().enumerate() {
            if f.twin != crate::gpu::types::NO_FACE && corners[i].is_empty() {
                corners[i] = corners[f.twin as usize].clone();
            }
        }
        let in_front = |a: usize, b: usize| {
            let n = glam::Vec3::from(faces[a].normal);
            corners[b]
                .iter()
                .any(|p| n.dot(*p) - faces[a].plane_offset > 1e-5)
        };
        for (k, &a) in mirrors.iter().enumerate() {
            for &b in &mirrors[k + 1..] {
                if in_front(a, b) && in_front(b, a) {
                    return facing;
                }
            }
        }
        MirrorChains {
            bounces: 1,
            tiles_needed: false,
        }
    }
}

impl LightField {
    pub fn mirror_chains(&self) -> MirrorChains {
        MirrorChains::of(&self.faces, &self.materials, &self.render_vertices)
    }

    pub fn camera(&self, name: Option<&str>) -> crate::error::Result<&Camera> {
        let err = |n: &str| crate::error::VlfError::UnknownCamera {
            name: n.to_string(),
            available: self
                .meta
                .cameras
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        };
        match name {
            None => self.meta.cameras.first().ok_or_else(|| err("(default)")),
            Some(n) => self
                .meta
                .cameras
                .iter()
                .find(|c| c.name == n)
                .ok_or_else(|| err(n)),
        }
    }

    /// Upload for rendering.
    pub fn upload(&self, ctx: Arc<GpuContext>) -> crate::error::Result<ResidentLightField> {
        let ledger = MemoryLedger::default();
        let limits = ctx.limits();
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let texel_pages = tiles::TilePages::plan_texels(self.total.len() as u64, max_binding)?;
        let faces = ctx.buffer_init(&ledger, "faces", bytemuck::cast_slice(&self.faces), STORAGE);
        let materials = ctx.buffer_init(
            &ledger,
            "materials",
            bytemuck::cast_slice(&self.materials),
            STORAGE,
        );
        let total = texel_pages
            .ranges()
            .iter()
            .map(|&(first, n)| {
                ctx.buffer_init(
                    &ledger,
                    "total radiance",
                    bytemuck::cast_slice(&self.total[first as usize..(first + n) as usize]),
                    STORAGE,
                )
            })
            .collect();
        // tiles only where rendering reads them (mirrors facing each other)
        let tiles = match self
            .tiles
            .as_ref()
            .filter(|_| self.mirror_chains().tiles_needed)
        {
            None => None,
            Some(t) => {
                let cells_per_tile = self.meta.params.tile_size * self.meta.params.tile_size;
                let pages =
                    tiles::TilePages::plan(t.total.len() as u64, cells_per_tile, max_binding)?;
                let set = directions::DirectionSet::geodesic(self.meta.params.geodesic_frequency);
                let (points, index) = set.gpu_tables();
                let dirs = directions::gpu_directions(&set.directions);
                Some(ResidentTiles {
                    rects: ctx.buffer_init(
                        &ledger,
                        "tile rectangles",
                        bytemuck::cast_slice(&t.rects),
                        STORAGE,
                    ),
                    index: ctx.buffer_init(
                        &ledger,
                        "tile index",
                        bytemuck::cast_slice(&t.index),
                        STORAGE,
                    ),
                    radiance: pages
                        .ranges()
                        .iter()
                        .map(|&(first, n)| {
                            let cells = &t.total[first as usize..(first + n) as usize];
                            ctx.buffer_init(
                                &ledger,
                                "mirror tiles: total radiance",
                                bytemuck::cast_slice(cells),
                                STORAGE,
                            )
                        })
                        .collect(),
                    pages,
                    geodesic_points: ctx.buffer_init(
                        &ledger,
                        "geodesic tables",
                        bytemuck::cast_slice(&points),
                        STORAGE,
                    ),
                    geodesic_index: ctx.buffer_init(
                        &ledger,
                        "geodesic index",
                        bytemuck::cast_slice(&index),
                        STORAGE,
                    ),
                    directions: ctx.buffer_init(
                        &ledger,
                        "directions",
                        bytemuck::cast_slice(&dirs),
                        STORAGE,
                    ),
                })
            }
        };
        let mut resident = ResidentLightField {
            ctx,
            faces,
            materials,
            total,
            texel_pages,
            tiles,
            ledger,
            detail: None,
        };
        resident.upload_detail(self);
        Ok(resident)
    }
}

/// The light field on the GPU: all that rendering binds.
pub struct ResidentLightField {
    pub ctx: Arc<GpuContext>,
    pub faces: wgpu::Buffer,
    /// the material table the faces index (`crate::material`)
    pub materials: wgpu::Buffer,
    /// converged radiance per texel, in pages of at most one binding
    pub total: Vec<wgpu::Buffer>,
    pub texel_pages: tiles::TilePages,
    /// the view-dependent part; None for a diffuse-only scene
    pub tiles: Option<ResidentTiles>,
    pub ledger: MemoryLedger,
    /// the textures at full resolution; None for a scene without diffuse textures, or where
    /// they exceed a storage binding of the device (then views show them at texel resolution)
    pub detail: Option<textures::ResidentDetail>,
}

impl ResidentLightField {
    /// Upload `lf`'s texture detail, where it has any: a device that cannot bind it draws the
    /// textures at texel resolution, and says so once.
    pub fn upload_detail(&mut self, lf: &LightField) {
        let Some(detail) = &lf.detail else {
            return;
        };
        match detail.upload(&self.ctx, &self.ledger) {
            Ok(d) => self.detail = Some(d),
            Err(why) => log::warn!("textures are drawn at texel resolution: {why}"),
        }
    }
}

pub struct ResidentTiles {
    pub rects: wgpu::Buffer,
    pub index: wgpu::Buffer,
    /// converged mirror radiance per tile cell, in pages of at most one binding
    pub radiance: Vec<wgpu::Buffer>,
    pub pages: tiles::TilePages,
    pub geodesic_points: wgpu::Buffer,
    pub geodesic_index: wgpu::Buffer,
    pub directions: wgpu::Buffer,
}
