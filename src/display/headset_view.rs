//! The headset's eyes as geometry, for the headset's session (`crate::xr`) and for drawing its
//! log again (`display::replay`): OpenXR's asymmetric field of view to a projection, an eye's
//! located pose in the stage to a view in the light field's normalised space through the
//! navigation, and what moving objects follow (the head between the eyes, the controllers'
//! grips) placed in the world.

use crate::dynamic::Tracked;
use crate::tracking::pose::WandPose;
use crate::tracking::Pose;
use glam::{Affine3A, Mat4, Quat, Vec3, Vec4};

/// OpenXR's field of view of one eye: four angles in radians from the view direction (left and
/// down are usually negative).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fov {
    pub angle_left: f32,
    pub angle_right: f32,
    pub angle_up: f32,
    pub angle_down: f32,
}

/// The projection of an asymmetric field of view: right-handed view space looking down -z, y up,
/// clip depth 0 at `near` and 1 at `far` (wgpu and Vulkan).
pub fn projection_from_fov(fov: Fov, near: f32, far: f32) -> Mat4 {
    let (left, right) = (fov.angle_left.tan(), fov.angle_right.tan());
    let (down, up) = (fov.angle_down.tan(), fov.angle_up.tan());
    let (width, height) = (right - left, up - down);
    Mat4::from_cols(
        Vec4::new(2.0 / width, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 2.0 / height, 0.0, 0.0),
        Vec4::new(
            (right + left) / width,
            (up + down) / height,
            far / (near - far),
            -1.0,
        ),
        Vec4::new(0.0, 0.0, near * far / (near - far), 0.0),
    )
}

/// An OpenXR pose: orientation and position of an eye in the reference space (stage: metres,
/// y up, -z ahead; the same convention as the CAVE's room space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct XrPose {
    /// quaternion (x, y, z, w), as XrQuaternionf
    pub orientation: [f32; 4],
    pub position: [f32; 3],
}

/// The view matrix (reference space to eye space) of a pose.
pub fn view_from_pose(pose: XrPose) -> Mat4 {
    let q = Quat::from_array(pose.orientation).normalize();
    Mat4::from_rotation_translation(q, Vec3::from(pose.position)).inverse()
}

/// The pose whose view matrix this is (rigid transforms only).
pub fn pose_from_view(view: Mat4) -> XrPose {
    let (_, rotation, translation) = view.inverse().to_scale_rotation_translation();
    XrPose {
        orientation: rotation.to_array(),
        position: translation.into(),
    }
}

/// An eye as the session log keeps it (`study::log::EyeRecord`): its located pose and field of
/// view, exactly (replay draws the eye again from it).
pub fn eye_record(pose: XrPose, fov: Fov) -> crate::study::log::EyeRecord {
    crate::study::log::EyeRecord {
        position: pose.position,
        orientation: pose.orientation,
        fov: [
            fov.angle_left,
            fov.angle_right,
            fov.angle_up,
            fov.angle_down,
        ],
    }
}

/// A logged eye's pose and field of view back (`eye_record`'s inverse).
pub fn logged_eye(eye: &crate::study::log::EyeRecord) -> (XrPose, Fov) {
    let [angle_left, angle_right, angle_up, angle_down] = eye.fov;
    let pose = XrPose {
        orientation: eye.orientation,
        position: eye.position,
    };
    let fov = Fov {
        angle_left,
        angle_right,
        angle_up,
        angle_down,
    };
    (pose, fov)
}

/// The far plane of the eyes' projection over the near plane: the renderer's depth (submitted
/// as the depth layer) runs from the near plane at 0 to this far at 1.
pub const FAR_OVER_NEAR: f32 = 1e4;

/// One eye's view-projection and position in the light field's normalised space: the stage is
/// placed in the scene by `room` (navigation), then normalised.
pub fn eye_view(
    pose: XrPose,
    fov: Fov,
    room: &Pose,
    norm: &crate::prepare::Normalisation,
    near: f32,
) -> (Mat4, Vec3) {
    let world_from_stage = Mat4::from_rotation_translation(
        Quat::from_rotation_y(room.room_yaw_deg.to_radians()),
        room.room_position,
    );
    let origin = norm.to_unit([0.0; 3]).as_vec3();
    let scale = norm.to_unit([1.0, 0.0, 0.0]).as_vec3().x - origin.x;
    let unit_from_world =
        Mat4::from_scale_rotation_translation(Vec3::splat(scale), Quat::IDENTITY, origin);
    let eye_from_unit = view_from_pose(pose) * (unit_from_world * world_from_stage).inverse();
    let eye = (unit_from_world * world_from_stage).transform_point3(Vec3::from(pose.position));
    let near_unit = near * scale;
    (
        projection_from_fov(fov, near_unit, near_unit * FAR_OVER_NEAR) * eye_from_unit,
        eye,
    )
}

/// A pose located in the app's reference space (the stage): world-from-thing once the stage is
/// placed in the world.
pub fn stage_pose(orientation: Quat, position: Vec3) -> Affine3A {
    Affine3A::from_rotation_translation(orientation.normalize(), position)
}

/// A controller's grip as the runtime located it (and the session log keeps it), in the stage.
pub fn hand_in_stage(grip: WandPose) -> Affine3A {
    stage_pose(grip.rotation, grip.position)
}

/// Where the navigation `room` puts the stage in the world (`eye_view` places the eyes so).
pub fn world_from_stage(room: &Pose) -> Affine3A {
    Affine3A::from_rotation_translation(
        Quat::from_rotation_y(room.room_yaw_deg.to_radians()),
        room.room_position,
    )
}

/// The head between two eye poses located in the stage: their mean position, and the rotation
/// halfway between theirs (the same rotation on a runtime without canted displays).
pub fn head_between(eyes: [(Quat, Vec3); 2]) -> Affine3A {
    let [(left_rotation, left), (right_rotation, right)] = eyes;
    let rotation = left_rotation
        .normalize()
        .slerp(right_rotation.normalize(), 0.5);
    stage_pose(rotation, 0.5 * (left + right))
}

/// What the objects follow this frame, in the world: the head and the controllers' grips
/// (left, right; None where the runtime does not track one) located in the stage, placed by the
/// navigation `room`; `time` moves keyframed objects.
pub fn tracked(
    room: &Pose,
    head: Affine3A,
    [left, right]: [Option<Affine3A>; 2],
    time: f64,
) -> Tracked {
    let world = world_from_stage(room);
    Tracked {
        time,
        head: world * head,
        wand: right.map(|g| world * g),
        left_hand: left.map(|g| world * g),
        // the headset tracks no targets ([[tracking.target]] is a CAVE's)
        targets: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_head_is_between_the_eyes_and_the_grips_move_with_the_navigation() {
        let turn = Quat::from_rotation_y(0.3);
        let head = head_between([
            (turn, Vec3::new(-0.032, 1.6, 0.0)),
            (turn, Vec3::new(0.032, 1.6, 0.0)),
        ]);
        assert!((Vec3::from(head.translation) - Vec3::new(0.0, 1.6, 0.0)).length() < 1e-6);
        let room = Pose::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 2.0), 90.0);
        let grip = stage_pose(Quat::IDENTITY, Vec3::new(0.0, 1.0, -0.5));
        let t = tracked(&room, head, [None, Some(grip)], 0.0);
        // a quarter turn left: the stage's -z becomes the world's -x
        let wand = Vec3::from(t.wand.unwrap().translation);
        assert!((wand - Vec3::new(0.5, 1.0, 2.0)).length() < 1e-5, "{wand}");
        assert!(t.left_hand.is_none());
    }
}
