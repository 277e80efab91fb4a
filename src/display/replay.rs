//! `vlf replay`: the frames of a session log (`crate::study::log`) drawn again offscreen, each view
//! exactly as the live run drew it: the logged pose, wand and left hand through the same walls (the
//! moving objects on them, the keyframed ones at the logged `object_time_s`), and the logged
//! settings of every view (eye rays per pixel, the paced tiles, mirror reflections) in place of the
//! pacer's, in its logged condition (its light field and exposure: `conditions.rs`), the moving
//! objects shown or hidden, with or without shadows and reflections, as logged for the frame, and
//! the latency test's white or black walls where it flashed. Each frame's images go to
//! `OUT/frame-<n>/` as the headless run writes its last frame (`<wall>-<eye>.png`, projectors' outputs, the overview). Or, with a `ThirdPerson`
//! camera, the scene seen from outside the participant, the avatar and objects posed as logged
//! (`OUT/frame-<n>/third-person.png`). One view, or that camera, can go to a video
//! (`replay/video.rs`), and the events over the images as text (`replay/overlay.rs`).

mod headset;
pub mod overlay;
pub mod video;

use super::conditions::{Conditions, MainField};
use super::frame::{FrameOfViews, Poses, Slots};
use super::headless::{write_kept, Kept};
use super::DisplayConfig;
use crate::error::{Result, VlfError};
use crate::lightfield::{LightField, ResidentLightField};
use crate::render::budget::ViewSettings;
use crate::render::image_io::{display_image, write_image};
use crate::render::Frame;
use crate::study::{FrameRecord, SessionMeta};
use crate::tracking::{HeldPoses, Pose};
use glam::{Quat, Vec3};
use std::path::{Path, PathBuf};

/// A camera outside the participant (`vlf replay --third-person`): where it stands and what it
/// looks at, world metres; either left out follows the logged head (`default_placement`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThirdPerson {
    pub eye: Option<Vec3>,
    pub look_at: Option<Vec3>,
    pub fov_y_deg: f32,
    pub size: [u32; 2],
}

/// The default third-person camera for a logged pose: 1.8 m behind the head (along its
/// heading, level) and 0.6 m above it, looking at a point 0.5 m below the head, so that the
/// body is in the picture.
pub fn default_placement(pose: &Pose) -> (Vec3, Vec3) {
    let head = pose.room_to_world(pose.head);
    let turn = Quat::from_rotation_y(pose.room_yaw_deg.to_radians()) * pose.head_rotation;
    let ahead = turn * Vec3::NEG_Z;
    let level = Vec3::new(ahead.x, 0.0, ahead.z);
    let level = match level.length() > 1e-3 {
        true => level.normalize(),
        // looking straight up or down: the room's own ahead
        false => Quat::from_rotation_y(pose.room_yaw_deg.to_radians()) * Vec3::NEG_Z,
    };
    (head - level * 1.8 + Vec3::Y * 0.6, head - Vec3::Y * 0.5)
}

/// A video of the replay (`vlf replay --video`): which view it shows (its name as in the log's
/// `views`; None the first, or the third-person camera where there is one) and its rate
/// (None: `frame_rate`).
#[derive(Clone, Copy, Debug)]
pub struct VideoOut<'a> {
    pub path: &'a Path,
    pub view: Option<&'a str>,
    pub fps: Option<f64>,
}

/// What a replay makes of each frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReplayOutput<'a> {
    /// each frame's images into `dir/frame-<n>/` (None: none, e.g. a video alone)
    pub images: Option<&'a Path>,
    /// EXR (linear radiance) beside the PNG images
    pub exr: bool,
    pub video: Option<VideoOut<'a>>,
    /// draw from this camera instead of the walls
    pub camera: Option<ThirdPerson>,
    /// the events as text over the PNG images and the video (`overlay::lines`), taken from
    /// these frames of the log (all of them, so that an event before the first drawn shows)
    pub overlay: Option<&'a [FrameRecord]>,
}

/// Draw `frames` (of the log's `meta`) from the light field the session drew, images into
/// `out`; `progress` hears of each. The folders written, in order.
pub fn replay(
    (lf, resident): (&LightField, &ResidentLightField),
    meta: &SessionMeta,
    frames: &[FrameRecord],
    (out, exr): (&Path, bool),
    progress: &dyn crate::progress::Progress,
) -> Result<Vec<PathBuf>> {
    let output = ReplayOutput {
        images: Some(out),
        exr,
        ..Default::default()
    };
    replay_with((lf, resident), meta, frames, &output, progress)
}

/// The video's rate: the display's refresh rate (a CAVE's `refresh_hz`), or else the logged frames' median spacing in
/// `time_s`, or else 60.
pub fn frame_rate(refresh_hz: Option<f64>, frames: &[FrameRecord]) -> f64 {
    if let Some(hz) = refresh_hz {
        return hz;
    }
    let mut steps: Vec<f64> = (frames.windows(2))
        .map(|w| (w[1].time_s - w[0].time_s) / (w[1].frame - w[0].frame).max(1) as f64)
        .filter(|s| *s > 0.0)
        .collect();
    steps.sort_by(f64::total_cmp);
    steps.get(steps.len() / 2).map_or(60.0, |s| 1.0 / s)
}

/// The log's view `name` (None: the first), by index; an unknown one is refused with the names.
fn view_index(meta: &SessionMeta, name: Option<&str>) -> Result<usize> {
    let Some(name) = name else { return Ok(0) };
    (meta.views.iter().position(|v| v == name)).ok_or_else(|| {
        VlfError::Display(format!(
            "no view {name:?} in the session: its views are {}",
            meta.views.join(", ")
        ))
    })
}

/// The display as the session drew it: every view, or where the log is one cluster rank's
/// (`vlf cave --log` under mpirun: each rank logs its own views), only that rank's views. Err
/// where the log names views the display no longer has.
fn logged_views(
    config: DisplayConfig,
    config_path: &Path,
    meta: &SessionMeta,
) -> Result<DisplayConfig> {
    let names: Vec<String> = (super::frame::wall_views(&config).iter())
        .map(|v| v.name(&config))
        .collect();
    if names == meta.views {
        return Ok(config);
    }
    match config.views_named(&meta.views) {
        Some(views) if !views.is_empty() => Ok(config.only_views(&views)),
        _ => Err(VlfError::Display(format!(
            "{}: its views are now {names:?}, the session drew {:?}: the display configuration changed since",
            config_path.display(),
            meta.views
        ))),
    }
}

/// `replay` with every output: images, a video, a third-person camera, the events overlaid. A
/// headset's session (`vlf xr --log`) is drawn by its eyes (`headset.rs`), a CAVE's by its
/// display config's walls.
pub fn replay_with(
    (lf, resident): (&LightField, &ResidentLightField),
    meta: &SessionMeta,
    frames: &[FrameRecord],
    output: &ReplayOutput<'_>,
    progress: &dyn crate::progress::Progress,
) -> Result<Vec<PathBuf>> {
    let main = MainField {
        source: &meta.light_field,
        lf,
        resident,
    };
    if meta.headset.is_some() {
        return headset::replay(main, meta, frames, output, progress);
    }
    let config_path = meta.display_config.as_path();
    let mut config = DisplayConfig::load(config_path)?;
    // the logged settings are drawn as they are: nothing is probed
    config.fit_frame_time = false;
    let poses = config.pose_source(config_path)?;
    let config = logged_views(config, config_path, meta)?;
    // the conditions' light fields made again as the run made them (propagation repeats bit
    // for bit)
    let conditions = Conditions::prepare(&config, config_path, main, progress)?;
    let frame = FrameOfViews::cave(
        (lf, resident),
        &config,
        config_path,
        &poses,
        Slots::PerWall,
        conditions.as_ref(),
    )?;
    let shown = match output.camera {
        Some(_) => 0,
        None => view_index(meta, output.video.and_then(|v| v.view))?,
    };
    let refresh = config.refresh_hz.map(f64::from);
    let fps = (output.video).map(|v| v.fps.unwrap_or_else(|| frame_rate(refresh, frames)));
    let mut cave = CaveReplay {
        frame,
        config: &config,
        camera: output.camera,
        shown,
        last: None,
    };
    drive(&mut cave, frames, output, fps, progress)
}

/// A session's frames drawn again, one by one: by the CAVE's walls (`CaveReplay`) or the
/// headset's eyes (`headset::HeadsetReplay`), or by a third-person camera.
trait Replayer {
    /// Draw `record` again, exactly as the session drew it.
    fn draw(&mut self, record: &FrameRecord) -> Result<()>;
    /// The last frame's images into `dir`: PNG (with `text` over it where given), and EXR
    /// (linear radiance) beside with `exr`.
    fn write(&self, dir: &Path, exr: bool, text: Option<&[String]>) -> Result<()>;
    /// The last frame's image that a video shows, as displayed.
    fn shown(&self) -> image::RgbImage;
}

/// Draw every one of `frames` by `replayer` into `output` (a video at `fps`), reporting each to
/// `progress`; the folders written, in order.
fn drive(
    replayer: &mut dyn Replayer,
    frames: &[FrameRecord],
    output: &ReplayOutput<'_>,
    fps: Option<f64>,
    progress: &dyn crate::progress::Progress,
) -> Result<Vec<PathBuf>> {
    let mut video: Option<video::VideoWriter> = None;
    let mut written = Vec::new();
    progress.begin(
        frames.len() as u64,
        "frames",
        "drawing the logged frames again",
    );
    for (k, record) in frames.iter().enumerate() {
        replayer.draw(record)?;
        let text = output.overlay.map(|log| overlay::lines(log, record));
        if let Some(dir) = output.images {
            let dir = dir.join(format!("frame-{:06}", record.frame));
            std::fs::create_dir_all(&dir).map_err(|e| VlfError::io(&dir, e))?;
            replayer.write(&dir, output.exr, text.as_deref())?;
            written.push(dir);
        }
        if let (Some(v), Some(fps)) = (output.video, fps) {
            let mut rgb = replayer.shown();
            if let Some(text) = &text {
                overlay::draw(&mut rgb, text);
            }
            if video.is_none() {
                let size = [rgb.width(), rgb.height()];
                video = Some(video::VideoWriter::start(v.path, size, fps)?);
            }
            video.as_mut().expect("started").push(&rgb)?;
        }
        progress.advance_to(k as u64 + 1, &format!("frame {}", record.frame));
    }
    progress.finish();
    if let Some(v) = video {
        v.finish()?;
    }
    Ok(written)
}

/// One frame's images: every view (and the projectors') read back, or the third-person camera's.
enum Images {
    Views(Kept),
    Camera(Frame),
}

impl Images {
    /// The image a video shows: view `i`, or the camera's.
    fn shown(&self, i: usize) -> &Frame {
        match self {
            Images::Views(kept) => &kept.views()[i],
            Images::Camera(image) => image,
        }
    }
}

/// A CAVE's session drawn again through its display config's walls.
struct CaveReplay<'a> {
    frame: FrameOfViews<'a>,
    config: &'a DisplayConfig,
    camera: Option<ThirdPerson>,
    /// the view a video shows
    shown: usize,
    last: Option<Images>,
}

impl Replayer for CaveReplay<'_> {
    fn draw(&mut self, record: &FrameRecord) -> Result<()> {
        let images = draw_frame(&mut self.frame, self.config, record, self.camera)?;
        self.last = Some(images);
        Ok(())
    }

    fn write(&self, dir: &Path, exr: bool, text: Option<&[String]>) -> Result<()> {
        let images = self.last.as_ref().expect("a frame drawn");
        write_frame(self.config, &self.frame, images, dir, (exr, text))
    }

    fn shown(&self) -> image::RgbImage {
        let images = self.last.as_ref().expect("a frame drawn");
        display_image(images.shown(self.shown), self.frame.exposure())
    }
}

/// Draw `record` again: its settings, object time and poses; the walls' views, or the
/// third-person camera's.
fn draw_frame(
    frame: &mut FrameOfViews<'_>,
    config: &DisplayConfig,
    record: &FrameRecord,
    camera: Option<ThirdPerson>,
) -> Result<Images> {
    set_logged_state(frame, record)?;
    let held = HeldPoses {
        wand: record.wand,
        left_hand: record.left_hand,
        targets: record.targets,
    };
    let poses = Poses::Tracked {
        pose: &record.pose,
        held: &held,
        arrived: None,
    };
    let Some(third) = camera else {
        let images = frame.read_back(poses)?;
        let mut kept = Kept::of(config, frame.wall_views(), images);
        kept.exposure = frame.exposure();
        // the latency test's white or black walls, as the run showed them
        kept.flash(record.flash);
        return Ok(Images::Views(kept));
    };
    let image = third_person(frame, record, poses, (third, config.antialiasing))?;
    Ok(Images::Camera(image))
}

/// A logged frame's state on `frame`: its views' settings, its condition, the moving objects'
/// switches and their time.
fn set_logged_state(frame: &mut FrameOfViews<'_>, record: &FrameRecord) -> Result<()> {
    frame.force_view_settings(record.views.clone());
    // each frame in its logged condition (a log without conditions: as the config starts)
    if !record.condition.is_empty() && frame.condition() != Some(record.condition.as_str()) {
        frame.set_condition(&record.condition)?;
    }
    // the objects shown and hidden, their shadows and reflections, as the frame drew them (a
    // log before format 5 has only the condition's)
    if let Some(switches) = &record.objects {
        frame.set_object_switches(switches);
    }
    // a log before format 4 has no object time: the keyframed objects at their start
    frame.set_object_time(record.object_time_s.unwrap_or(0.0));
    Ok(())
}

/// The third-person camera's image of `record`, the moving objects posed from `poses`; drawn
/// with the display's `antialiasing`, unpaced, with the first view's mirror reflections.
fn third_person(
    frame: &mut FrameOfViews<'_>,
    record: &FrameRecord,
    poses: Poses<'_>,
    (third, antialiasing): (ThirdPerson, u32),
) -> Result<Frame> {
    let (eye, look_at) = default_placement(&record.pose);
    let camera = crate::scene::Camera {
        name: "third-person".into(),
        eye: third.eye.unwrap_or(eye).into(),
        target: third.look_at.unwrap_or(look_at).into(),
        up: [0.0, 1.0, 0.0],
        fov_y_deg: third.fov_y_deg,
        size: third.size,
    };
    let first = record.views.first();
    let settings = ViewSettings {
        samples_per_pixel: antialiasing,
        paced_samples: antialiasing,
        paced_fraction: 0.0,
        mirror_bounces: first.map_or(1, |s| s.mirror_bounces),
        fixed_work: first.map_or(0, |s| s.fixed_work),
    };
    frame.read_back_camera(poses, &camera, settings)
}

/// A frame's images into `dir`: the views as the headless run writes them (or the camera's
/// `third-person.png`), with `text` over the PNGs where given.
fn write_frame(
    config: &DisplayConfig,
    frame: &FrameOfViews<'_>,
    images: &Images,
    dir: &Path,
    (exr, text): (bool, Option<&[String]>),
) -> Result<()> {
    let named: Vec<(String, &Frame)> = match images {
        Images::Views(kept) => {
            write_kept(config, frame.wall_views(), kept, dir, exr)?;
            let names = frame.wall_views().iter().map(|v| v.name(config));
            names.zip(kept.views()).collect()
        }
        Images::Camera(image) => {
            if exr {
                write_image(image, &dir.join("third-person.exr"), 1.0)?;
            }
            vec![("third-person".into(), image)]
        }
    };
    for (name, image) in named {
        let png = dir.join(format!("{name}.png"));
        // the walls' PNGs are the headless run's (`write_kept`): written again only with text
        if text.is_some() || matches!(images, Images::Camera(_)) {
            write_png(image, &png, frame.exposure(), text)?;
        }
    }
    Ok(())
}

/// `image` as displayed at `exposure` into the PNG `path`, with `text` over it where given.
fn write_png(image: &Frame, path: &Path, exposure: f32, text: Option<&[String]>) -> Result<()> {
    let mut rgb = display_image(image, exposure);
    if let Some(text) = text {
        overlay::draw(&mut rgb, text);
    }
    crate::render::image_io::save_png(&rgb, path)
}
