//! `vlf xr`'s study tools, as `vlf cave` has them (`crate::study`): an experiment script's
//! commands over TCP (`--control ADDR`: the same JSON lines, each acknowledged with the frame
//! where it took effect), the session log (`--log DIR`: the same columns, a row per frame drawn)
//! and the Lab Streaming Layer outlets (`--lsl`). The head is the point between the eyes (their
//! mean pose, `body::head_between`), the wand and the left hand are the right and left
//! controllers' grips, all in the runtime's stage (the log's room), and the photons are due at
//! the runtime's predicted display time. A study's conditions come from a file of their own
//! (`--conditions`: `default_condition` and `[[condition]]` tables, as a display config has
//! them). Commands a headset cannot carry out (the latency test's `flash`; `condition` without
//! `--conditions`) are refused with the reason, changing nothing.

use super::{XrOptions, XrRuntime};
use crate::display::conditions::{study_conditions, ConditionsFile};
use crate::display::frame::{FrameOfViews, ViewLabel};
use crate::error::Result;
use crate::lightfield::LightField;
use crate::study::log::{Drawn, FrameRecord, HeadsetSetup, SessionMeta};
use crate::study::{ControlServer, LslOutlets, Session, SessionLog};
use crate::tracking::pose::WandPose;
use crate::tracking::source::Pose;
use glam::Affine3A;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What `vlf xr` was asked to do for a study (all off by default).
#[derive(Clone, Debug, Default)]
pub struct XrStudy {
    /// `--control ADDR`: listen there for an experiment script (port 0: any free port; the
    /// address is said on stderr as `control: listening on ...`)
    pub control: Option<String>,
    /// `--log DIR`, with the `--scene` it draws (session.json's `light_field`)
    pub log: Option<(PathBuf, PathBuf)>,
    /// `--lsl`: the three Lab Streaming Layer outlets
    pub lsl: bool,
    /// `--conditions FILE`: the study's named conditions (`ConditionsFile`), with the `--scene`
    /// their light fields are made beside
    pub conditions: Option<(PathBuf, PathBuf)>,
}

/// The study's parts, made before the first frame; a `Session` borrows them.
pub(super) struct StudyParts {
    pub control: Option<ControlServer>,
    pub log: Option<SessionLog>,
    pub lsl: Option<LslOutlets>,
}

/// The commands a headset does not take, each with why; `conditions`: whether the run has a
/// `--conditions` file (without one, `condition` is refused too).
pub(super) fn refused(conditions: bool) -> Vec<(&'static str, String)> {
    let mut refused = vec![(
        "flash",
        "flash: the latency test lights a CAVE's walls; a headset's eye images go through its runtime's compositor, which vlf does not light: measure a headset's latency with the runtime's own tools (vlf xr logs the runtime's predicted display time)".into(),
    )];
    if !conditions {
        refused.push((
            "condition",
            "condition: this vlf xr run has no conditions: give them with --conditions FILE.toml ([[condition]] tables as a display config has them)".into(),
        ));
    }
    refused
}

/// The control server, the session log and the LSL outlets `options.study` asks for; `lf` is the
/// light field drawn, `views` the eyes, `near_m` their near plane.
pub(super) fn open(
    options: &XrOptions,
    (lf, adapter, runtime): (&LightField, &str, &XrRuntime),
    views: &[ViewLabel],
    near_m: f32,
) -> Result<StudyParts> {
    let study = &options.study;
    let control = match &study.control {
        Some(addr) => {
            let server = ControlServer::bind(addr)?;
            eprintln!("control: listening on {}", server.addr);
            Some(server)
        }
        None => None,
    };
    let log = match &study.log {
        Some((dir, scene)) => {
            let meta = SessionMeta {
                headset_setup: Some(setup(options, views, near_m)),
                ..meta(scene, (lf, adapter, runtime), views)
            };
            Some(SessionLog::create(dir, meta)?)
        }
        None => None,
    };
    let lsl = match study.lsl {
        true => Some(LslOutlets::open("headset", None, false)?),
        false => None,
    };
    Ok(StudyParts { control, log, lsl })
}

/// session.json of a headset's session: no display config, the runtime named.
fn meta(
    scene: &Path,
    (lf, adapter, runtime): (&LightField, &str, &XrRuntime),
    views: &[ViewLabel],
) -> SessionMeta {
    let views = (views.iter())
        .map(|v| format!("{}-{}", v.wall, v.eye))
        .collect();
    SessionMeta {
        headset: Some(format!("{} ({})", runtime.runtime, runtime.system)),
        ..SessionMeta::starting(scene, lf, adapter, views)
    }
}

/// How the eyes are drawn, for `vlf replay` (session.json's `headset_setup`).
fn setup(options: &XrOptions, views: &[ViewLabel], near_m: f32) -> HeadsetSetup {
    let absolute = |p: &PathBuf| std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
    HeadsetSetup {
        eye_pixels: views.iter().map(|v| v.pixels).collect(),
        antialiasing: options.antialiasing,
        first_hits: options.first_hits,
        exposure: options.exposure,
        objects: options.objects.as_ref().map(absolute),
        conditions: (options.study.conditions.as_ref()).map(|(file, _)| absolute(file)),
        near_m,
    }
}

/// The session of `parts`: the headset's refusals, the names of the moving objects `frame`
/// draws, the `--conditions` (none without).
pub(super) fn session<'p>(
    parts: &'p mut StudyParts,
    frame: &FrameOfViews<'_>,
    file: Option<&ConditionsFile>,
) -> Session<'p> {
    let objects: Vec<String> = (frame.objects().iter())
        .flat_map(|o| o.configs().iter().map(|c| c.name.clone()))
        .collect();
    let conditions = file.map_or(Vec::new(), |f| {
        study_conditions(&f.conditions, f.default_condition.as_deref())
    });
    let refusals = refused(!conditions.is_empty());
    Session::new(parts.log.as_mut(), parts.control.as_ref())
        .with_display(None, parts.lsl.take())
        .with_objects(objects)
        .with_conditions(conditions)
        .refusing(refusals)
}

/// When a frame's photons are due on this process's clock: the runtime's predicted display
/// time `display_ns`, through `clock` (an instant and the runtime's time then; None without
/// XR_KHR_convert_timespec_time).
pub(super) fn due(clock: Option<(Instant, i64)>, display_ns: i64) -> Option<Instant> {
    let (at, now_ns) = clock?;
    Some(at + Duration::from_nanos((display_ns - now_ns).max(0) as u64))
}

/// What a frame drew, as a row of the log (the session adds the block, trial, events and
/// flash): `room` the navigation, `head` and `hands` (left, right) in the stage.
pub(super) struct Drew {
    pub frame: u64,
    pub room: Pose,
    pub head: Affine3A,
    pub hands: [Option<WandPose>; 2],
    /// each eye as located
    pub eyes: Vec<crate::study::log::EyeRecord>,
    pub cpu_ms: f64,
    pub pose_to_submit_ms: f64,
    pub object_time_s: Option<f64>,
}

/// The log's row of a frame drawn by `frame_of_views`.
pub(super) fn record(drew: Drew, time_s: f64, frame_of_views: &FrameOfViews<'_>) -> FrameRecord {
    let (_, rotation, head) = drew.head.to_scale_rotation_translation();
    let [left, right] = drew.hands;
    FrameRecord {
        frame: drew.frame,
        time_s,
        drawn: Drawn::Shown,
        pose: Pose {
            head,
            head_rotation: rotation.normalize(),
            room_position: drew.room.room_position,
            room_yaw_deg: drew.room.room_yaw_deg,
        },
        wand: right,
        left_hand: left,
        // the headset tracks no targets
        targets: Default::default(),
        // the GPU's times come back frames late (frames in flight): in the report
        gpu_ms: None,
        cpu_ms: Some(drew.cpu_ms),
        block: 0,
        trial: 0,
        pose_to_submit_ms: Some(drew.pose_to_submit_ms),
        pose_to_photon_ms: None,
        object_time_s: drew.object_time_s,
        raw: Default::default(),
        views: frame_of_views.drawn().to_vec(),
        events: String::new(),
        condition: String::new(),
        objects: Some(frame_of_views.object_switches()),
        flash: None,
        eyes: drew.eyes,
    }
}
