//! Head tracking: a static head, a scripted path of keyframed head and navigation poses
//! (TOML, for repeatable walkthroughs and measurements; keyframes may carry a wand), or live poses (`live.rs`: OSC, DTrack, VRPN).

use super::live::WandPose;
use super::{DisplayConfig, TrackingConfig};
use crate::error::{Result, VlfError};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

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

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// seconds
    pub t: f32,
    pub head: [f32; 3],
    /// the head's orientation (see `head_rotation`); looking along -z when left out
    pub head_yaw_deg: Option<f32>,
    pub head_pitch_deg: Option<f32>,
    pub head_roll_deg: Option<f32>,
    pub head_orientation: Option<[f32; 4]>,
    /// where the room stands in the world
    pub position: [f32; 3],
    #[serde(default)]
    pub yaw_deg: f32,
    /// a tracked wand at this moment (room metres; `wand::wand_pose`): its ray is drawn
    pub wand_position: Option<[f32; 3]>,
    pub wand_yaw_deg: Option<f32>,
    pub wand_pitch_deg: Option<f32>,
    pub wand_orientation: Option<[f32; 4]>,
}

impl Keyframe {
    fn head_rotation(&self) -> std::result::Result<Quat, String> {
        head_rotation(
            [self.head_yaw_deg, self.head_pitch_deg, self.head_roll_deg],
            self.head_orientation,
            "",
        )
    }
    fn wand(&self) -> std::result::Result<Option<WandPose>, String> {
        super::wand::wand_pose(
            self.wand_position,
            [self.wand_yaw_deg, self.wand_pitch_deg],
            self.wand_orientation,
            "",
        )
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ScriptedPath {
    #[serde(rename = "keyframe")]
    pub keyframes: Vec<Keyframe>,
}

impl ScriptedPath {
    pub fn load(path: &Path) -> Result<ScriptedPath> {
        let text = std::fs::read_to_string(path).map_err(|e| VlfError::io(path, e))?;
        let err = |message: String| VlfError::Config {
            path: path.to_path_buf(),
            message,
        };
        let p: ScriptedPath =
            toml::from_str(&text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
        if p.keyframes.is_empty() {
            return Err(err(
                "[[keyframe]]: a path needs at least one keyframe".into()
            ));
        }
        for (i, k) in p.keyframes.iter().enumerate() {
            k.head_rotation()
                .map_err(|e| err(format!("keyframe[{i}].{e}")))?;
            k.wand().map_err(|e| err(format!("keyframe[{i}].{e}")))?;
        }
        for (i, w) in p.keyframes.windows(2).enumerate() {
            if w[1].t <= w[0].t {
                return Err(err(format!(
                    "keyframe[{}].t: times must increase ({} after {})",
                    i + 1,
                    w[1].t,
                    w[0].t
                )));
            }
        }
        Ok(p)
    }

    /// Linear interpolation between keyframes (spherical for the head's orientation); held at
    /// the ends.
    pub fn at(&self, t: f32) -> Pose {
        let k = &self.keyframes;
        let i = k.iter().rposition(|f| f.t <= t).unwrap_or(0);
        let (a, b) = (&k[i], &k[(i + 1).min(k.len() - 1)]);
        let s = if b.t > a.t {
            ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let lerp = |x: [f32; 3], y: [f32; 3]| Vec3::from(x).lerp(Vec3::from(y), s);
        let rotation = |k: &Keyframe| k.head_rotation().unwrap_or(Quat::IDENTITY);
        Pose {
            head: lerp(a.head, b.head),
            head_rotation: rotation(a).slerp(rotation(b), s),
            room_position: lerp(a.position, b.position),
            room_yaw_deg: a.yaw_deg + (b.yaw_deg - a.yaw_deg) * s,
        }
    }

    /// The wand at `t`: shown from a keyframe with a wand until the next keyframe, moving
    /// towards that one's wand if it has one (slerped), held otherwise.
    pub fn wand_at(&self, t: f32) -> Option<WandPose> {
        let k = &self.keyframes;
        let i = k.iter().rposition(|f| f.t <= t).unwrap_or(0);
        let (a, b) = (&k[i], &k[(i + 1).min(k.len() - 1)]);
        let wa = a.wand().ok().flatten()?;
        let Some(wb) = b.wand().ok().flatten() else {
            return Some(wa);
        };
        let s = if b.t > a.t {
            ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Some(WandPose {
            position: wa.position.lerp(wb.position, s),
            rotation: wa.rotation.slerp(wb.rotation, s),
        })
    }

    /// Whether any keyframe carries a wand.
    pub fn has_wand(&self) -> bool {
        self.keyframes.iter().any(|k| k.wand_position.is_some())
    }

    pub fn duration(&self) -> f32 {
        self.keyframes.last().map_or(0.0, |k| k.t)
    }
}

/// The pose source of a display configuration, for headless runs (`config_path` resolves a
/// scripted path relative to the configuration file).
pub enum PoseSource {
    Static(Pose),
    Scripted(ScriptedPath),
    Live(std::sync::Mutex<super::live::LiveTracker>),
}

impl PoseSource {
    pub fn from_config(config: &DisplayConfig, config_path: &Path) -> Result<PoseSource> {
        let start = Pose::new(
            Vec3::ZERO,
            Vec3::from(config.start_pose.position),
            config.start_pose.yaw_deg,
        );
        match &config.tracking {
            TrackingConfig::Static { head, .. } => {
                let head_rotation =
                    config
                        .tracking
                        .static_head_rotation()
                        .map_err(|message| VlfError::Config {
                            path: config_path.to_path_buf(),
                            message,
                        })?;
                Ok(PoseSource::Static(Pose {
                    head: Vec3::from(*head),
                    head_rotation,
                    ..start
                }))
            }
            TrackingConfig::Scripted { path } => Ok(PoseSource::Scripted(ScriptedPath::load(
                &config_path.parent().unwrap_or(Path::new(".")).join(path),
            )?)),
            TrackingConfig::Osc { .. }
            | TrackingConfig::Dtrack { .. }
            | TrackingConfig::Vrpn { .. } => {
                let start = Pose {
                    head: Vec3::new(0.0, 1.7, 0.0),
                    ..start
                };
                let tracker = config
                    .tracking
                    .live()
                    .expect("a live source")
                    .start(start, config_path)?;
                Ok(PoseSource::Live(std::sync::Mutex::new(tracker)))
            }
        }
    }

    /// The pose at `t` and, for live tracking, how the source is doing.
    pub fn at_with_status(&self, t: f32) -> (Pose, Option<super::live::TrackingStatus>) {
        match self {
            PoseSource::Live(tracker) => {
                let (pose, status) = tracker.lock().unwrap().latest();
                (pose, Some(status))
            }
            other => (other.at(t), None),
        }
    }

    /// The tracked wand at `t`, if any (a static wand comes from the configuration's
    /// `tracking`; a live source's wand once one has been seen).
    pub fn wand_at(&self, tracking: &TrackingConfig, t: f32) -> Option<WandPose> {
        match self {
            PoseSource::Static(_) => tracking.static_wand().ok().flatten(),
            PoseSource::Scripted(s) => s.wand_at(t),
            PoseSource::Live(tracker) => {
                tracker
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .latest_state()
                    .0
                    .wand
            }
        }
    }

    /// Whether this source can ever give a wand.
    pub fn may_have_wand(&self, tracking: &TrackingConfig) -> bool {
        match self {
            PoseSource::Static(_) => matches!(tracking.static_wand(), Ok(Some(_))),
            PoseSource::Scripted(s) => s.has_wand(),
            PoseSource::Live(_) => true,
        }
    }

    /// The pose at `t` and, for live tracking, when it arrived if no frame has been drawn from
    /// it yet (`LiveTracker::take_fresh`): for the latency from a pose's arrival to its frame.
    pub fn at_fresh(&self, t: f32) -> (Pose, Option<std::time::Instant>) {
        match self {
            PoseSource::Live(tracker) => {
                let mut tracker = tracker.lock().unwrap_or_else(|e| e.into_inner());
                let pose = tracker.latest().0;
                (pose, tracker.take_fresh())
            }
            other => (other.at(t), None),
        }
    }

    pub fn at(&self, t: f32) -> Pose {
        match self {
            PoseSource::Static(p) => *p,
            PoseSource::Scripted(s) => s.at(t),
            PoseSource::Live(tracker) => tracker.lock().unwrap().latest().0,
        }
    }
}
