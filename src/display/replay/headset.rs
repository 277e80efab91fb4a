//! `vlf replay` of a headset's session (`vlf xr --log`, log format 6 on): each eye drawn again
//! from the pose and field of view the runtime located it at (the rows' eye columns), at its
//! logged size, antialiasing and first hits (session.json's `headset_setup`), through the same
//! `xr::eye_view`; the moving objects (`--objects`) on the head between the eyes and the logged
//! grips (`xr::body`), at the logged object time; in the logged condition (`--conditions`, made
//! again as the run made them). The images are each eye's `headset-<eye>.png` (at the run's
//! exposure times the condition's, as the headset showed it) and `.exr` (the linear radiance
//! the run drew: `vlf xr --screenshot left.exr` is the same image).

use super::{third_person, write_png, ReplayOutput, Replayer, ThirdPerson};
use crate::display::conditions::{Conditions, ConditionsFile, MainField};
use crate::display::frame::{FrameOfViews, Poses, ViewLabel};
use crate::display::headset_view::{self as body, eye_view};
use crate::dynamic::{Objects, Tracked};
use crate::error::{Result, VlfError};
use crate::gpu::MemoryLedger;
use crate::render::image_io::{display_image, write_image};
use crate::render::objects_file::ObjectsFile;
use crate::render::{Frame, ObjectsToDraw, Renderer};
use crate::study::log::{EyeRecord, HeadsetSetup};
use crate::study::{FrameRecord, SessionMeta};
use glam::{Mat4, Quat, Vec3};
use std::path::{Path, PathBuf};

/// Draw `frames` of a headset's session `meta` again into `output`.
pub(super) fn replay(
    main: MainField<'_>,
    meta: &SessionMeta,
    frames: &[FrameRecord],
    output: &ReplayOutput<'_>,
    progress: &dyn crate::progress::Progress,
) -> Result<Vec<PathBuf>> {
    let setup = meta.headset_setup.as_ref().ok_or_else(|| {
        VlfError::Display(format!(
            "a headset's session of log format {} ({}): its eyes' poses and fields of view were not logged before format 6; record the session again with this vlf (`vlf xr --log`)",
            meta.format,
            meta.headset.as_deref().unwrap_or("")
        ))
    })?;
    if setup.eye_pixels.len() != meta.views.len() || meta.views.len() != 2 {
        return Err(VlfError::Display(format!(
            "session.json: {} eye sizes for {} views, where a headset has 2 eyes",
            setup.eye_pixels.len(),
            meta.views.len()
        )));
    }
    let objects = load_objects(setup)?;
    let conditions = load_conditions(setup, objects.as_ref(), main, progress)?;
    let frame = eyes_frame(main, setup, meta, objects, conditions.as_ref())?;
    let shown = match output.camera {
        Some(_) => 0,
        None => super::view_index(meta, output.video.and_then(|v| v.view))?,
    };
    let fps = (output.video).map(|v| v.fps.unwrap_or_else(|| super::frame_rate(None, frames)));
    let mut headset = HeadsetReplay {
        frame,
        setup,
        names: meta.views.clone(),
        camera: output.camera,
        shown,
        last: Vec::new(),
    };
    super::drive(&mut headset, frames, output, fps, progress)
}

/// The logged `--objects` loaded again, with how they are lit (None: the run had none).
fn load_objects(
    setup: &HeadsetSetup,
) -> Result<Option<(Objects, crate::render::probes::ObjectLighting)>> {
    let Some(path) = &setup.objects else {
        return Ok(None);
    };
    let file = ObjectsFile::load(path)?;
    let objects = Objects::load(&file.objects, path)?;
    Ok(Some((objects, file.object_lighting.unwrap_or_default())))
}

/// The logged `--conditions` with their light fields made again (propagation repeats bit for
/// bit), beside `main` (None: the run had none).
fn load_conditions(
    setup: &HeadsetSetup,
    objects: Option<&(Objects, crate::render::probes::ObjectLighting)>,
    main: MainField<'_>,
    progress: &dyn crate::progress::Progress,
) -> Result<Option<Conditions>> {
    let Some(path) = &setup.conditions else {
        return Ok(None);
    };
    let names: Vec<String> = (objects.iter())
        .flat_map(|(o, _)| o.configs().iter().map(|c| c.name.clone()))
        .collect();
    let file = ConditionsFile::load(path, &names)?;
    let list = (&file.conditions[..], file.default_condition.as_deref());
    Conditions::prepare_list(list, path, main, progress)
}

/// The eyes as the run drew them: a renderer with the moving objects, the logged eye rays per
/// pixel and first hits, each eye's image at its logged size, the conditions bound.
fn eyes_frame<'c>(
    main: MainField<'_>,
    setup: &HeadsetSetup,
    meta: &SessionMeta,
    objects: Option<(Objects, crate::render::probes::ObjectLighting)>,
    conditions: Option<&'c Conditions>,
) -> Result<FrameOfViews<'c>> {
    let to_draw = objects.as_ref().map(|(o, lighting)| ObjectsToDraw {
        mesh: o.mesh(),
        lighting: *lighting,
    });
    let ledger = MemoryLedger::default();
    let mut renderer = Renderer::with_objects(main.resident, main.lf, &ledger, to_draw)?;
    renderer.set_samples_per_pixel(setup.antialiasing)?;
    renderer.set_first_hits(setup.first_hits)?;
    let views = (meta.views.iter().zip(&setup.eye_pixels))
        .map(|(name, &[w, h])| {
            let label = ViewLabel {
                wall: "headset".into(),
                eye: if name.ends_with("right") {
                    "right"
                } else {
                    "left"
                },
                pixels: [w, h],
            };
            (label, renderer.view_targets(w, h))
        })
        .collect();
    let ctx = main.resident.ctx.clone();
    let objects = objects.map(|(o, _)| o);
    let mut frame = FrameOfViews::eyes(&ctx, renderer, views, 1, objects);
    if let Some(c) = conditions {
        frame.use_conditions(c)?;
    }
    Ok(frame)
}

/// A headset's session drawn again by its eyes.
struct HeadsetReplay<'a> {
    frame: FrameOfViews<'a>,
    setup: &'a HeadsetSetup,
    /// the views' names (`headset-left`, `headset-right`)
    names: Vec<String>,
    camera: Option<ThirdPerson>,
    /// the view a video shows
    shown: usize,
    /// the last frame's images: the eyes', or the camera's alone
    last: Vec<Frame>,
}

impl HeadsetReplay<'_> {
    /// What a headset showed: `--exposure` times the condition's.
    fn exposure(&self) -> f32 {
        self.setup.exposure * self.frame.exposure()
    }
}

impl Replayer for HeadsetReplay<'_> {
    fn draw(&mut self, record: &FrameRecord) -> Result<()> {
        if record.eyes.len() != self.names.len() {
            return Err(VlfError::Display(format!(
                "frame {}: {} eyes logged for {} views",
                record.frame,
                record.eyes.len(),
                self.names.len()
            )));
        }
        super::set_logged_state(&mut self.frame, record)?;
        let norm = &self.frame.renderer().normalisation();
        let matrices: Vec<(Mat4, Vec3)> = (record.eyes.iter())
            .map(|e| {
                let (pose, fov) = body::logged_eye(e);
                eye_view(pose, fov, &record.pose, norm, self.setup.near_m)
            })
            .collect();
        let tracked = tracked(record);
        let poses = Poses::Eyes {
            matrices: &matrices,
            tracked: Some(&tracked),
        };
        self.last = match self.camera {
            None => (self.frame.read_back(poses)?.into_iter())
                .map(|(image, _)| image)
                .collect(),
            Some(third) => {
                let aa = (third, self.setup.antialiasing);
                vec![third_person(&mut self.frame, record, poses, aa)?]
            }
        };
        Ok(())
    }

    fn write(&self, dir: &Path, exr: bool, text: Option<&[String]>) -> Result<()> {
        let names: Vec<&str> = match self.camera {
            None => self.names.iter().map(String::as_str).collect(),
            Some(_) => vec!["third-person"],
        };
        // the camera's image at the run's exposure; the eyes' as the headset showed them
        let exposure = match self.camera {
            None => self.exposure(),
            Some(_) => self.frame.exposure(),
        };
        for (name, image) in names.iter().zip(&self.last) {
            if exr {
                write_image(image, &dir.join(format!("{name}.exr")), 1.0)?;
            }
            write_png(image, &dir.join(format!("{name}.png")), exposure, text)?;
        }
        Ok(())
    }

    fn shown(&self) -> image::RgbImage {
        let i = if self.camera.is_some() { 0 } else { self.shown };
        display_image(&self.last[i], self.exposure())
    }
}

/// What the moving objects followed: the head between the logged eyes and the logged grips, in
/// the world through the logged navigation (the frame's object time replaces `time`).
fn tracked(record: &FrameRecord) -> Tracked {
    let eye = |e: &EyeRecord| (Quat::from_array(e.orientation), Vec3::from(e.position));
    let head = body::head_between([eye(&record.eyes[0]), eye(&record.eyes[1])]);
    let hands = [record.left_hand, record.wand].map(|h| h.map(body::hand_in_stage));
    body::tracked(&record.pose, head, hands, 0.0)
}
