//! Room-from-tracker calibration (`[tracking.calibration]` in a display configuration): a
//! tracking system reports poses in its own frame (its units, often millimetres, and often
//! z up); the room is metres, y up, the viewer facing -z. A tracker position p becomes
//! `translation + rotation * axes * (unit_scale * p)`, and a tracked body's orientation q
//! becomes `rotation * axes * q * axes^-1` (a body aligned with the tracker's axes is a head
//! looking along the tracker's forward axis, expressed in the room's convention). It also says
//! which sensor or body is the head, which the wand, which, if any, the left hand, and which the
//! declared targets (`[[tracking.target]]`, `target.rs`).

use super::pose::{head_rotation_from_angles, Pose, WandPose};
use super::target::{self, TargetConfig};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

/// Which of the tracker's axes points up.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Axes {
    /// x right, y up, z towards the viewer (the room's own convention)
    #[default]
    YUp,
    /// x right, y ahead (away from the viewer), z up
    ZUp,
}

#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// where the tracker's origin lies in the room, metres
    #[serde(default)]
    pub translation: [f32; 3],
    /// the tracker's axes turned in the room (after `axes`): degrees, yaw about up, then pitch
    /// about x, then roll about z; or a quaternion `rotation = [x, y, z, w]`
    pub yaw_deg: Option<f32>,
    pub pitch_deg: Option<f32>,
    pub roll_deg: Option<f32>,
    pub rotation: Option<[f32; 4]>,
    /// metres per tracker unit (0.001 for millimetres); default: the source's own unit
    /// (DTrack: millimetres, OSC and VRPN: metres)
    pub unit_scale: Option<f32>,
    #[serde(default)]
    pub axes: Axes,
    /// the head's body (DTrack `6d`) or sensor (VRPN) id; default 0
    pub head_id: Option<u32>,
    /// the wand's Flystick (DTrack `6df2`) or sensor (VRPN) id; default: DTrack 0, VRPN 1
    pub wand_id: Option<u32>,
    /// the left hand's body (DTrack `6d`) or sensor (VRPN) id; none by default (no left hand
    /// tracked; OSC sends it as `/vlf/left_hand` without an id)
    pub left_hand_id: Option<u32>,
}

/// A tracked target as a live source finds it: its name (OSC's `/vlf/target/<name>`) and its
/// body or sensor id (DTrack, VRPN; None for OSC). Its index is its place in
/// `RoomFromTracker::targets`.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetId {
    pub name: String,
    pub id: Option<u32>,
}

/// A calibration resolved for one source: the transform and the ids.
#[derive(Clone, Debug, PartialEq)]
pub struct RoomFromTracker {
    pub translation: Vec3,
    /// the calibration rotation times the axis convention
    pub rotation: Quat,
    /// the axis convention alone (conjugates body orientations)
    pub axes: Quat,
    pub scale: f32,
    pub head_id: u32,
    pub wand_id: u32,
    pub left_hand_id: Option<u32>,
    /// the declared targets, in order (`with_targets`)
    pub targets: Vec<TargetId>,
}

impl Default for RoomFromTracker {
    fn default() -> Self {
        RoomFromTracker {
            translation: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            axes: Quat::IDENTITY,
            scale: 1.0,
            head_id: 0,
            wand_id: 1,
            left_hand_id: None,
            targets: Vec::new(),
        }
    }
}

impl Calibration {
    /// Check the values; errors name the key under `[tracking.calibration]`.
    pub fn validate(&self) -> std::result::Result<(), String> {
        self.resolve(1.0, 0).map(|_| ())
    }

    /// The transform for a source whose unit is `default_scale` metres and whose wand is
    /// `default_wand` unless configured.
    pub fn resolve(
        &self,
        default_scale: f32,
        default_wand: u32,
    ) -> std::result::Result<RoomFromTracker, String> {
        let at = "tracking.calibration";
        if !self.translation.iter().all(|x| x.is_finite()) {
            return Err(format!(
                "{at}.translation: {:?} must be finite metres",
                self.translation
            ));
        }
        let scale = self.unit_scale.unwrap_or(default_scale);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(format!("{at}.unit_scale: {scale} must be a positive number of metres per tracker unit (0.001 for millimetres)"));
        }
        let angles = [
            ("yaw_deg", self.yaw_deg),
            ("pitch_deg", self.pitch_deg),
            ("roll_deg", self.roll_deg),
        ];
        let rotation = match self.rotation {
            Some(_) if angles.iter().any(|(_, a)| a.is_some()) => {
                return Err(format!("{at}.rotation: give the rotation either as a quaternion or as yaw_deg/pitch_deg/roll_deg, not both"));
            }
            Some(q) => {
                let q = Quat::from_array(q);
                if !q.is_finite() || q.length() < 1e-3 {
                    return Err(format!("{at}.rotation: {:?} is not a rotation (a finite quaternion [x, y, z, w] of non-zero length)", q.to_array()));
                }
                q.normalize()
            }
            None => {
                if let Some((name, a)) = angles.iter().find(|(_, a)| !a.unwrap_or(0.0).is_finite())
                {
                    return Err(format!(
                        "{at}.{name}: {a:?} must be a finite number of degrees"
                    ));
                }
                let [yaw, pitch, roll] = angles.map(|(_, a)| a.unwrap_or(0.0));
                head_rotation_from_angles(yaw, pitch, roll)
            }
        };
        let axes = match self.axes {
            Axes::YUp => Quat::IDENTITY,
            // tracker (x, y, z) with z up -> room (x, z, -y)
            Axes::ZUp => Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        };
        let head_id = self.head_id.unwrap_or(0);
        if self.left_hand_id == Some(head_id) {
            return Err(format!(
                "{at}.left_hand_id: {head_id} is the head's id (head_id): give the left hand's own body or sensor"
            ));
        }
        Ok(RoomFromTracker {
            translation: Vec3::from(self.translation),
            rotation: rotation * axes,
            axes,
            scale,
            head_id,
            wand_id: self.wand_id.unwrap_or(default_wand),
            left_hand_id: self.left_hand_id,
            targets: Vec::new(),
        })
    }
}

impl RoomFromTracker {
    /// These ids with the declared targets' (already checked among themselves:
    /// `target::check_targets`), or which key to change: a target's body or sensor cannot be the
    /// head's or the left hand's (a VRPN sensor that is the wand's is `vrpn::distinct_sensors`'
    /// check; DTrack's wand is a Flystick, numbered apart from the bodies).
    pub fn with_targets(
        mut self,
        targets: &[TargetConfig],
    ) -> std::result::Result<RoomFromTracker, String> {
        for (i, t) in targets.iter().enumerate() {
            let Some(id) = t.id else { continue };
            let at = target::at(i, &t.name);
            if id == self.head_id {
                return Err(format!("{at}id: {id} is the head's (tracking.calibration.head_id, 0 unless given): give the target its own body or sensor"));
            }
            if self.left_hand_id == Some(id) {
                return Err(format!("{at}id: {id} is the left hand's (tracking.calibration.left_hand_id): give the target its own body or sensor"));
            }
        }
        self.targets = (targets.iter())
            .map(|t| TargetId {
                name: t.name.clone(),
                id: t.id,
            })
            .collect();
        Ok(self)
    }

    /// The index of the target whose body or sensor is `id`, if one is.
    pub fn target_of(&self, id: u32) -> Option<usize> {
        self.targets.iter().position(|t| t.id == Some(id))
    }

    /// A tracker position in the room, metres.
    pub fn position(&self, p: Vec3) -> Vec3 {
        self.translation + self.rotation * (p * self.scale)
    }

    /// A tracked body's orientation in the room.
    pub fn orientation(&self, q: Quat) -> Quat {
        (self.rotation * q * self.axes.inverse()).normalize()
    }

    /// A tracked wand or hand (position and orientation in the tracker's frame) in the room.
    pub fn held(&self, position: Vec3, rotation: Quat) -> WandPose {
        WandPose {
            position: self.position(position),
            rotation: self.orientation(rotation),
        }
    }

    /// A tracked head (position and orientation in the tracker's frame) as the head of `pose`.
    pub fn head(&self, pose: &mut Pose, position: Vec3, orientation: Option<Quat>) {
        pose.head = self.position(position);
        if let Some(q) = orientation {
            pose.head_rotation = self.orientation(q);
        }
    }
}
