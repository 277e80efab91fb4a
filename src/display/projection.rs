//! Off-axis projection for a wall seen from an eye: Kooima, "Generalized Perspective
//! Projection" (2008). The screen is given by three corners; the frustum from the eye through
//! the screen's edges is asymmetric whenever the eye is not on the screen's centre axis.

use glam::{Mat4, Vec3};

/// Frustum extents at the near plane and the view-projection of a wall for an eye. Corners and
/// eye are in one space (any similarity of world space keeps the projection the same).
#[derive(Clone, Copy, Debug)]
pub struct OffAxis {
    pub left: f32,
    pub right: f32,
    pub bottom: f32,
    pub top: f32,
    pub near: f32,
    pub far: f32,
    pub view_proj: Mat4,
}

pub fn off_axis(
    lower_left: Vec3,
    lower_right: Vec3,
    upper_left: Vec3,
    eye: Vec3,
    near: f32,
    far: f32,
) -> OffAxis {
    let vr = (lower_right - lower_left).normalize();
    let vu = (upper_left - lower_left).normalize();
    let vn = vr.cross(vu).normalize();
    let (va, vb, vc) = (lower_left - eye, lower_right - eye, upper_left - eye);
    // distance from the eye to the screen plane
    let d = -va.dot(vn);
    let scale = near / d;
    let (left, right) = (vr.dot(va) * scale, vr.dot(vb) * scale);
    let (bottom, top) = (vu.dot(va) * scale, vu.dot(vc) * scale);
    let projection = Mat4::frustum_rh(left, right, bottom, top, near, far);
    // rotate the screen's basis onto the axes, then move the eye to the origin
    let basis = Mat4::from_cols(
        vr.extend(0.0),
        vu.extend(0.0),
        vn.extend(0.0),
        glam::Vec4::W,
    )
    .transpose();
    let view_proj = projection * basis * Mat4::from_translation(-eye);
    OffAxis {
        left,
        right,
        bottom,
        top,
        near,
        far,
        view_proj,
    }
}

/// Where a world point lands on a wall's image, in pixels from the top-left (None behind).
pub fn project_to_pixel(view_proj: Mat4, p: Vec3, pixels: [u32; 2]) -> Option<(f32, f32)> {
    let clip = view_proj * p.extend(1.0);
    if clip.w <= 0.0 {
        return None;
    }
    let ndc = clip.truncate() / clip.w;
    Some((
        (ndc.x + 1.0) * 0.5 * pixels[0] as f32,
        (1.0 - ndc.y) * 0.5 * pixels[1] as f32,
    ))
}
