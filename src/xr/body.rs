//! The headset's body and moving objects (`vlf xr --objects FILE.toml`): the file holds a display
//! config's `[[object]]` and `[object_lighting]` tables alone (the same types, `crate::dynamic`
//! and `render::probes`), and each frame the objects follow what the runtime tracks: the head
//! (the mean of the two eye poses), the right controller's grip as the wand (the avatar's right
//! hand) and the left controller's grip as the left hand, all moved into the world by the
//! navigation that places the eyes (`eye_view`).

pub use crate::render::objects_file::ObjectsFile;
use glam::Affine3A;
use serde::Serialize;

pub use crate::display::headset_view::{
    hand_in_stage, head_between, stage_pose, tracked, world_from_stage,
};

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
