//! CPU twin of `shaders/common/atlas.wgsl`: the four texels around a point on a face and
//! their bilinear weights.

use crate::gpu::types::GpuFace;
use glam::Vec3;

pub struct AtlasTaps {
    pub index: [u32; 4],
    pub weight: [f32; 4],
}

pub fn atlas_taps(f: &GpuFace, p: Vec3, atlas_width: u32) -> AtlasTaps {
    let d = p - Vec3::from(f.origin);
    let s =
        (d.dot(Vec3::from(f.axis_a)) * f.texel_density - 0.5).clamp(0.0, (f.atlas_w - 1) as f32);
    let t =
        (d.dot(Vec3::from(f.axis_b)) * f.texel_density - 0.5).clamp(0.0, (f.atlas_h - 1) as f32);
    let (s0, t0) = (s.floor(), t.floor());
    let (fs, ft) = (s - s0, t - t0);
    let (x0, y0) = (s0 as u32, t0 as u32);
    let x1 = (x0 + 1).min(f.atlas_w - 1);
    let y1 = (y0 + 1).min(f.atlas_h - 1);
    let row0 = (f.atlas_y + y0) * atlas_width + f.atlas_x;
    let row1 = (f.atlas_y + y1) * atlas_width + f.atlas_x;
    AtlasTaps {
        index: [row0 + x0, row0 + x1, row1 + x0, row1 + x1],
        weight: [
            (1.0 - fs) * (1.0 - ft),
            fs * (1.0 - ft),
            (1.0 - fs) * ft,
            fs * ft,
        ],
    }
}
