//! Tracking: where the head, the wand, the left hand and the declared targets are, and how the
//! user moves through the scene. The display TOML's `[tracking]`, `[start_pose]` and
//! `[navigation]` tables (this module); the `[[tracking.target]]` tables (`target.rs`); the pose
//! types (`pose.rs`); the pose source a display's loops draw from, static, scripted or
//! live (`source.rs`, and `vlf track`); live sources (`live.rs`: the receiving thread and its
//! state) with their protocols (`osc.rs`, `dtrack.rs`, `vrpn.rs`) and the room calibration
//! (`calibration.rs`); the tracked wand (`wand.rs`) and navigation added to the tracked pose
//! (`navigator.rs`). Nothing here draws: the displays (`crate::display`), the cluster and the
//! headset read poses from here.

pub mod calibration;
pub mod dtrack;
pub mod live;
pub mod navigator;
pub mod osc;
pub mod pose;
pub mod source;
pub mod target;
pub mod vrpn;
pub mod wand;

pub use pose::{HeldPoses, Pose, RawPoses, Targets, WandPose, MAX_TARGETS};
pub use target::TargetConfig;

use crate::error::{Result, VlfError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Where the room stands in the scene: world = position + rotate_y(yaw) * room.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StartPose {
    #[serde(default)]
    pub position: [f32; 3],
    #[serde(default)]
    pub yaw_deg: f32,
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, tag = "source", rename_all = "lowercase")]
pub enum TrackingConfig {
    /// a fixed head in room metres, looking along -z unless oriented (`tracking::head_rotation`)
    Static {
        head: [f32; 3],
        head_yaw_deg: Option<f32>,
        head_pitch_deg: Option<f32>,
        head_roll_deg: Option<f32>,
        head_orientation: Option<[f32; 4]>,
        /// a tracked wand held still (room metres; see `wand::wand_pose`): draws the wand ray
        wand_position: Option<[f32; 3]>,
        wand_yaw_deg: Option<f32>,
        wand_pitch_deg: Option<f32>,
        wand_orientation: Option<[f32; 4]>,
        /// a tracked left hand held still (room metres, the same keys as the wand's): the
        /// avatar's left hand and `follow = "left_hand"` objects go there
        left_hand_position: Option<[f32; 3]>,
        left_hand_yaw_deg: Option<f32>,
        left_hand_pitch_deg: Option<f32>,
        left_hand_orientation: Option<[f32; 4]>,
        /// tracked targets besides the head and the hands (`[[tracking.target]]`, `target.rs`)
        #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
        targets: Vec<TargetConfig>,
    },
    /// keyframed head and navigation poses (a TOML file, path relative to the config); its
    /// targets are moved by the keyframes' `[[keyframe.target]]` tables
    Scripted {
        path: PathBuf,
        /// tracked targets besides the head and the hands (`[[tracking.target]]`, `target.rs`)
        #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
        targets: Vec<TargetConfig>,
    },
    /// live poses over UDP/OSC (`osc.rs`)
    Osc {
        port: u16,
        #[serde(default)]
        calibration: calibration::Calibration,
        /// tracked targets besides the head and the hands (`[[tracking.target]]`, `target.rs`)
        #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
        targets: Vec<TargetConfig>,
    },
    /// live poses from A.R.T. DTrack2 (ASCII over UDP, `dtrack.rs`)
    Dtrack {
        port: u16,
        #[serde(default)]
        calibration: calibration::Calibration,
        /// tracked targets besides the head and the hands (`[[tracking.target]]`, `target.rs`)
        #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
        targets: Vec<TargetConfig>,
    },
    /// live poses from a VRPN server (`host[:port]`), device `device` (`vrpn.rs`)
    Vrpn {
        server: String,
        device: String,
        #[serde(default)]
        calibration: calibration::Calibration,
        /// tracked targets besides the head and the hands (`[[tracking.target]]`, `target.rs`)
        #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
        targets: Vec<TargetConfig>,
    },
}

impl Default for TrackingConfig {
    fn default() -> Self {
        TrackingConfig::Static {
            head: [0.0, 1.7, 0.0],
            head_yaw_deg: None,
            head_pitch_deg: None,
            head_roll_deg: None,
            head_orientation: None,
            wand_position: None,
            wand_yaw_deg: None,
            wand_pitch_deg: None,
            wand_orientation: None,
            left_hand_position: None,
            left_hand_yaw_deg: None,
            left_hand_pitch_deg: None,
            left_hand_orientation: None,
            targets: Vec::new(),
        }
    }
}

/// A live tracking source as configured (`TrackingConfig::live`).
pub struct LiveSource {
    pub protocol: &'static str,
    /// where it is received: "UDP 9000", "Tracker0@host:3883"
    pub address: String,
    pub calibration: std::result::Result<calibration::RoomFromTracker, String>,
    pub kind: LiveKind,
}

pub enum LiveKind {
    /// packets on a UDP port, read by a parser
    Udp {
        port: u16,
        parse: live::Parser,
    },
    Vrpn {
        server: String,
        device: String,
    },
}

impl LiveSource {
    /// Start receiving; `start` is the pose until the first measurement.
    pub fn start(self, start: Pose, config_path: &Path) -> Result<live::LiveTracker> {
        let calibration = self.calibration.map_err(|message| VlfError::Config {
            path: config_path.to_path_buf(),
            message,
        })?;
        match self.kind {
            LiveKind::Udp { port, parse } => live::LiveTracker::spawn(
                self.protocol,
                &format!("0.0.0.0:{port}"),
                start,
                calibration,
                parse,
            ),
            LiveKind::Vrpn { server, device } => {
                live::LiveTracker::connect_vrpn(&server, &device, start, calibration)
            }
        }
    }
}

impl TrackingConfig {
    /// The static wand, if one is configured.
    pub fn static_wand(&self) -> std::result::Result<Option<live::WandPose>, String> {
        match self {
            TrackingConfig::Static {
                wand_position,
                wand_yaw_deg,
                wand_pitch_deg,
                wand_orientation,
                ..
            } => wand::held_pose(
                "wand_",
                *wand_position,
                [*wand_yaw_deg, *wand_pitch_deg],
                *wand_orientation,
                "tracking.",
            ),
            _ => Ok(None),
        }
    }

    /// The static left hand, if one is configured.
    pub fn static_left_hand(&self) -> std::result::Result<Option<live::WandPose>, String> {
        match self {
            TrackingConfig::Static {
                left_hand_position,
                left_hand_yaw_deg,
                left_hand_pitch_deg,
                left_hand_orientation,
                ..
            } => wand::held_pose(
                "left_hand_",
                *left_hand_position,
                [*left_hand_yaw_deg, *left_hand_pitch_deg],
                *left_hand_orientation,
                "tracking.",
            ),
            _ => Ok(None),
        }
    }

    /// The declared targets (`[[tracking.target]]`), in order: a target's index is its place.
    pub fn targets(&self) -> &[TargetConfig] {
        match self {
            TrackingConfig::Static { targets, .. }
            | TrackingConfig::Scripted { targets, .. }
            | TrackingConfig::Osc { targets, .. }
            | TrackingConfig::Dtrack { targets, .. }
            | TrackingConfig::Vrpn { targets, .. } => targets,
        }
    }

    /// The declared targets' names, in order.
    pub fn target_names(&self) -> Vec<String> {
        target::names(self.targets())
    }

    /// The targets' checks for this source (`target::check_targets`); errors name the key.
    pub fn check_targets(&self) -> std::result::Result<(), String> {
        let source = match self {
            TrackingConfig::Static { .. } => target::TargetSource::Static,
            TrackingConfig::Scripted { .. } => target::TargetSource::Scripted,
            TrackingConfig::Osc { .. } => target::TargetSource::Osc,
            TrackingConfig::Dtrack { .. } => target::TargetSource::Dtrack,
            TrackingConfig::Vrpn { .. } => target::TargetSource::Vrpn,
        };
        target::check_targets(self.targets(), source)
    }

    /// A static source's targets where their positions hold them (the others never seen).
    pub fn static_targets(&self) -> std::result::Result<Targets, String> {
        let mut out = Targets::default();
        if let TrackingConfig::Static { targets, .. } = self {
            for (i, t) in targets.iter().enumerate().take(MAX_TARGETS) {
                out[i] = t.static_pose(i)?;
            }
        }
        Ok(out)
    }

    /// The static head's orientation (identity for the other sources).
    pub fn static_head_rotation(&self) -> std::result::Result<glam::Quat, String> {
        match self {
            TrackingConfig::Static {
                head_yaw_deg,
                head_pitch_deg,
                head_roll_deg,
                head_orientation,
                ..
            } => pose::head_rotation(
                [*head_yaw_deg, *head_pitch_deg, *head_roll_deg],
                *head_orientation,
                "tracking.",
            ),
            _ => Ok(glam::Quat::IDENTITY),
        }
    }

    /// A live source: its protocol, UDP port, calibration (resolved with the protocol's own unit
    /// and wand id, with the declared targets; VRPN's sensors checked apart) and packet parser;
    /// None for static and scripted heads.
    pub fn live(&self) -> Option<LiveSource> {
        let targets = self.targets();
        let with_targets = |c: std::result::Result<calibration::RoomFromTracker, String>| {
            c.and_then(|c| c.with_targets(targets))
        };
        let udp =
            |protocol, port: &u16, calibration: std::result::Result<_, _>, parse| LiveSource {
                protocol,
                address: format!("UDP {port}"),
                calibration,
                kind: LiveKind::Udp { port: *port, parse },
            };
        match self {
            TrackingConfig::Osc {
                port, calibration, ..
            } => Some(udp(
                "OSC",
                port,
                with_targets(calibration.resolve(1.0, 1)),
                osc::parse as live::Parser,
            )),
            // DTrack sends millimetres; the wand is a Flystick, numbered apart from the bodies
            TrackingConfig::Dtrack {
                port, calibration, ..
            } => Some(udp(
                "DTrack",
                port,
                with_targets(calibration.resolve(0.001, 0)),
                dtrack::parse,
            )),
            TrackingConfig::Vrpn {
                server,
                device,
                calibration,
                ..
            } => Some(LiveSource {
                protocol: "VRPN",
                address: format!("{device}@{server}"),
                calibration: with_targets(calibration.resolve(1.0, 1))
                    .and_then(vrpn::distinct_sensors),
                kind: LiveKind::Vrpn {
                    server: server.clone(),
                    device: device.clone(),
                },
            }),
            _ => None,
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Navigation {
    /// metres per second
    pub walk_speed: f32,
    /// degrees per second
    pub turn_speed_deg: f32,
    /// fly (move along the view direction) rather than walk on the ground plane
    pub fly: bool,
    /// the tracked wand's button that resets the navigation (DTrack Flystick2: 0 trigger,
    /// 1-4 the blue buttons right to left, 5 the joystick pressed)
    #[serde(default = "default_reset_button")]
    pub wand_reset_button: u32,
}

fn default_reset_button() -> u32 {
    1
}

impl Default for Navigation {
    fn default() -> Self {
        Navigation {
            walk_speed: 1.4,
            turn_speed_deg: 60.0,
            fly: false,
            wand_reset_button: default_reset_button(),
        }
    }
}
