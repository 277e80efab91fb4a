//! Where a world-placed object is at time t: its keyframes interpolated (position linearly,
//! orientation by spherical interpolation), held after the last or repeated.

use super::config::ObjectKeyframe;
use crate::tracking::pose::head_rotation_from_angles;
use glam::{Affine3A, Vec3};

/// The placement of keyframe `k` (its orientation as the head's angles are read).
fn placement(k: &ObjectKeyframe) -> (Vec3, glam::Quat) {
    (
        Vec3::from(k.position),
        head_rotation_from_angles(k.yaw_deg, k.pitch_deg, k.roll_deg),
    )
}

/// The keyframes' placement at `t` seconds (`keys` non-empty, times increasing): before the
/// first the first, after the last the last (or, with `repeat`, t modulo the last time).
pub fn keyframed(keys: &[ObjectKeyframe], t: f64, repeat: bool) -> Affine3A {
    let (first, last) = (keys[0], keys[keys.len() - 1]);
    let mut t = t as f32;
    if repeat && last.t > first.t && t > last.t {
        t = first.t + (t - first.t).rem_euclid(last.t - first.t);
    }
    let after = keys.partition_point(|k| k.t <= t);
    let (position, rotation) = if after == 0 {
        placement(&first)
    } else if after == keys.len() {
        placement(&last)
    } else {
        let (a, b) = (&keys[after - 1], &keys[after]);
        let s = (t - a.t) / (b.t - a.t);
        let ((pa, ra), (pb, rb)) = (placement(a), placement(b));
        (pa.lerp(pb, s), ra.slerp(rb, s))
    };
    Affine3A::from_rotation_translation(rotation, position)
}
