//! Analytic two-bone inverse kinematics (shoulder -> elbow -> wrist) and the rotation that
//! turns a bone from its bind direction to a posed one with a controlled twist.

use glam::{Mat3, Quat, Vec3};

/// Where the elbow and the wrist go for a chain rooted at `shoulder` with bone lengths `upper`
/// and `lower`, reaching for `target`, the elbow bent towards `pole` (a direction).
///
/// A reachable target is met exactly; one beyond reach gets a straight chain pointing at it;
/// one closer than `|upper - lower|` gets the wrist as near as the chain allows, on the line
/// towards it.
pub fn two_bone(shoulder: Vec3, upper: f32, lower: f32, target: Vec3, pole: Vec3) -> (Vec3, Vec3) {
    let to = target - shoulder;
    let distance = to.length();
    let dir = if distance > 1e-6 {
        to / distance
    } else {
        perpendicular(pole, Vec3::X).unwrap_or(Vec3::NEG_Y)
    };
    if distance >= upper + lower {
        return (shoulder + dir * upper, shoulder + dir * (upper + lower));
    }
    let d = distance.max((upper - lower).abs()).max(1e-6);
    let cos = ((upper * upper + d * d - lower * lower) / (2.0 * upper * d)).clamp(-1.0, 1.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let bend = reference(pole, dir);
    let elbow = shoulder + upper * (cos * dir + sin * bend);
    (elbow, shoulder + dir * d)
}

/// `v`'s part perpendicular to the unit `axis`, normalised (None when `v` is along `axis`).
pub fn perpendicular(v: Vec3, axis: Vec3) -> Option<Vec3> {
    (v - axis * v.dot(axis)).try_normalize()
}

/// A unit direction perpendicular to the unit `axis`: the pole's perpendicular part, or, when
/// the pole lies along the axis, back (-z), then up (+y), then +x.
pub fn reference(pole: Vec3, axis: Vec3) -> Vec3 {
    [pole, Vec3::NEG_Z, Vec3::Y, Vec3::X]
        .into_iter()
        .find_map(|v| perpendicular(v, axis).filter(|p| p.is_finite()))
        .unwrap_or(Vec3::X)
}

/// The rotation `rest` turned so that the bone direction `from` becomes `to`, the twist fixed
/// by the pole: the frame (from, pole perpendicular to from) goes to (to, pole perpendicular
/// to to). `from` and `to` are unit vectors.
pub fn aim(rest: Quat, from: Vec3, to: Vec3, pole: Vec3) -> Quat {
    let frame = |axis: Vec3| {
        let r = reference(pole, axis);
        Mat3::from_cols(axis, r, axis.cross(r))
    };
    let turn = frame(to) * frame(from).transpose();
    (Quat::from_mat3(&turn) * rest).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reachable_target_is_met_with_the_bone_lengths_kept() {
        let s = Vec3::new(0.2, 1.4, 0.0);
        let target = Vec3::new(0.3, 1.2, -0.35);
        let (e, w) = two_bone(s, 0.28, 0.25, target, Vec3::new(0.4, -1.0, -0.4));
        assert!((w - target).length() < 1e-5);
        assert!(((e - s).length() - 0.28).abs() < 1e-5);
        assert!(((w - e).length() - 0.25).abs() < 1e-5);
        assert!(e.y < s.y, "the elbow bends down: {e}");
    }

    #[test]
    fn aim_turns_the_bone_and_keeps_the_twist_of_a_pure_turn() {
        let q = aim(Quat::IDENTITY, Vec3::X, Vec3::NEG_Z, Vec3::NEG_Y);
        assert!((q * Vec3::X - Vec3::NEG_Z).length() < 1e-6);
        assert!((q * Vec3::NEG_Y - Vec3::NEG_Y).length() < 1e-6);
    }
}
