//! GPU structs, defined once here with `#[repr(C)]` + bytemuck. Each names the WGSL struct in
//! `shaders/common/types.wgsl` that it mirrors; `tests/shaders.rs` checks that sizes agree.

use bytemuck::{Pod, Zeroable};

pub const NO_FACE: u32 = u32::MAX;
pub const FACE_EMITTER: u32 = 1;

/// Mirrors WGSL `Direction`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuDirection {
    pub w: [f32; 3],
    pub solid_angle: f32,
    pub u: [f32; 3],
    pub _pad0: f32,
    pub v: [f32; 3],
    pub _pad1: f32,
}

/// Mirrors WGSL `Face`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuFace {
    pub normal: [f32; 3],
    pub plane_offset: f32,
    pub origin: [f32; 3],
    pub texel_density: f32,
    pub axis_a: [f32; 3],
    pub kappa: f32,
    pub axis_b: [f32; 3],
    pub flags: u32,
    pub albedo: [f32; 3],
    pub atlas_x: u32,
    pub emission: [f32; 3],
    pub atlas_y: u32,
    pub atlas_w: u32,
    pub atlas_h: u32,
    pub twin: u32,
    pub _pad: u32,
}

/// Mirrors WGSL `GridParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuGrid {
    pub resolution: u32,
    pub direction_count: u32,
    pub triangle_count: u32,
    pub triangle_base: u32,
    pub texel_count: u32,
    pub atlas_width: u32,
    pub iteration: u32,
    pub flags: u32,
    pub sky: [f32; 3],
    pub cell_size: f32,
    pub depth_epsilon: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

pub const GRID_FLAG_SKY: u32 = 1;

/// Mirrors WGSL `View`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuView {
    pub view_proj: [[f32; 4]; 4],
    pub sky: [f32; 4],
    pub atlas_width: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// Render vertex: position in normalised scene space and the face it belongs to.
/// Matches the vertex layout of `vs_main` in `shaders/render.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RenderVertex {
    pub position: [f32; 3],
    pub face: u32,
}

/// Every mirrored pair: (Rust name, WGSL name, Rust size).
pub fn mirrored_structs() -> [(&'static str, &'static str, usize); 4] {
    [
        ("GpuDirection", "Direction", std::mem::size_of::<GpuDirection>()),
        ("GpuFace", "Face", std::mem::size_of::<GpuFace>()),
        ("GpuGrid", "GridParams", std::mem::size_of::<GpuGrid>()),
        ("GpuView", "View", std::mem::size_of::<GpuView>()),
    ]
}
