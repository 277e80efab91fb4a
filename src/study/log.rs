//! The session log (`vlf cave --log DIR`): `DIR/session.json` says what ran (the display
//! configuration, the light field, the views, the adapter, when) and documents every column;
//! `DIR/frames.csv` has one row per frame drawn, written as the run goes and flushed to the disk at
//! least once a second, so a crash (even SIGKILL) loses at most the last second; the same rows go
//! to `DIR/frames.parquet/` (`log/parquet.rs`), a part each time the CSV is flushed.
//!
//! A row: the frame number, seconds since the session began, how the frame was drawn, the head pose
//! in the room (after calibration) and the navigation (where the room is in the world), the wand,
//! the frame's GPU and CPU milliseconds, the latencies, the left hand, and per view what it was
//! drawn with (eye rays per pixel, the paced tiles' count and share, mirror reflections, fixed
//! work), a headset's eyes, each declared tracked target (`[[tracking.target]]`, calibrated and
//! raw), then the frame's events. Floats are written in Rust's shortest form that reads back to
//! the same bits, so `vlf replay` (`SessionLog::read`) draws exactly what the run drew.

pub mod parquet;

use crate::error::{Result, VlfError};
use crate::render::budget::ViewSettings;
use crate::tracking::pose::{Pose, RawPoses, Targets, WandPose, MAX_TARGETS};
use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The log's own format version (session.json's `format`): 2 added `pose_to_photon_ms`, 3 the
/// left hand's columns after it, 4 `condition`, `object_time_s` and the raw (uncalibrated) poses
/// after those, 5 the moving objects' switches (`objects_hidden`, `shadows`, `reflections`) and
/// the latency test's `flash` after the raw poses, 6 a headset's eyes (`EYE_COLUMNS` after each
/// view's, and session.json's `headset_setup`), 7 the declared tracked targets (session.json's
/// `targets`, and `TARGET_COLUMNS` for each after the views and eyes); `SessionLog::read` reads
/// 1 to 6 too (without them).
pub const LOG_FORMAT: u32 = 7;
/// The longest a row waits in memory before it is on the disk.
pub const FLUSH_EVERY: Duration = Duration::from_secs(1);

/// What ran: `DIR/session.json`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SessionMeta {
    pub format: u32,
    pub vlf_version: String,
    /// the display configuration, as an absolute path
    pub display_config: PathBuf,
    /// the light field drawn: a .vlf file, or a scene.toml / glTF propagated at `vlf cave`'s
    /// settings (propagation repeats bit for bit)
    pub light_field: PathBuf,
    /// where `light_field` is a scene: the settings it was propagated with (replay propagates
    /// it again with them); None for a .vlf file
    pub propagation: Option<crate::params::PropagationParams>,
    /// the scene's hash (`LightFieldMeta::scene_hash`): replay checks it drew the same scene
    pub scene_hash: String,
    pub adapter: String,
    /// seconds since the Unix epoch when the session began
    pub started_unix_s: f64,
    /// the views of every frame, in the order of the per-view columns: `<wall>-<eye>`
    pub views: Vec<String>,
    /// every column of frames.csv: name and meaning
    pub columns: Vec<(String, String)>,
    /// a headset's session (`vlf xr --log`): the OpenXR runtime and its system; the head is
    /// then the point between the eyes, the wand and left hand the controllers' grips, all in
    /// the runtime's stage, and `display_config` is empty (None: a CAVE's)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub headset: Option<String>,
    /// a headset's session from format 6: how its eyes were drawn (their located poses and
    /// fields of view are in each row), which `vlf replay` draws them again with
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub headset_setup: Option<HeadsetSetup>,
    /// from format 7: the display config's tracked targets (`[[tracking.target]]`), in the
    /// order of the per-target columns (`target:<name>`, ...); empty: none declared
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<String>,
}

/// How a headset session drew its eyes (`vlf xr --log`), besides what each row holds: what
/// `vlf replay` needs to draw them again.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HeadsetSetup {
    /// each eye's image, pixels (width, height), in `views` order
    pub eye_pixels: Vec<[u32; 2]>,
    /// `--aa`: eye rays per pixel where not paced
    pub antialiasing: u32,
    /// `--first-hits`
    pub first_hits: crate::render::raster::FirstHits,
    /// `--exposure` (a condition's exposure multiplies it)
    pub exposure: f32,
    /// `--objects`, as an absolute path (None: no moving objects)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objects: Option<PathBuf>,
    /// `--conditions`, as an absolute path (None: none)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub conditions: Option<PathBuf>,
    /// the eyes' near plane, metres
    pub near_m: f32,
}

/// A headset's eye as the runtime located it for a frame (`xrLocateViews` at the predicted
/// display time): its pose in the stage and its field of view. `vlf replay` draws the eye from
/// it; the head is the point between the eyes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeRecord {
    /// metres, in the stage
    pub position: [f32; 3],
    /// stage from eye, quaternion x, y, z, w
    pub orientation: [f32; 4],
    /// radians from the view direction: left, right, up, down (left and down usually negative)
    pub fov: [f32; 4],
}

impl SessionMeta {
    /// What a session starting now records of the light field `lf` (made from `source`: a
    /// `.vlf`, or a scene with `lf`'s propagation settings), drawn on `adapter` into `views`;
    /// a CAVE's sets `display_config`, a headset's `headset`.
    pub fn starting(
        source: &Path,
        lf: &crate::lightfield::LightField,
        adapter: &str,
        views: Vec<String>,
    ) -> SessionMeta {
        let is_vlf = crate::lightfield::file::is_vlf_path(source);
        SessionMeta {
            format: LOG_FORMAT,
            vlf_version: env!("CARGO_PKG_VERSION").into(),
            display_config: PathBuf::new(),
            light_field: std::fs::canonicalize(source).unwrap_or_else(|_| source.to_path_buf()),
            propagation: (!is_vlf).then(|| lf.meta.params.clone()),
            scene_hash: lf.meta.scene_hash.clone(),
            adapter: adapter.into(),
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0.0, |d| d.as_secs_f64()),
            views,
            columns: Vec::new(),
            headset: None,
            headset_setup: None,
            targets: Vec::new(),
        }
    }
}

/// How a frame was drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Drawn {
    /// submitted and timed (it counts in the frame-time report)
    Timed,
    /// drawn again view by view and read back (the headless run's last frame, its images)
    ReadBack,
    /// drawn and presented on the windows
    Shown,
}

impl Drawn {
    const ALL: [Drawn; 3] = [Drawn::Timed, Drawn::ReadBack, Drawn::Shown];

    pub(crate) fn name(self) -> &'static str {
        match self {
            Drawn::Timed => "timed",
            Drawn::ReadBack => "read_back",
            Drawn::Shown => "shown",
        }
    }
}

/// One frame of the log.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRecord {
    pub frame: u64,
    pub time_s: f64,
    pub drawn: Drawn,
    pub pose: Pose,
    pub wand: Option<WandPose>,
    /// the tracked left hand in the room, where one is given
    pub left_hand: Option<WandPose>,
    /// the declared targets in the room (`SessionMeta::targets`, by index), each where seen;
    /// the slots past the declared ones are not written (None when read back)
    pub targets: Targets,
    /// all the frame's passes on the GPU, and the frame on the CPU (None where not timed)
    pub gpu_ms: Option<f64>,
    pub cpu_ms: Option<f64>,
    /// the experiment's block and trial as the script last set them (0 before it does)
    pub block: u32,
    pub trial: u32,
    /// from the pose's arrival (live tracking) or sampling (scripted, static) to the frame's
    /// submission to the GPU, ms (None where not measured: a frame read back)
    pub pose_to_submit_ms: Option<f64>,
    /// from the same to the frame's predicted photons (its GPU end plus one refresh period),
    /// ms (None where not shown: a frame read back)
    pub pose_to_photon_ms: Option<f64>,
    /// the time that moved the keyframed objects in this frame, seconds (`FrameOfViews::
    /// set_object_time`; None in a log before format 4)
    pub object_time_s: Option<f64>,
    /// the head, wand, left hand and targets as the tracker sent them, before the calibration
    /// (none from a source without a tracker frame: static, scripted)
    pub raw: RawPoses,
    /// each view's settings, in `SessionMeta::views` order
    pub views: Vec<ViewSettings>,
    /// what happened at this frame (free text; empty for none)
    pub events: String,
    /// the study's condition in effect (the display config's `[[condition]]` name; empty
    /// without conditions)
    pub condition: String,
    /// the moving objects as the frame drew them: which were hidden, their shadows and
    /// reflections (as the script's `show`/`hide`/`shadows`/`reflections` and the condition
    /// left them; None in a log before format 5)
    pub objects: Option<ObjectSwitches>,
    /// the latency test (`flash`): Some(true) every wall full white this frame, Some(false)
    /// black, None the scene
    pub flash: Option<bool>,
    /// a headset's eyes as located for this frame, in `SessionMeta::views` order (empty for a
    /// CAVE's views, which the head and the walls place)
    pub eyes: Vec<EyeRecord>,
}

/// The moving objects' switches in a frame (`FrameRecord::objects`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ObjectSwitches {
    /// the `[[object]]` names hidden, in the display config's order
    pub hidden: Vec<String>,
    /// their shadows on the scene
    pub shadows: bool,
    /// their reflections in the scene's mirrors
    pub reflections: bool,
}

impl ObjectSwitches {
    /// Every object shown, with shadows and reflections: as a run starts without conditions.
    pub fn all_on() -> ObjectSwitches {
        ObjectSwitches {
            hidden: Vec::new(),
            shadows: true,
            reflections: true,
        }
    }
}

/// What separates the hidden objects' names in `objects_hidden` (an `[[object]]` name never
/// holds it: `ObjectConfig::check`).
pub const HIDDEN_SEPARATOR: char = '|';

/// The columns before the per-view ones, with their meaning.
const FRAME_COLUMNS: [(&str, &str); 66] = [
    ("frame", "frame number, from 0"),
    (
        "time_s",
        "seconds since the session began, when the frame's drawing began",
    ),
    (
        "drawn",
        "timed (submitted and timed), read_back (drawn again and read back) or shown (presented on the windows)",
    ),
    (
        "head_x",
        "head position in the room, metres (after calibration)",
    ),
    ("head_y", "head position in the room, metres"),
    ("head_z", "head position in the room, metres"),
    ("head_qx", "head rotation, room from head, quaternion x"),
    ("head_qy", "head rotation, quaternion y"),
    ("head_qz", "head rotation, quaternion z"),
    ("head_qw", "head rotation, quaternion w"),
    (
        "room_x",
        "navigation: the room's origin in the world, metres",
    ),
    (
        "room_y",
        "navigation: the room's origin in the world, metres",
    ),
    (
        "room_z",
        "navigation: the room's origin in the world, metres",
    ),
    (
        "room_yaw_deg",
        "navigation: the room's turn about the world's up axis, degrees",
    ),
    (
        "wand",
        "1 where a wand pose is given, else 0 (its columns then 0)",
    ),
    ("wand_x", "wand position in the room, metres"),
    ("wand_y", "wand position in the room, metres"),
    ("wand_z", "wand position in the room, metres"),
    ("wand_qx", "wand rotation, quaternion x"),
    ("wand_qy", "wand rotation, quaternion y"),
    ("wand_qz", "wand rotation, quaternion z"),
    ("wand_qw", "wand rotation, quaternion w"),
    (
        "gpu_ms",
        "all the frame's passes on the GPU (timestamps), ms; empty when not timed",
    ),
    (
        "cpu_ms",
        "the frame on the CPU, submission to the GPU's end, ms; empty when not timed",
    ),
    (
        "block",
        "the experiment's block, as the script's `trial` command last set it (0 before)",
    ),
    (
        "trial",
        "the experiment's trial in its block (0 before the script sets one)",
    ),
    (
        "pose_to_submit_ms",
        "from the pose's arrival (live tracking) or sampling (scripted, static) to the frame's submission to the GPU, ms; the photons follow after the GPU's time and the display's scan-out; empty where not measured",
    ),
    (
        "pose_to_photon_ms",
        "from the same to the frame's predicted photons: its GPU end plus one refresh period (half a period on average to the vertical blank, half to scan out to the picture's middle; the GPU end alone without refresh_hz; a projector's input lag comes on top), ms; empty where not shown",
    ),
    (
        "left_hand",
        "1 where a left hand pose is given, else 0 (its columns then 0)",
    ),
    ("left_hand_x", "left hand position in the room, metres"),
    ("left_hand_y", "left hand position in the room, metres"),
    ("left_hand_z", "left hand position in the room, metres"),
    ("left_hand_qx", "left hand rotation, quaternion x"),
    ("left_hand_qy", "left hand rotation, quaternion y"),
    ("left_hand_qz", "left hand rotation, quaternion z"),
    ("left_hand_qw", "left hand rotation, quaternion w"),
    (
        "condition",
        "the study's condition in effect (the display config's [[condition]] name, as the script's `condition` command or default_condition set it); empty without conditions",
    ),
    (
        "object_time_s",
        "the time that placed the keyframed moving objects in this frame, seconds (replay draws them at it)",
    ),
    (
        "raw_head",
        "1 where the tracker has sent a head, else 0 (static and scripted sources have none; its columns then 0)",
    ),
    (
        "raw_head_x",
        "head position as the tracker sent it, before [tracking.calibration]: the tracker's frame and units",
    ),
    ("raw_head_y", "raw head position, tracker units"),
    ("raw_head_z", "raw head position, tracker units"),
    (
        "raw_head_qx",
        "raw head rotation in the tracker's frame, quaternion x (the last one sent; identity before one)",
    ),
    ("raw_head_qy", "raw head rotation, quaternion y"),
    ("raw_head_qz", "raw head rotation, quaternion z"),
    ("raw_head_qw", "raw head rotation, quaternion w"),
    (
        "raw_wand",
        "1 where the tracker has sent a wand, else 0 (its columns then 0)",
    ),
    (
        "raw_wand_x",
        "wand position as the tracker sent it, before calibration, tracker units",
    ),
    ("raw_wand_y", "raw wand position, tracker units"),
    ("raw_wand_z", "raw wand position, tracker units"),
    ("raw_wand_qx", "raw wand rotation, quaternion x"),
    ("raw_wand_qy", "raw wand rotation, quaternion y"),
    ("raw_wand_qz", "raw wand rotation, quaternion z"),
    ("raw_wand_qw", "raw wand rotation, quaternion w"),
    (
        "raw_left_hand",
        "1 where the tracker has sent a left hand, else 0 (its columns then 0)",
    ),
    (
        "raw_left_hand_x",
        "left hand position as the tracker sent it, before calibration, tracker units",
    ),
    ("raw_left_hand_y", "raw left hand position, tracker units"),
    ("raw_left_hand_z", "raw left hand position, tracker units"),
    ("raw_left_hand_qx", "raw left hand rotation, quaternion x"),
    ("raw_left_hand_qy", "raw left hand rotation, quaternion y"),
    ("raw_left_hand_qz", "raw left hand rotation, quaternion z"),
    ("raw_left_hand_qw", "raw left hand rotation, quaternion w"),
    (
        "objects_hidden",
        "the moving objects hidden in this frame ([[object]] names, separated by |), as the script's show/hide and the condition left them; empty: every object shown (replay draws the frame so; format 5 on)",
    ),
    (
        "shadows",
        "1: the moving objects cast shadows on the scene in this frame, 0: not (the script's `shadows` and the condition; replay draws the frame so)",
    ),
    (
        "reflections",
        "1: the moving objects show in the scene's mirrors in this frame, 0: not (the script's `reflections` and the condition)",
    ),
    (
        "flash",
        "the latency test (the script's `flash`): white (every wall full white this frame), black (every wall black until the test ends) or empty (the scene); replay's images are the same",
    ),
];

/// How many of `FRAME_COLUMNS` a log of `format` has: 1 lacks pose_to_photon_ms, 2 the left
/// hand's eight, 3 the condition, object_time_s and the raw poses, 4 the objects' switches and
/// the flash.
fn frame_columns(format: u32) -> usize {
    match format {
        1 => 27,
        2 => 28,
        3 => 36,
        4 => 62,
        _ => FRAME_COLUMNS.len(),
    }
}

/// The `flash` column's text for a frame's latency test.
pub(crate) fn flash_name(flash: Option<bool>) -> &'static str {
    match flash {
        Some(true) => "white",
        Some(false) => "black",
        None => "",
    }
}

/// A wand's or hand's columns: 1 and its position and rotation, or 0 and zeros.
fn held_cells(held: Option<&WandPose>) -> impl Iterator<Item = String> {
    let (given, p, q) = match held {
        Some(w) => (1, w.position, w.rotation),
        None => (0, Vec3::ZERO, Quat::from_xyzw(0.0, 0.0, 0.0, 0.0)),
    };
    let floats = [p.x, p.y, p.z, q.x, q.y, q.z, q.w];
    std::iter::once(given.to_string()).chain(floats.map(|v| v.to_string()))
}
/// Each view's columns, after the frame's; then the events.
const VIEW_COLUMNS: [(&str, &str); 5] = [
    (
        "samples",
        "eye rays per pixel in the view's tiles that are not paced",
    ),
    ("paced_samples", "eye rays per pixel in the paced tiles"),
    (
        "paced_fraction",
        "the share of the view's 8x8 tiles drawn with paced_samples",
    ),
    ("bounces", "mirror reflections traced per eye ray"),
    (
        "fixed_work",
        "1: every pixel traces its reflections whatever it sees",
    ),
];

/// A headset's eye columns, after its views' (format 6 on; a CAVE's log has none).
const EYE_COLUMNS: [(&str, &str); 11] = [
    (
        "eye_x",
        "the eye's position in the stage (the headset's room) as the runtime located it for the frame's predicted display time, metres",
    ),
    ("eye_y", "the eye's position in the stage, metres"),
    ("eye_z", "the eye's position in the stage, metres"),
    ("eye_qx", "the eye's rotation, stage from eye, quaternion x"),
    ("eye_qy", "the eye's rotation, quaternion y"),
    ("eye_qz", "the eye's rotation, quaternion z"),
    ("eye_qw", "the eye's rotation, quaternion w"),
    (
        "fov_left",
        "the eye's field of view: its left edge's angle from the view direction, radians (negative: to the left)",
    ),
    ("fov_right", "the field of view's right edge, radians"),
    ("fov_up", "the field of view's upper edge, radians"),
    (
        "fov_down",
        "the field of view's lower edge, radians (negative: below)",
    ),
];

/// A declared target's columns (format 7 on), after the views' and eyes': `target:<name>` and
/// `raw_target:<name>`, each as the left hand's eight (`<column>` 1 or 0, then `_x` .. `_qw`).
const TARGET_COLUMNS: [(&str, &str); 16] = [
    (
        "target:",
        "1 where the tracked target (the display config's [[tracking.target]] of this name) has been seen, else 0 (its columns then 0); follow = \"target\" objects stand on it",
    ),
    ("_x", "the target's position in the room, metres (after calibration)"),
    ("_y", "the target's position in the room, metres"),
    ("_z", "the target's position in the room, metres"),
    ("_qx", "the target's rotation, quaternion x"),
    ("_qy", "the target's rotation, quaternion y"),
    ("_qz", "the target's rotation, quaternion z"),
    ("_qw", "the target's rotation, quaternion w"),
    (
        "raw_target:",
        "1 where the tracker has sent the target, else 0 (static and scripted sources have no tracker frame; its columns then 0)",
    ),
    (
        "_x",
        "the target's position as the tracker sent it, before [tracking.calibration], tracker units",
    ),
    ("_y", "raw target position, tracker units"),
    ("_z", "raw target position, tracker units"),
    ("_qx", "raw target rotation in the tracker's frame, quaternion x"),
    ("_qy", "raw target rotation, quaternion y"),
    ("_qz", "raw target rotation, quaternion z"),
    ("_qw", "raw target rotation, quaternion w"),
];

/// The documented columns of a log of `views`; `eyes`: a headset's, with each eye's pose and
/// field of view; `targets`: the declared tracked targets' names.
pub(crate) fn columns(views: &[String], eyes: bool, targets: &[String]) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = (FRAME_COLUMNS.iter())
        .map(|(n, m)| (n.to_string(), m.to_string()))
        .collect();
    for v in views {
        for (n, m) in VIEW_COLUMNS {
            out.push((format!("{v}:{n}"), format!("view {v}: {m}")));
        }
    }
    for v in views.iter().filter(|_| eyes) {
        for (n, m) in EYE_COLUMNS {
            out.push((format!("{v}:{n}"), format!("view {v}: {m}")));
        }
    }
    for t in targets {
        for half in TARGET_COLUMNS.chunks(8) {
            let given = format!("{}{t}", half[0].0);
            out.push((given.clone(), half[0].1.to_string()));
            for (n, m) in &half[1..] {
                out.push((format!("{given}{n}"), format!("target {t}: {m}")));
            }
        }
    }
    out.push((
        "events".into(),
        "what happened at this frame, quoted".into(),
    ));
    out
}

/// Writes a session: `create`, then `record` every frame.
pub struct SessionLog {
    dir: PathBuf,
    frames: std::io::BufWriter<std::fs::File>,
    parquet: parquet::FramesParquet,
    views: usize,
    /// a headset's: each row has its eyes
    eyes: bool,
    /// the declared targets: each row has this many
    targets: usize,
    began: Instant,
    last_flush: Instant,
}

impl SessionLog {
    /// Start a session log in `dir` (made if missing). Refuses a folder that holds a log
    /// already: a session is never written over.
    pub fn create(dir: &Path, mut meta: SessionMeta) -> Result<SessionLog> {
        std::fs::create_dir_all(dir).map_err(|e| VlfError::io(dir, e))?;
        let (json, csv) = (dir.join("session.json"), dir.join("frames.csv"));
        let parquet = dir.join(parquet::PARQUET_DIR);
        if json.exists() || csv.exists() || parquet.exists() {
            return Err(VlfError::io(
                &csv,
                std::io::Error::new(
                    std::io::ErrorKind::AlreadyExists,
                    "a session log is there already: give --log a new folder",
                ),
            ));
        }
        let eyes = meta.headset_setup.is_some();
        if meta.targets.len() > MAX_TARGETS {
            return Err(VlfError::Display(format!(
                "a session log of {} tracked targets: at most {MAX_TARGETS} are tracked",
                meta.targets.len()
            )));
        }
        meta.columns = columns(&meta.views, eyes, &meta.targets);
        let text = serde_json::to_string_pretty(&meta).expect("metadata serialises");
        std::fs::write(&json, text).map_err(|e| VlfError::write(&json, e))?;
        let file = std::fs::File::create(&csv).map_err(|e| VlfError::write(&csv, e))?;
        let mut frames = std::io::BufWriter::new(file);
        let header: Vec<String> = meta.columns.iter().map(|(n, _)| n.clone()).collect();
        writeln!(frames, "{}", header.join(",")).map_err(|e| VlfError::io(&csv, e))?;
        let now = Instant::now();
        let mut log = SessionLog {
            dir: dir.to_path_buf(),
            frames,
            parquet: parquet::FramesParquet::create(dir, header, meta.targets.len())?,
            views: meta.views.len(),
            eyes,
            targets: meta.targets.len(),
            began: now,
            last_flush: now,
        };
        log.flush()?;
        Ok(log)
    }

    /// Seconds since the session began.
    pub fn elapsed_s(&self) -> f64 {
        self.began.elapsed().as_secs_f64()
    }

    /// One frame's row; on the disk within `FLUSH_EVERY`.
    pub fn record(&mut self, r: &FrameRecord) -> Result<()> {
        if r.views.len() != self.views {
            return Err(VlfError::Display(format!(
                "a session log row of {} views for a session of {}",
                r.views.len(),
                self.views
            )));
        }
        let eyes = if self.eyes { self.views } else { 0 };
        if r.eyes.len() != eyes {
            return Err(VlfError::Display(format!(
                "a session log row of {} eyes for a session of {eyes}",
                r.eyes.len()
            )));
        }
        let row = row_text(r, self.targets);
        let csv = self.dir.join("frames.csv");
        writeln!(self.frames, "{row}").map_err(|e| VlfError::io(&csv, e))?;
        self.parquet.push(r);
        if self.last_flush.elapsed() >= FLUSH_EVERY {
            self.flush()?;
        }
        Ok(())
    }

    /// Everything recorded so far onto the disk.
    pub fn flush(&mut self) -> Result<()> {
        let csv = self.dir.join("frames.csv");
        self.frames.flush().map_err(|e| VlfError::io(&csv, e))?;
        self.frames
            .get_ref()
            .sync_data()
            .map_err(|e| VlfError::io(&csv, e))?;
        self.parquet.flush()?;
        self.last_flush = Instant::now();
        Ok(())
    }

    /// A session log back: what ran and every frame, in order. Errors name the file and line.
    pub fn read(dir: &Path) -> Result<(SessionMeta, Vec<FrameRecord>)> {
        let json = dir.join("session.json");
        let text = std::fs::read_to_string(&json).map_err(|e| VlfError::io(&json, e))?;
        let meta: SessionMeta = serde_json::from_str(&text).map_err(|e| {
            VlfError::Display(format!(
                "{}: not a vlf session log ({e}); `vlf cave --log DIR` writes one",
                json.display()
            ))
        })?;
        if !(1..=LOG_FORMAT).contains(&meta.format) {
            return Err(VlfError::Display(format!(
                "{}: session log format {}, this vlf reads 1 to {LOG_FORMAT}: read it with the vlf that wrote it",
                json.display(),
                meta.format
            )));
        }
        let csv = dir.join("frames.csv");
        let text = std::fs::read_to_string(&csv).map_err(|e| VlfError::io(&csv, e))?;
        // every row ends with a newline: a last line without one was cut short by a crash
        let complete = match text.ends_with('\n') {
            true => text.as_str(),
            false => {
                log::warn!("{}: the last row is incomplete, left out", csv.display());
                text.rfind('\n').map_or("", |end| &text[..=end])
            }
        };
        let mut records = Vec::new();
        if meta.targets.len() > MAX_TARGETS {
            return Err(VlfError::Display(format!(
                "{}: {} tracked targets, this vlf tracks at most {MAX_TARGETS}",
                json.display(),
                meta.targets.len()
            )));
        }
        // the targets' columns came with format 7
        let targets = if meta.format >= 7 {
            meta.targets.len()
        } else {
            0
        };
        for (n, line) in complete.lines().enumerate().skip(1) {
            let shape = (frame_columns(meta.format), meta.views.len());
            let r = parse_row(line, shape, meta.headset_setup.is_some(), targets)
                .map_err(|why| VlfError::Display(format!("{}:{}: {why}", csv.display(), n + 1)))?;
            records.push(r);
        }
        Ok((meta, records))
    }
}

impl Drop for SessionLog {
    fn drop(&mut self) {
        if let Err(e) = self.flush() {
            log::warn!("the session log's last rows: {e}");
        }
    }
}

/// A row of frames.csv, with the first `targets` targets.
fn row_text(r: &FrameRecord, targets: usize) -> String {
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    let (p, q, room) = (r.pose.head, r.pose.head_rotation, r.pose.room_position);
    let mut cells: Vec<String> = vec![
        r.frame.to_string(),
        r.time_s.to_string(),
        r.drawn.name().into(),
    ];
    let floats = [
        p.x,
        p.y,
        p.z,
        q.x,
        q.y,
        q.z,
        q.w,
        room.x,
        room.y,
        room.z,
        r.pose.room_yaw_deg,
    ];
    cells.extend(floats.iter().map(f32::to_string));
    cells.extend(held_cells(r.wand.as_ref()));
    cells.push(opt(r.gpu_ms));
    cells.push(opt(r.cpu_ms));
    cells.push(r.block.to_string());
    cells.push(r.trial.to_string());
    cells.push(opt(r.pose_to_submit_ms));
    cells.push(opt(r.pose_to_photon_ms));
    cells.extend(held_cells(r.left_hand.as_ref()));
    cells.push(r.condition.clone());
    cells.push(opt(r.object_time_s));
    for raw in [r.raw.head, r.raw.wand, r.raw.left_hand] {
        cells.extend(held_cells(raw.as_ref()));
    }
    // a record without switches (read from an older log) written as every object on
    let objects = r.objects.clone().unwrap_or_else(ObjectSwitches::all_on);
    cells.push(objects.hidden.join(&HIDDEN_SEPARATOR.to_string()));
    cells.push(u32::from(objects.shadows).to_string());
    cells.push(u32::from(objects.reflections).to_string());
    cells.push(flash_name(r.flash).into());
    for v in &r.views {
        cells.push(v.samples_per_pixel.to_string());
        cells.push(v.paced_samples.to_string());
        cells.push(v.paced_fraction.to_string());
        cells.push(v.mirror_bounces.to_string());
        cells.push(v.fixed_work.to_string());
    }
    for e in &r.eyes {
        let floats = e.position.iter().chain(&e.orientation).chain(&e.fov);
        cells.extend(floats.map(f32::to_string));
    }
    for (target, raw) in r.targets.iter().zip(&r.raw.targets).take(targets) {
        cells.extend(held_cells(target.as_ref()));
        cells.extend(held_cells(raw.as_ref()));
    }
    cells.push(format!("\"{}\"", r.events.replace('"', "\"\"")));
    cells.join(",")
}

/// A row's cell `i` as a number, or why not.
fn cell<T: std::str::FromStr>(cells: &[&str], i: usize) -> std::result::Result<T, String> {
    cells[i]
        .parse()
        .map_err(|_| format!("not a number: {:?}", cells[i]))
}

/// A row's per-view cells (from the first view's): `views` views' settings, then `eyes` eyes.
fn per_view(
    cells: &[&str],
    views: usize,
    eyes: usize,
) -> std::result::Result<(Vec<ViewSettings>, Vec<EyeRecord>), String> {
    let settings = (0..views)
        .map(|k| {
            let c = k * VIEW_COLUMNS.len();
            Ok(ViewSettings {
                samples_per_pixel: cell(cells, c)?,
                paced_samples: cell(cells, c + 1)?,
                paced_fraction: cell(cells, c + 2)?,
                mirror_bounces: cell(cells, c + 3)?,
                fixed_work: cell(cells, c + 4)?,
            })
        })
        .collect::<std::result::Result<Vec<_>, String>>()
        .map_err(|e| format!("a view's column: {e}"))?;
    let first_eye = views * VIEW_COLUMNS.len();
    let eyes = (0..eyes)
        .map(|k| {
            let c = first_eye + k * EYE_COLUMNS.len();
            let v = (c..c + EYE_COLUMNS.len())
                .map(|i| cell::<f32>(cells, i))
                .collect::<std::result::Result<Vec<f32>, String>>()?;
            Ok(EyeRecord {
                position: [v[0], v[1], v[2]],
                orientation: [v[3], v[4], v[5], v[6]],
                fov: [v[7], v[8], v[9], v[10]],
            })
        })
        .collect::<std::result::Result<Vec<_>, String>>()
        .map_err(|e| format!("an eye's column: {e}"))?;
    Ok((settings, eyes))
}

/// A row's `count` targets from its cell `first` on (`TARGET_COLUMNS` each): calibrated and raw.
fn targets_of(
    cells: &[&str],
    first: usize,
    count: usize,
) -> std::result::Result<(Targets, Targets), String> {
    // one pose's eight columns from `c`: 1 or 0, then its position and rotation
    let pose = |c: usize| -> std::result::Result<Option<WandPose>, String> {
        let f = |i: usize| cell::<f32>(cells, i).map_err(|e| format!("column {}: {e}", i + 1));
        match cells[c] {
            "0" => Ok(None),
            "1" => Ok(Some(WandPose {
                position: Vec3::new(f(c + 1)?, f(c + 2)?, f(c + 3)?),
                rotation: Quat::from_xyzw(f(c + 4)?, f(c + 5)?, f(c + 6)?, f(c + 7)?),
            })),
            other => Err(format!("column {}: {other:?} is not 1 or 0", c + 1)),
        }
    };
    let (mut tracked, mut raw) = (Targets::default(), Targets::default());
    let slots = tracked.iter_mut().zip(raw.iter_mut()).take(count);
    for (k, (calibrated, sent)) in slots.enumerate() {
        let c = first + k * TARGET_COLUMNS.len();
        *calibrated = pose(c)?;
        *sent = pose(c + TARGET_COLUMNS.len() / 2)?;
    }
    Ok((tracked, raw))
}

/// A row back (`frame_columns` of `FRAME_COLUMNS`, then `views` views, with `eyes` as many
/// eyes, then `targets` targets), or why it is not one.
fn parse_row(
    line: &str,
    (frame_columns, views): (usize, usize),
    eyes: bool,
    targets: usize,
) -> std::result::Result<FrameRecord, String> {
    let eye_count = if eyes { views } else { 0 };
    let first_target = frame_columns + views * VIEW_COLUMNS.len() + eye_count * EYE_COLUMNS.len();
    let fixed = first_target + targets * TARGET_COLUMNS.len();
    let mut parts = line.splitn(fixed + 1, ',');
    let cells: Vec<&str> = parts.by_ref().take(fixed).collect();
    let events = parts.next().ok_or("fewer columns than the header")?;
    let events = (events.strip_prefix('"').and_then(|e| e.strip_suffix('"')))
        .ok_or("the events column is not quoted")?
        .replace("\"\"", "\"");
    let f = |i: usize| -> std::result::Result<f32, String> {
        cells[i]
            .parse()
            .map_err(|_| format!("column {} is not a number: {:?}", i + 1, cells[i]))
    };
    let u = |i: usize| -> std::result::Result<u32, String> {
        cells[i]
            .parse()
            .map_err(|_| format!("column {} is not a count: {:?}", i + 1, cells[i]))
    };
    let opt = |i: usize| -> std::result::Result<Option<f64>, String> {
        match cells[i] {
            "" => Ok(None),
            c => c
                .parse()
                .map(Some)
                .map_err(|_| format!("column {} is not a number", i + 1)),
        }
    };
    let drawn = (Drawn::ALL.into_iter())
        .find(|d| d.name() == cells[2])
        .ok_or_else(|| format!("column 3: {:?} is not timed, read_back or shown", cells[2]))?;
    let pose = Pose {
        head: Vec3::new(f(3)?, f(4)?, f(5)?),
        head_rotation: Quat::from_xyzw(f(6)?, f(7)?, f(8)?, f(9)?),
        room_position: Vec3::new(f(10)?, f(11)?, f(12)?),
        room_yaw_deg: f(13)?,
    };
    // a wand's or hand's eight columns from `c` (a log without them: none)
    let held = |c: usize| -> std::result::Result<Option<WandPose>, String> {
        if c + 8 > frame_columns || u(c)? != 1 {
            return Ok(None);
        }
        Ok(Some(WandPose {
            position: Vec3::new(f(c + 1)?, f(c + 2)?, f(c + 3)?),
            rotation: Quat::from_xyzw(f(c + 4)?, f(c + 5)?, f(c + 6)?, f(c + 7)?),
        }))
    };
    let switch = |i: usize| -> std::result::Result<bool, String> {
        match cells[i] {
            "1" => Ok(true),
            "0" => Ok(false),
            other => Err(format!("column {}: {other:?} is not 1 or 0", i + 1)),
        }
    };
    let (views, eyes) = per_view(&cells[frame_columns..], views, eye_count)?;
    let (tracked, raw_targets) = targets_of(&cells, first_target, targets)?;
    Ok(FrameRecord {
        frame: cells[0]
            .parse()
            .map_err(|_| "column 1 is not a frame number")?,
        time_s: cells[1].parse().map_err(|_| "column 2 is not a time")?,
        drawn,
        pose,
        wand: held(14)?,
        left_hand: held(28)?,
        targets: tracked,
        gpu_ms: opt(22)?,
        cpu_ms: opt(23)?,
        block: u(24)?,
        trial: u(25)?,
        pose_to_submit_ms: opt(26)?,
        pose_to_photon_ms: if frame_columns > 27 { opt(27)? } else { None },
        object_time_s: if frame_columns > 37 { opt(37)? } else { None },
        raw: RawPoses {
            head: held(38)?,
            wand: held(46)?,
            left_hand: held(54)?,
            targets: raw_targets,
        },
        views,
        events,
        condition: match frame_columns > 36 {
            true => cells[36].to_string(),
            false => String::new(),
        },
        objects: match frame_columns > 62 {
            true => Some(ObjectSwitches {
                hidden: (cells[62].split(HIDDEN_SEPARATOR))
                    .filter(|n| !n.is_empty())
                    .map(str::to_string)
                    .collect(),
                shadows: switch(62 + 1)?,
                reflections: switch(62 + 2)?,
            }),
            false => None,
        },
        flash: match frame_columns > 65 {
            true => match cells[65] {
                "white" => Some(true),
                "black" => Some(false),
                "" => None,
                other => return Err(format!("column 66: {other:?} is not white, black or empty")),
            },
            false => None,
        },
        eyes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(frame: u64, wand: bool) -> FrameRecord {
        let s = ViewSettings {
            samples_per_pixel: 2,
            paced_samples: 4,
            paced_fraction: 0.123_456_79,
            mirror_bounces: 1,
            fixed_work: 0,
        };
        FrameRecord {
            frame,
            time_s: 0.1 * frame as f64,
            drawn: Drawn::Timed,
            pose: Pose {
                head: Vec3::new(0.1, 1.7, -0.3),
                head_rotation: Quat::from_rotation_y(0.3),
                room_position: Vec3::new(1.0, 0.0, 2.0),
                room_yaw_deg: 12.5,
            },
            wand: wand.then(|| WandPose {
                position: Vec3::new(0.2, 1.2, -0.5),
                rotation: Quat::from_rotation_x(-0.2),
            }),
            left_hand: wand.then(|| WandPose {
                position: Vec3::new(-0.3, 1.1, -0.4),
                rotation: Quat::from_rotation_z(0.7),
            }),
            // the first of meta()'s two targets seen (with the wand), the second never
            targets: {
                let mut t = Targets::default();
                t[0] = wand.then(|| WandPose {
                    position: Vec3::new(0.412_345_7, 0.0, -1.5),
                    rotation: Quat::from_rotation_y(1.0 / 3.0),
                });
                t
            },
            gpu_ms: Some(1.25),
            cpu_ms: None,
            block: 2,
            trial: 7,
            pose_to_submit_ms: Some(0.731),
            pose_to_photon_ms: Some(9.125),
            object_time_s: Some(0.25 * frame as f64 + 1.0 / 3.0),
            raw: RawPoses {
                head: Some(WandPose {
                    position: Vec3::new(120.5, -300.25, 1710.0),
                    rotation: Quat::from_rotation_z(0.4),
                }),
                wand: wand.then(|| WandPose {
                    position: Vec3::new(200.0, 500.0, 1200.0),
                    rotation: Quat::from_rotation_x(0.1),
                }),
                left_hand: None,
                targets: {
                    let mut t = Targets::default();
                    t[0] = wand.then(|| WandPose {
                        position: Vec3::new(412.345_7, 1500.0, 0.1),
                        rotation: Quat::from_rotation_z(1.0 / 3.0),
                    });
                    t
                },
            },
            views: vec![s, ViewSettings { fixed_work: 1, ..s }],
            events: "condition \"GI off\", trial 3".into(),
            condition: if wand { "gi-off".into() } else { String::new() },
            objects: Some(ObjectSwitches {
                hidden: match wand {
                    true => vec!["body".into(), "chair 2".into()],
                    false => Vec::new(),
                },
                shadows: !wand,
                reflections: true,
            }),
            flash: wand.then_some(false),
            eyes: Vec::new(),
        }
    }

    fn meta() -> SessionMeta {
        SessionMeta {
            format: LOG_FORMAT,
            vlf_version: "test".into(),
            display_config: "/x/cave.toml".into(),
            light_field: "/x/scene.vlf".into(),
            propagation: None,
            scene_hash: "0".into(),
            adapter: "test".into(),
            started_unix_s: 0.0,
            views: vec!["front-left".into(), "front-right".into()],
            columns: Vec::new(),
            headset: None,
            headset_setup: None,
            targets: vec!["chair".into(), "box".into()],
        }
    }

    /// `r` as a log without targets reads it back.
    fn untargeted(r: FrameRecord) -> FrameRecord {
        FrameRecord {
            targets: Targets::default(),
            raw: RawPoses {
                targets: Targets::default(),
                ..r.raw
            },
            ..r
        }
    }

    #[test]
    fn a_log_reads_back_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![record(0, true), record(1, false)];
        {
            let mut log = SessionLog::create(dir.path(), meta()).unwrap();
            for r in &rows {
                log.record(r).unwrap();
            }
        }
        let (m, back) = SessionLog::read(dir.path()).unwrap();
        assert_eq!(back, rows);
        assert!(back[0].targets[0].is_some() && back[0].raw.targets[0].is_some());
        assert_eq!(m.targets, ["chair", "box"]);
        assert_eq!(m.columns.len(), 66 + 2 * 5 + 2 * 16 + 1);
        let names: Vec<&str> = m.columns.iter().map(|(n, _)| n.as_str()).collect();
        let first = 66 + 2 * 5;
        assert_eq!(
            names[first..first + 9],
            [
                "target:chair",
                "target:chair_x",
                "target:chair_y",
                "target:chair_z",
                "target:chair_qx",
                "target:chair_qy",
                "target:chair_qz",
                "target:chair_qw",
                "raw_target:chair"
            ]
        );
        assert_eq!(names[first + 16], "target:box");
        // the Parquet part has the same columns, typed
        let parts = dir
            .path()
            .join(parquet::PARQUET_DIR)
            .join("part-000000.parquet");
        let rows = parquet::read_part(&parts);
        assert_eq!(rows[0].len(), m.columns.len());
        let x = |row: usize| {
            let (_, x) = rows[row]
                .iter()
                .find(|(n, _)| n == "target:chair_x")
                .unwrap();
            x.clone()
        };
        use ::parquet::record::Field;
        assert_eq!((x(0), x(1)), (Field::Float(0.412_345_7), Field::Float(0.0)));
        // a second session is never written over the first
        assert!(SessionLog::create(dir.path(), meta()).is_err());
    }

    #[test]
    fn a_headsets_eyes_read_back_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let eye = |x: f32| EyeRecord {
            position: [x, 1.612_345_7, -0.1],
            orientation: [0.01, 0.999_9, -0.003, 0.012_345_679],
            fov: [-0.78, 0.698_131_7, 0.8, -0.9],
        };
        let rows: Vec<FrameRecord> = (0..2)
            .map(|k| FrameRecord {
                eyes: vec![eye(-0.032 + k as f32), eye(0.032)],
                ..record(k, k == 0)
            })
            .collect();
        let headset = SessionMeta {
            headset: Some("test runtime".into()),
            headset_setup: Some(HeadsetSetup {
                eye_pixels: vec![[256, 224], [256, 224]],
                antialiasing: 4,
                first_hits: Default::default(),
                exposure: 1.5,
                objects: Some("/x/body.toml".into()),
                conditions: None,
                near_m: 0.05,
            }),
            ..meta()
        };
        {
            let mut log = SessionLog::create(dir.path(), headset.clone()).unwrap();
            for r in &rows {
                log.record(r).unwrap();
            }
            // a row without its eyes is refused
            assert!(log.record(&record(2, false)).is_err());
        }
        let (m, back) = SessionLog::read(dir.path()).unwrap();
        assert_eq!(back, rows);
        assert_eq!(m.headset_setup, headset.headset_setup);
        assert_eq!(m.columns.len(), 66 + 2 * 5 + 2 * 11 + 2 * 16 + 1);
        assert!(m.columns.iter().any(|(n, _)| n == "front-right:fov_down"));
    }

    /// A log written now, rewritten as an older format wrote it: session.json's `format` and
    /// the frame columns `dropped` (0-based) taken out of every line of frames.csv.
    fn as_older_format(dir: &Path, format: u32, dropped: std::ops::Range<usize>) {
        let (json, csv) = (dir.join("session.json"), dir.join("frames.csv"));
        let text = std::fs::read_to_string(&json).unwrap();
        let now = format!("\"format\": {LOG_FORMAT}");
        assert!(text.contains(&now));
        std::fs::write(&json, text.replace(&now, &format!("\"format\": {format}"))).unwrap();
        let lines: Vec<String> = (std::fs::read_to_string(&csv).unwrap().lines())
            .map(|l| {
                let mut cells: Vec<&str> = l.split(',').collect();
                cells.drain(dropped.clone());
                cells.join(",") + "\n"
            })
            .collect();
        std::fs::write(&csv, lines.concat()).unwrap();
    }

    #[test]
    fn format_1_to_4_logs_without_the_newer_columns_still_read() {
        // as format 1 wrote it: no pose_to_photon_ms (the 28th column) nor anything after it;
        // format 2: the frame's columns end at pose_to_photon_ms; 3: at the left hand's; 4: at
        // the raw poses (the logs of this test declare no targets)
        let meta = || SessionMeta {
            targets: Vec::new(),
            ..meta()
        };
        let record = |frame, wand| untargeted(record(frame, wand));
        let full = record(0, true);
        let (photon, hand) = (full.pose_to_photon_ms, full.left_hand);
        let format_4 = FrameRecord {
            objects: None,
            flash: None,
            ..full.clone()
        };
        for (format, dropped, pose_to_photon_ms, left_hand) in [
            (1, 27..66, None, None),
            (2, 28..66, photon, None),
            (3, 36..66, photon, hand),
            (4, 62..66, photon, hand),
        ] {
            let dir = tempfile::tempdir().unwrap();
            {
                let mut log = SessionLog::create(dir.path(), meta()).unwrap();
                log.record(&record(0, true)).unwrap();
            }
            as_older_format(dir.path(), format, dropped);
            let back = SessionLog::read(dir.path()).unwrap().1;
            let expect = match format {
                4 => format_4.clone(),
                _ => FrameRecord {
                    pose_to_photon_ms,
                    left_hand,
                    condition: String::new(),
                    object_time_s: None,
                    raw: RawPoses::default(),
                    objects: None,
                    flash: None,
                    ..record(0, true)
                },
            };
            assert_eq!(back, [expect], "format {format}");
        }
    }

    #[test]
    fn a_format_6_log_without_the_targets_columns_still_reads() {
        // format 6: the views' columns (two views of five) end the row before the events
        let dir = tempfile::tempdir().unwrap();
        {
            let mut log = SessionLog::create(dir.path(), meta()).unwrap();
            log.record(&record(0, true)).unwrap();
        }
        let first = 66 + 2 * 5;
        as_older_format(dir.path(), 6, first..first + 2 * 16);
        let back = SessionLog::read(dir.path()).unwrap().1;
        assert_eq!(back, [untargeted(record(0, true))]);
    }

    #[test]
    fn a_row_cut_short_at_the_end_is_left_out_and_a_bad_row_elsewhere_is_named() {
        let dir = tempfile::tempdir().unwrap();
        {
            let mut log = SessionLog::create(dir.path(), meta()).unwrap();
            log.record(&record(0, true)).unwrap();
            log.record(&record(1, true)).unwrap();
        }
        let csv = dir.path().join("frames.csv");
        let text = std::fs::read_to_string(&csv).unwrap();
        std::fs::write(&csv, &text[..text.len() - 20]).unwrap();
        assert_eq!(SessionLog::read(dir.path()).unwrap().1.len(), 1);
        std::fs::write(&csv, text.replacen(",timed,", ",later,", 1)).unwrap();
        let e = SessionLog::read(dir.path()).unwrap_err().to_string();
        assert!(e.contains("frames.csv:2") && e.contains("later"), "{e}");
    }
}
