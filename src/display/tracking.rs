//! Head tracking: a static head, a scripted path of keyframed head and navigation poses
//! (TOML, for repeatable walkthroughs and measurements), or live poses over UDP/OSC (`osc.rs`).

use super::{DisplayConfig, TrackingConfig};
use crate::error::{Result, VlfError};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Where the viewer is at one moment: the head in room metres, and where the room stands in
/// the world (navigation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub head: Vec3,
    pub room_position: Vec3,
    pub room_yaw_deg: f32,
}

impl Pose {
    pub fn room_to_world(&self, p: Vec3) -> Vec3 {
        self.room_position + Quat::from_rotation_y(self.room_yaw_deg.to_radians()) * p
    }
    /// The room's x axis in the world: the direction between the eyes.
    pub fn right(&self) -> Vec3 {
        Quat::from_rotation_y(self.room_yaw_deg.to_radians()) * Vec3::X
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// seconds
    pub t: f32,
    pub head: [f32; 3],
    /// where the room stands in the world
    pub position: [f32; 3],
    #[serde(default)]
    pub yaw_deg: f32,
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
        let err = |message: String| VlfError::Config { path: path.to_path_buf(), message };
        let p: ScriptedPath = toml::from_str(&text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
        if p.keyframes.is_empty() {
            return Err(err("[[keyframe]]: a path needs at least one keyframe".into()));
        }
        for (i, w) in p.keyframes.windows(2).enumerate() {
            if w[1].t <= w[0].t {
                return Err(err(format!("keyframe[{}].t: times must increase ({} after {})", i + 1, w[1].t, w[0].t)));
            }
        }
        Ok(p)
    }

    /// Linear interpolation between keyframes; held at the ends.
    pub fn at(&self, t: f32) -> Pose {
        let k = &self.keyframes;
        let i = k.iter().rposition(|f| f.t <= t).unwrap_or(0);
        let (a, b) = (&k[i], &k[(i + 1).min(k.len() - 1)]);
        let s = if b.t > a.t { ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0) } else { 0.0 };
        let lerp = |x: [f32; 3], y: [f32; 3]| Vec3::from(x).lerp(Vec3::from(y), s);
        Pose { head: lerp(a.head, b.head), room_position: lerp(a.position, b.position), room_yaw_deg: a.yaw_deg + (b.yaw_deg - a.yaw_deg) * s }
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
    Live(std::sync::Mutex<super::osc::OscTracker>),
}

impl PoseSource {
    pub fn from_config(config: &DisplayConfig, config_path: &Path) -> Result<PoseSource> {
        let start = Pose { head: Vec3::ZERO, room_position: Vec3::from(config.start_pose.position), room_yaw_deg: config.start_pose.yaw_deg };
        match &config.tracking {
            TrackingConfig::Static { head } => Ok(PoseSource::Static(Pose { head: Vec3::from(*head), ..start })),
            TrackingConfig::Scripted { path } => {
                Ok(PoseSource::Scripted(ScriptedPath::load(&config_path.parent().unwrap_or(Path::new(".")).join(path))?))
            }
            TrackingConfig::Osc { port } => {
                let start = Pose { head: Vec3::new(0.0, 1.7, 0.0), ..start };
                Ok(PoseSource::Live(std::sync::Mutex::new(super::osc::OscTracker::listen(&format!("0.0.0.0:{port}"), start)?)))
            }
        }
    }

    /// The pose at `t` and, for live tracking, how the source is doing.
    pub fn at_with_status(&self, t: f32) -> (Pose, Option<super::osc::TrackingStatus>) {
        match self {
            PoseSource::Live(tracker) => {
                let (pose, status) = tracker.lock().unwrap().latest();
                (pose, Some(status))
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
