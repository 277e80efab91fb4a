//! The headset's body and moving objects (`vlf xr --objects FILE.toml`): the file holds a display
//! config's `[[object]]` and `[object_lighting]` tables alone (the same types, `crate::dynamic`
//! and `render::probes`), and each frame the objects follow what the runtime tracks: the head
//! (the mean of the two eye poses), the right controller's grip as the wand (the avatar's right
//! hand) and the left controller's grip as the left hand, all moved into the world by the
//! navigation that places the eyes (`eye_view`).

use crate::dynamic::Tracked;
pub use crate::render::objects_file::ObjectsFile;
use crate::tracking::Pose;
use glam::{Affine3A, Quat, Vec3};
use serde::Serialize;

/// A pose located in the app's reference space (the stage): world-from-thing once the stage is
/// placed in the world.
pub fn stage_pose(orientation: Quat, position: Vec3) -> Affine3A {
    Affine3A::from_rotation_translation(orientation.normalize(), position)
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
    }
}

/// The moving objects in a headset run: how often the runtime located each hand, and what the
/// last frame drawn followed (`vlf xr --json`).
#[derive(Clone, Debug, Serialize)]
pub struct BodyReport {
    /// the objects' names, in the file's order
    pub objects: Vec<String>,
    /// frames whose left and right controller grips the runtime located
    pub frames_with_left_grip: u32,
    pub frames_with_right_grip: u32,
    pub last: Option<BodyFrame>,
}

/// What one frame's objects followed, in the world (metres).
#[derive(Clone, Debug, Serialize)]
pub struct BodyFrame {
    /// where the navigation put the stage: world = room_position + rotate_y(room_yaw) * stage
    pub room_position: [f32; 3],
    pub room_yaw_deg: f32,
    /// the head (between the eyes) and the controllers' grips (None: not tracked)
    pub head: WorldPose,
    pub left_grip: Option<WorldPose>,
    pub right_grip: Option<WorldPose>,
    /// the avatar's left and right hand joints as drawn (None: no avatar shown)
    pub avatar_hands: Option<[[f32; 3]; 2]>,
}

/// A position and an orientation (quaternion x, y, z, w) in the world.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct WorldPose {
    pub position: [f32; 3],
    pub orientation: [f32; 4],
}

impl From<Affine3A> for WorldPose {
    fn from(a: Affine3A) -> WorldPose {
        let (_, rotation, position) = a.to_scale_rotation_translation();
        WorldPose {
            position: position.to_array(),
            orientation: rotation.to_array(),
        }
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
