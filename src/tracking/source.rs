//! The pose source a display's loops draw from (`PoseSource`): a static head, a scripted path of keyframed head and navigation poses
//! (TOML, for repeatable walkthroughs and measurements; keyframes may carry a wand, a left hand
//! and the declared targets, `[[keyframe.target]]`), or live poses (`live.rs`: OSC, DTrack, VRPN).

pub use super::pose::{
    head_rotation, head_rotation_from_angles, HeldPoses, Pose, RawPoses, Targets, WandPose,
    MAX_TARGETS,
};
use super::{StartPose, TrackingConfig};
use crate::error::{Result, VlfError};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::{Duration, Instant};

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
    /// a tracked left hand at this moment (room metres, the same keys as the wand's)
    pub left_hand_position: Option<[f32; 3]>,
    pub left_hand_yaw_deg: Option<f32>,
    pub left_hand_pitch_deg: Option<f32>,
    pub left_hand_orientation: Option<[f32; 4]>,
    /// declared targets at this moment (`[[keyframe.target]]`: the name of a
    /// `[[tracking.target]]`, then the wand's keys without `wand_`)
    #[serde(default, rename = "target", skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<KeyframeTarget>,
}

/// A declared target at a keyframe: interpolated and slerped to the next keyframe's, as the wand.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KeyframeTarget {
    pub name: String,
    pub position: [f32; 3],
    pub yaw_deg: Option<f32>,
    pub pitch_deg: Option<f32>,
    pub orientation: Option<[f32; 4]>,
}

/// Which held thing of a keyframe: the wand's keys, the left hand's or a target's (by name).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeldKind<'a> {
    Wand,
    LeftHand,
    Target(&'a str),
}

impl Keyframe {
    fn head_rotation(&self) -> std::result::Result<Quat, String> {
        head_rotation(
            [self.head_yaw_deg, self.head_pitch_deg, self.head_roll_deg],
            self.head_orientation,
            "",
        )
    }
    fn held(&self, which: HeldKind) -> std::result::Result<Option<WandPose>, String> {
        match which {
            HeldKind::Wand => super::wand::held_pose(
                "wand_",
                self.wand_position,
                [self.wand_yaw_deg, self.wand_pitch_deg],
                self.wand_orientation,
                "",
            ),
            HeldKind::LeftHand => super::wand::held_pose(
                "left_hand_",
                self.left_hand_position,
                [self.left_hand_yaw_deg, self.left_hand_pitch_deg],
                self.left_hand_orientation,
                "",
            ),
            HeldKind::Target(name) => {
                let Some(i) = self.targets.iter().position(|t| t.name == name) else {
                    return Ok(None);
                };
                let t = &self.targets[i];
                super::wand::held_pose(
                    "",
                    Some(t.position),
                    [t.yaw_deg, t.pitch_deg],
                    t.orientation,
                    &format!("target[{i}] ({name:?})."),
                )
            }
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ScriptedPath {
    #[serde(rename = "keyframe")]
    pub keyframes: Vec<Keyframe>,
    /// the display config's declared targets (`[[tracking.target]]`), whose keyframes' poses
    /// `held` gives by index (`with_targets`)
    #[serde(skip)]
    pub target_names: Vec<String>,
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
            for which in [HeldKind::Wand, HeldKind::LeftHand] {
                k.held(which)
                    .map_err(|e| err(format!("keyframe[{i}].{e}")))?;
            }
            for t in &k.targets {
                k.held(HeldKind::Target(&t.name))
                    .map_err(|e| err(format!("keyframe[{i}].{e}")))?;
            }
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

    /// This path with the display config's declared targets (`[[tracking.target]]`), or which
    /// keyframe names one that is not declared (`path` names the file in errors).
    pub fn with_targets(mut self, names: Vec<String>, path: &Path) -> Result<ScriptedPath> {
        for (i, k) in self.keyframes.iter().enumerate() {
            for (j, t) in k.targets.iter().enumerate() {
                if !names.contains(&t.name) {
                    return Err(VlfError::Config {
                        path: path.to_path_buf(),
                        message: format!(
                            "keyframe[{i}].target[{j}].name: {:?} is not a [[tracking.target]] of the display config (there are: {})",
                            t.name,
                            if names.is_empty() { "none".into() } else { names.join(", ") }
                        ),
                    });
                }
            }
        }
        self.target_names = names;
        Ok(self)
    }

    /// The wand, the left hand and the declared targets at `t` (each as `wand_at`).
    pub fn held(&self, t: f32) -> HeldPoses {
        let mut targets = Targets::default();
        for (slot, name) in targets.iter_mut().zip(&self.target_names) {
            *slot = self.held_at(HeldKind::Target(name), t);
        }
        HeldPoses {
            wand: self.wand_at(t),
            left_hand: self.left_hand_at(t),
            targets,
        }
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
        self.held_at(HeldKind::Wand, t)
    }

    /// The left hand at `t`, as the wand (`wand_at`) from the keyframes' left hands.
    pub fn left_hand_at(&self, t: f32) -> Option<WandPose> {
        self.held_at(HeldKind::LeftHand, t)
    }

    fn held_at(&self, which: HeldKind<'_>, t: f32) -> Option<WandPose> {
        let k = &self.keyframes;
        let i = k.iter().rposition(|f| f.t <= t).unwrap_or(0);
        let (a, b) = (&k[i], &k[(i + 1).min(k.len() - 1)]);
        let wa = a.held(which).ok().flatten()?;
        let Some(wb) = b.held(which).ok().flatten() else {
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
// one per run, never copied about: the live tracker's size (its latest state inline) costs nothing
#[allow(clippy::large_enum_variant)]
pub enum PoseSource {
    Static(Pose),
    Scripted(ScriptedPath),
    Live(std::sync::Mutex<super::live::LiveTracker>),
}

impl PoseSource {
    pub fn from_config(
        tracking: &TrackingConfig,
        start_pose: &StartPose,
        config_path: &Path,
    ) -> Result<PoseSource> {
        let start = Pose::new(
            Vec3::ZERO,
            Vec3::from(start_pose.position),
            start_pose.yaw_deg,
        );
        match tracking {
            TrackingConfig::Static { head, .. } => {
                let head_rotation =
                    tracking
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
            TrackingConfig::Scripted { path, .. } => {
                let path = config_path.parent().unwrap_or(Path::new(".")).join(path);
                let script = ScriptedPath::load(&path)?;
                Ok(PoseSource::Scripted(
                    script.with_targets(tracking.target_names(), &path)?,
                ))
            }
            TrackingConfig::Osc { .. }
            | TrackingConfig::Dtrack { .. }
            | TrackingConfig::Vrpn { .. } => {
                let start = Pose {
                    head: Vec3::new(0.0, 1.7, 0.0),
                    ..start
                };
                let tracker = tracking
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
        self.held_at(tracking, t).wand
    }

    /// The wand, the left hand and the declared targets at `t`, each where tracked: static, the
    /// configuration's `tracking`; scripted, the keyframes'; live, all from one state, each the
    /// last one seen (a hand or target out of view is held where it was, as the wand is; a
    /// target not yet seen is None).
    pub fn held_at(&self, tracking: &TrackingConfig, t: f32) -> HeldPoses {
        match self {
            PoseSource::Static(_) => HeldPoses {
                wand: tracking.static_wand().ok().flatten(),
                left_hand: tracking.static_left_hand().ok().flatten(),
                targets: tracking.static_targets().unwrap_or_default(),
            },
            PoseSource::Scripted(s) => s.held(t),
            PoseSource::Live(tracker) => (tracker.lock().unwrap_or_else(|e| e.into_inner()))
                .latest_state()
                .0
                .held(),
        }
    }

    /// Everything a frame takes from the source at `t`, from one state of it: the pose, the
    /// wand, left hand and targets (`held_at`), the raw poses as the tracker sent them (live sources
    /// only; `RawPoses`) and, live, when the state arrived if no frame was drawn from it yet
    /// (`at_fresh`).
    pub fn frame_at(
        &self,
        tracking: &TrackingConfig,
        t: f32,
    ) -> (Pose, HeldPoses, RawPoses, Option<std::time::Instant>) {
        match self {
            PoseSource::Live(tracker) => {
                let mut tracker = tracker.lock().unwrap_or_else(|e| e.into_inner());
                let state = tracker.latest_state().0;
                (state.pose, state.held(), state.raw, tracker.take_fresh())
            }
            other => (
                other.at(t),
                other.held_at(tracking, t),
                RawPoses::default(),
                None,
            ),
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

/// `vlf track`: print the configured live source's states as they arrive (every one, in
/// order) until `seconds` have passed (None: until the process is stopped), and when it goes
/// quiet or comes back. A static or scripted head is printed once. Returns the states printed.
pub fn track(
    name: &str,
    tracking: &TrackingConfig,
    start_pose: &StartPose,
    config_path: &std::path::Path,
    seconds: Option<Duration>,
    out: &mut dyn std::io::Write,
) -> Result<u64> {
    let write = |out: &mut dyn std::io::Write, line: String| {
        writeln!(out, "{line}").map_err(|e| VlfError::io("stdout", e))
    };
    let source = PoseSource::from_config(tracking, start_pose, config_path)?;
    let PoseSource::Live(tracker) = source else {
        write(
            out,
            format!(
                "{}: tracking is not live ({}); the head:",
                name,
                config_path.display()
            ),
        )?;
        write(
            out,
            super::live::describe(
                0.0,
                &super::live::LiveState::new(source.at(0.0)),
                &tracking.target_names(),
            ),
        )?;
        return Ok(1);
    };
    let mut tracker = tracker.into_inner().unwrap_or_else(|e| e.into_inner());
    write(
        out,
        format!(
            "{}: listening for {} (room metres after calibration)",
            name, tracker.name
        ),
    )?;
    let started = Instant::now();
    let mut printed = 0;
    let mut quiet = false;
    while seconds.is_none_or(|s| started.elapsed() < s) {
        let wait = seconds.map_or(Duration::from_millis(100), |s| {
            s.saturating_sub(started.elapsed())
                .min(Duration::from_millis(100))
        });
        match tracker.next(wait) {
            Some(sample) => {
                if quiet {
                    write(
                        out,
                        format!(
                            "{:8.3} s  live again",
                            sample.received.duration_since(started).as_secs_f64()
                        ),
                    )?;
                    quiet = false;
                }
                write(
                    out,
                    super::live::describe(
                        sample.received.duration_since(started).as_secs_f64(),
                        &sample.state,
                        &tracking.target_names(),
                    ),
                )?;
                printed += 1;
            }
            None => {
                if let (super::live::TrackingStatus::Quiet(d), false) = (tracker.status(), quiet) {
                    write(
                        out,
                        format!(
                            "{:8.3} s  quiet for {:.1} s: holding the last pose",
                            started.elapsed().as_secs_f64(),
                            d.as_secs_f64()
                        ),
                    )?;
                    quiet = true;
                }
            }
        }
    }
    if printed == 0 {
        write(
            out,
            format!(
                "nothing arrived from {} in {:.1} s",
                tracker.name,
                started.elapsed().as_secs_f64()
            ),
        )?;
    }
    Ok(printed)
}
