//! The poses every tracking source produces and every consumer reads: the viewer's `Pose` (head
//! in the room, room in the world), a tracked wand's, hand's or target's `WandPose` and those of
//! a frame (`HeldPoses`, with the declared targets by index up to `MAX_TARGETS`), with head
//! orientations from
//! configuration angles or quaternions. Below tracking, calibration, live sources and the wand,
//! so that none of them depends on another for these types.

use glam::{Quat, Vec3};

/// Where the viewer is at one moment: the tracked head (position in room metres and
/// orientation in the room), and where the room stands in the world (navigation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub head: Vec3,
    /// Room from head: the identity looks along the room's -z with +x to the right and +y up
    /// (the OpenXR convention).
    pub head_rotation: Quat,
    pub room_position: Vec3,
    pub room_yaw_deg: f32,
}

impl Pose {
    /// A pose whose head looks along the room's -z.
    pub fn new(head: Vec3, room_position: Vec3, room_yaw_deg: f32) -> Pose {
        Pose {
            head,
            head_rotation: Quat::IDENTITY,
            room_position,
            room_yaw_deg,
        }
    }
    pub fn room_to_world(&self, p: Vec3) -> Vec3 {
        self.room_position + Quat::from_rotation_y(self.room_yaw_deg.to_radians()) * p
    }
    /// The head's right axis in the world: the direction from the left eye to the right.
    pub fn right(&self) -> Vec3 {
        Quat::from_rotation_y(self.room_yaw_deg.to_radians()) * self.head_rotation * Vec3::X
    }
    /// One eye in room metres (`side` -1 left, +1 right, 0 between the eyes): `eye_offset` (head
    /// frame, metres) from the tracked point to the eyes' centre, then half the interpupillary
    /// distance along the head's right axis.
    pub fn eye(&self, eye_offset: Vec3, eye_separation: f32, side: f32) -> Vec3 {
        self.head + self.head_rotation * (eye_offset + Vec3::X * side * eye_separation * 0.5)
    }
}

/// A head orientation from angles in degrees: yaw about the room's up axis (positive turns
/// left), then pitch about the head's right axis (positive looks up), then roll about the
/// line of sight (positive tilts the head to the left).
pub fn head_rotation_from_angles(yaw_deg: f32, pitch_deg: f32, roll_deg: f32) -> Quat {
    Quat::from_rotation_y(yaw_deg.to_radians())
        * Quat::from_rotation_x(pitch_deg.to_radians())
        * Quat::from_rotation_z(roll_deg.to_radians())
}

/// A head orientation given in a configuration either as angles (`<key>_yaw_deg`, `_pitch_deg`,
/// `_roll_deg`, each 0 when left out) or as a quaternion `<key>_orientation = [x, y, z, w]`
/// (normalised here); `at` names the keys' table in errors.
pub fn head_rotation(
    angles: [Option<f32>; 3],
    quaternion: Option<[f32; 4]>,
    at: &str,
) -> std::result::Result<Quat, String> {
    match quaternion {
        Some(_) if angles.iter().any(Option::is_some) => {
            Err(format!("{at}head_orientation: give the head's orientation either as a quaternion or as head_yaw_deg/head_pitch_deg/head_roll_deg, not both"))
        }
        Some(q) => {
            let q = Quat::from_array(q);
            if !q.is_finite() || q.length() < 1e-3 {
                return Err(format!("{at}head_orientation: {:?} is not a rotation (a finite quaternion [x, y, z, w] of non-zero length)", q.to_array()));
            }
            Ok(q.normalize())
        }
        None => {
            let [yaw, pitch, roll] = angles.map(|a| a.unwrap_or(0.0));
            for (name, a) in [("head_yaw_deg", yaw), ("head_pitch_deg", pitch), ("head_roll_deg", roll)] {
                if !a.is_finite() {
                    return Err(format!("{at}{name}: must be a finite number of degrees"));
                }
            }
            Ok(head_rotation_from_angles(yaw, pitch, roll))
        }
    }
}

/// A tracked wand in the room: position (metres) and orientation (identity points along -z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WandPose {
    pub position: Vec3,
    pub rotation: Quat,
}

/// The most tracked targets a display config declares (`[[tracking.target]]`): the cluster's
/// frame state and the session log's rows hold this many, so that their size is fixed.
pub const MAX_TARGETS: usize = 8;

/// The tracked targets of one frame, in the order the display config declares them
/// (`[[tracking.target]]`), each where it has been seen; the slots past the declared ones stay
/// None.
pub type Targets = [Option<WandPose>; MAX_TARGETS];

/// What is tracked besides the head in one frame, in the room: the wand (the right hand), the
/// left hand and the declared targets, each where tracked.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HeldPoses {
    pub wand: Option<WandPose>,
    pub left_hand: Option<WandPose>,
    pub targets: Targets,
}

/// The tracked head, wand, left hand and targets as the tracker sent them, before
/// `[tracking.calibration]`:
/// in the tracker's own frame and units (a session log keeps them beside the calibrated ones).
/// None where the source has sent none, or has no tracker frame (static, scripted). The head's
/// rotation is the last one sent (identity before one: a head sent as a position alone).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RawPoses {
    pub head: Option<WandPose>,
    pub wand: Option<WandPose>,
    pub left_hand: Option<WandPose>,
    pub targets: Targets,
}
