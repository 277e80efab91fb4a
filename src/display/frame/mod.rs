//! One frame of views, as every display draws it: `FrameOfViews` owns the renderer, the views
//! (each with its report name and pixel size, `views.rs`) and where each view's image goes
//! (`Sink`: the CAVE's wall images and the outputs drawn from them, `post.rs`; the headset's
//! eye images), the frame-time fit and the pacer (`render/budget.rs`), and the accounting
//! (`accounting.rs`: timestamps read at once or frames in flight, `in_flight.rs`; the times,
//! `times.rs`). A frame is `begin`, one `draw` of every view from the frame's poses, and
//! `account`. The loops around it are its drivers: offscreen files (`headless.rs`), windows
//! (`window/`), the cluster's ranks through those two (`crate::cluster`) and the headset
//! (`crate::xr`) keep only how they get their poses, their events, presentation and their
//! reports.

mod accounting;
mod geometries;
mod in_flight;
mod slowest;
pub mod study;
mod times;
mod views;

pub use in_flight::InFlight;
pub use slowest::{slowest_frames, SlowFrame, SLOWEST_FRAMES};
pub use times::{
    frame_limits, worst_ratio, FrameSeries, FrameTimes, Limit, Pass, ViewTiming,
    CONSTANT_CPU_FRAME_TIME, CONSTANT_FRAME_TIME, MAX_OVER_MEDIAN,
};
pub use views::{labels, wall_views, ViewLabel, WallView};

use super::conditions::Conditions;
use super::post::{Draw, Outputs, WandOverlay};
use super::DisplayConfig;
use crate::dynamic::{Objects, Tracked};
use crate::error::{Result, VlfError};
use crate::gpu::{GpuContext, MemoryLedger, PairSpan, Timestamps};
use crate::lightfield::{LightField, ResidentLightField};
use crate::render::budget::{BudgetFit, Pacer, PacerReport, ProbeView, Quality, ViewSettings};
use crate::render::{Frame, ObjectsToDraw, Renderer, ViewTargets};
use crate::stats::Distribution;
use crate::study::log::ObjectSwitches;
use crate::study::session::ObjectChange;
use crate::tracking::source::{Pose, PoseSource};
use crate::tracking::HeldPoses;
use accounting::{Accounting, Clock};
use glam::{Mat4, Vec3};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// Rounds of the moving objects' pass timed at the fit (`probe_objects`), the first a warm-up.
const OBJECT_PROBE_ROUNDS: u32 = 6;

/// Where a frame's views look from.
#[derive(Clone, Copy)]
pub enum Poses<'p> {
    /// the tracked head (and the wand and left hand, room): each wall's views through
    /// `super::wall_view`, the wand's ray over them (`post::wand_overlay`), the moving objects
    /// on the head and hands; `arrived`, when a live pose came in
    Tracked {
        pose: &'p Pose,
        held: &'p HeldPoses,
        arrived: Option<Instant>,
    },
    /// each view's view-projection and eye, in view order (the headset's eyes), and what the
    /// moving objects follow in the world (the headset's head and hands; its `time` is replaced
    /// by the object time)
    Eyes {
        matrices: &'p [(Mat4, Vec3)],
        tracked: Option<&'p Tracked>,
    },
}

/// Where each view's image goes.
enum Sink {
    /// the CAVE: view i rendered into wall image `slots[i]` of `outputs`, its outputs (warp,
    /// blend, wand ray) drawn from it
    Outputs { outputs: Outputs, slots: Vec<usize> },
    /// the headset: view i rendered into its own image and depth
    Targets(Vec<ViewTargets>),
}

/// How the CAVE's views share wall images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slots {
    /// one image per wall, its eyes drawn into it one after the other (offscreen: each view is
    /// read back before the next is drawn)
    PerWall,
    /// one image per view (windows show every view of a frame at once)
    PerView,
}

/// The CAVE's walls, for turning a tracked pose into each view's matrices.
struct Cave<'a> {
    config: &'a DisplayConfig,
    views: Vec<WallView>,
}

/// A view read back: its image and its projectors' outputs (named by projector).
pub type ViewImages = (Frame, Vec<(String, Frame)>);

/// What the frame's last encoder carries besides the views (the headset's swapchain layers),
/// timed by the pair it is given (`Pass::Output`) when the frame is stamped.
pub type LastPasses<'f> =
    &'f mut dyn FnMut(&mut wgpu::CommandEncoder, Option<PairSpan<'_>>) -> Result<()>;

/// A frame of views: the renderer, the views and their sink, the pacing and the accounting.
pub struct FrameOfViews<'a> {
    ctx: Arc<GpuContext>,
    renderer: Renderer,
    sink: Sink,
    cave: Option<Cave<'a>>,
    /// with `fit_frame_time`: what was probed and chosen before the first frame
    fit: Option<BudgetFit>,
    /// with a fit: how many eye rays each view draws in which tiles, frame by frame
    pacer: Option<Pacer>,
    acc: Accounting,
    /// what each view of the last frame was drawn with (a session log records it)
    drawn: Vec<ViewSettings>,
    /// with edge antialiasing, the share of each view's pixels it refined when last read back
    refined: Vec<f64>,
    /// each view's settings given from outside instead of the pacer's (`vlf replay`)
    forced: Option<Vec<ViewSettings>>,
    /// the display's moving objects (`crate::dynamic`), posed before each frame's views, and the
    /// time that moves the keyframed ones
    objects: Option<Objects>,
    object_time: f64,
    /// their shadows on the scene, their reflections in its mirrors (a study switches them)
    object_switches: (bool, bool),
    /// a study's conditions (their light fields added to the renderer), the one in effect, and
    /// the exposure of what is shown (the condition's; 1 without)
    conditions: Option<&'a Conditions>,
    condition: Option<usize>,
    exposure: f32,
    /// the renderers of the other geometries (a condition's scene of other geometry,
    /// `geometries.rs`), by geometry; `renderer` draws geometry `geometry` (its slot None)
    parked: Vec<Option<Renderer>>,
    /// ... and their pacers (each geometry's views cost their own: its pacer resumes where
    /// its frames left it)
    parked_pacers: Vec<Option<Pacer>>,
    geometry: usize,
    /// each condition light field's renderer (its geometry) and its field there (0: the
    /// `--scene`'s, k + 1: `Conditions::fields[k]`)
    placement: Vec<(usize, usize)>,
}

impl<'a> FrameOfViews<'a> {
    /// A display's every wall and eye (`wall_views`), their outputs (`warp::load_outputs`; the
    /// pass after rendering only where needed, `Outputs::needed`) and, with `fit_frame_time`,
    /// the fit probed on the views of the first pose of `poses`. Timestamps are read serially.
    /// With `conditions` (`super::conditions`), their light fields are bound beside `lf`'s
    /// and the initial condition is in effect from the first frame (and the fit's probes).
    pub fn cave(
        (lf, resident): (&'a LightField, &ResidentLightField),
        config: &'a DisplayConfig,
        config_path: &Path,
        poses: &PoseSource,
        slots: Slots,
        conditions: Option<&'a Conditions>,
    ) -> Result<FrameOfViews<'a>> {
        let ctx = resident.ctx.clone();
        let objects = match config.objects.is_empty() {
            true => None,
            false => Some(Objects::load_tracked(
                &config.objects,
                &config.tracking.target_names(),
                config_path,
            )?),
        };
        let to_draw = objects.as_ref().map(|o| ObjectsToDraw {
            mesh: o.mesh(),
            lighting: config.object_lighting.unwrap_or_default(),
        });
        let mut renderer = Renderer::with_objects(resident, lf, &MemoryLedger::default(), to_draw)?;
        renderer.set_samples_per_pixel(config.antialiasing)?;
        renderer.set_first_hits(config.first_hits)?;
        renderer.set_edge_antialiasing(config.edge_antialiasing)?;
        let views = wall_views(config);
        let specs = super::warp::load_outputs(config, config_path)?;
        let post = Outputs::needed(config, &specs, poses.may_have_wand(&config.tracking));
        let (walls, slots): (Vec<usize>, Vec<usize>) = match slots {
            Slots::PerWall => (
                (0..config.walls.len()).collect(),
                (views.iter()).map(|v| v.wall).collect(),
            ),
            Slots::PerView => (
                (views.iter()).map(|v| v.wall).collect(),
                (0..views.len()).collect(),
            ),
        };
        let outputs = Outputs::new(&ctx, &renderer, config, &specs, &walls, post)?;
        // a timed frame's pairs: each view's render, then each of its outputs' passes
        let pairs: usize = (slots.iter())
            .map(|&s| 1 + outputs.timed_outputs(s))
            .sum::<usize>()
            + usize::from(objects.is_some());
        let clock = Clock::Serial(crate::gpu::Timestamps::new(&ctx, pairs as u32));
        let mut frame = FrameOfViews {
            acc: Accounting::new(labels(config, &views), clock),
            ctx,
            renderer,
            sink: Sink::Outputs { outputs, slots },
            cave: Some(Cave { config, views }),
            fit: None,
            pacer: None,
            drawn: Vec::new(),
            refined: Vec::new(),
            forced: None,
            objects,
            object_time: 0.0,
            object_switches: (true, true),
            conditions: None,
            condition: None,
            exposure: 1.0,
            parked: vec![None],
            parked_pacers: vec![None],
            geometry: 0,
            placement: vec![(0, 0)],
        };
        if let Some(c) = conditions {
            frame.use_conditions(c)?;
        }
        if let Some(budget) = config.frame_budget_ms().filter(|_| config.fit_frame_time) {
            let (pose, _) = poses.at_fresh(0.0);
            // (the hands untracked, as before the first frame of a live source)
            let held = HeldPoses::default();
            let first = Poses::Tracked {
                pose: &pose,
                held: &held,
                arrived: None,
            };
            // the views probed as they will be drawn: with the objects where they start
            frame.pose_objects(&first, false);
            frame.fit_frame_time(first, budget)?;
            frame.warm_up(first)?;
        }
        Ok(frame)
    }

    /// One frame drawn as the session's will be (every view paced as fitted, its outputs, the
    /// moving objects' pass), untimed, read by no pacer and shown nowhere, before the first: the
    /// first frame through that path after the fit paid for first uses (the walk CAVE with the
    /// body on an H200: 15.7 ms of GPU and 29.2 ms in all against 4.6 and 5.0 for the next).
    /// The headset does the same (`xr::eyes::warm_up`).
    fn warm_up(&mut self, poses: Poses<'_>) -> Result<()> {
        self.acc.begin(&self.ctx, false, None)?;
        self.draw(poses, Draw::Shown, None)?;
        self.ctx.wait()
    }

    /// Views drawn by `renderer` into their own `targets` (one per label), their times read
    /// `frames_in_flight` frames late: the headset's eyes; with the `objects` the renderer was
    /// made for (`Renderer::with_objects`), posed from each frame's `Poses::Eyes::tracked`.
    pub fn eyes(
        ctx: &Arc<GpuContext>,
        renderer: Renderer,
        views: Vec<(ViewLabel, ViewTargets)>,
        frames_in_flight: usize,
        objects: Option<Objects>,
    ) -> FrameOfViews<'a> {
        let (labels, targets): (Vec<ViewLabel>, Vec<ViewTargets>) = views.into_iter().unzip();
        let clock = Clock::InFlight {
            depth: frames_in_flight,
            // a pair per eye, one for the moving objects' pass and one for the swapchain layers
            frames: InFlight::new(ctx, labels.len() as u32 + 2, frames_in_flight),
        };
        FrameOfViews {
            ctx: ctx.clone(),
            renderer,
            sink: Sink::Targets(targets),
            cave: None,
            fit: None,
            pacer: None,
            acc: Accounting::new(labels, clock),
            drawn: Vec::new(),
            refined: Vec::new(),
            forced: None,
            objects,
            object_time: 0.0,
            object_switches: (true, true),
            conditions: None,
            condition: None,
            exposure: 1.0,
            parked: vec![None],
            parked_pacers: vec![None],
            geometry: 0,
            placement: vec![(0, 0)],
        }
    }

    /// The moving objects, where the display has any.
    pub fn objects(&self) -> Option<&Objects> {
        self.objects.as_ref()
    }

    /// The moving objects (a study shows and hides them), where the display has any.
    pub fn objects_mut(&mut self) -> Option<&mut Objects> {
        self.objects.as_mut()
    }

    /// A study's changes to the moving objects, from the next frame drawn (names were checked
    /// against the display's objects when the commands came).
    pub fn change_objects(&mut self, changes: &[ObjectChange]) {
        changes.iter().for_each(|c| self.change_object(c));
    }

    fn change_object(&mut self, change: &ObjectChange) {
        match change {
            ObjectChange::Visible(name, on) => {
                if let Some(o) = self.objects.as_mut() {
                    let _ = o.set_visible(name, *on);
                }
            }
            ObjectChange::Shadows(on) => self.object_switches.0 = *on,
            ObjectChange::Reflections(on) => self.object_switches.1 = *on,
        }
        let (shadows, in_mirrors) = self.object_switches;
        self.renderer.set_object_switches(shadows, in_mirrors);
        for r in self.parked.iter_mut().flatten() {
            r.set_object_switches(shadows, in_mirrors);
        }
    }

    /// A study's condition from the next frame drawn: its light field bound, its exposure, its
    /// moving objects shown or hidden, their shadows and reflections (`super::conditions`; its
    /// start pose is the session's, `crate::study::Session`). Everything was made before the
    /// first frame: this only rebinds. Err for a name the display has no condition of.
    pub fn set_condition(&mut self, name: &str) -> Result<()> {
        let Some(conditions) = self.conditions else {
            return Err(VlfError::Display(format!(
                "condition {name:?}: the display config has no [[condition]]"
            )));
        };
        let k = conditions
            .index(name)
            .ok_or_else(|| VlfError::Display(format!("no condition called {name:?}")))?;
        let c = &conditions.list[k];
        let (geometry, field) = self.placement[conditions.field_of[k]];
        self.use_geometry(geometry);
        self.renderer.use_light_field(field)?;
        self.exposure = c.exposure;
        let switches = ObjectSwitches {
            hidden: (self.object_names().into_iter())
                .filter(|n| c.objects_visible.as_ref().is_some_and(|v| !v.contains(n)))
                .collect(),
            shadows: c.shadows,
            reflections: c.reflections,
        };
        self.set_object_switches(&switches);
        self.condition = Some(k);
        Ok(())
    }

    /// What a study's script changed this frame (`crate::study::Session`): its condition and its
    /// changes to the moving objects, from the next frame drawn.
    pub fn take_study_changes(&mut self, session: &mut crate::study::Session<'_>) -> Result<()> {
        if let Some(name) = session.take_condition() {
            self.set_condition(&name)?;
        }
        self.change_objects(&session.take_object_changes());
        Ok(())
    }

    /// The moving objects' names, in the display config's order (none without objects).
    fn object_names(&self) -> Vec<String> {
        (self.objects.iter())
            .flat_map(|o| o.configs().iter().map(|c| c.name.clone()))
            .collect()
    }

    /// The moving objects' switches as the next frame draws them (the session log's columns,
    /// which `vlf replay` sets back with `set_object_switches`).
    pub fn object_switches(&self) -> ObjectSwitches {
        let (shadows, reflections) = self.object_switches;
        let hidden = (self.objects.iter())
            .flat_map(|o| o.configs().iter().zip(o.visible()))
            .filter(|(_, shown)| !**shown)
            .map(|(c, _)| c.name.clone())
            .collect();
        ObjectSwitches {
            hidden,
            shadows,
            reflections,
        }
    }

    /// The moving objects' switches as a session logged them for a frame: every object shown
    /// but the hidden ones, their shadows and reflections.
    pub fn set_object_switches(&mut self, switches: &ObjectSwitches) {
        let mut changes: Vec<ObjectChange> = (self.object_names().into_iter())
            .map(|n| {
                let shown = !switches.hidden.contains(&n);
                ObjectChange::Visible(n, shown)
            })
            .collect();
        changes.push(ObjectChange::Shadows(switches.shadows));
        changes.push(ObjectChange::Reflections(switches.reflections));
        self.change_objects(&changes);
    }

    /// The condition in effect (None: the display has none).
    pub fn condition(&self) -> Option<&str> {
        let (c, k) = (self.conditions?, self.condition?);
        Some(c.list[k].name.as_str())
    }

    /// The exposure of what the views show now (the condition's; 1 without conditions): the
    /// windows and the PNGs written scale the linear radiance by it.
    pub fn exposure(&self) -> f32 {
        self.exposure
    }

    /// The time (seconds from the start of the run) that moves keyframed objects in the frames
    /// drawn next.
    pub fn set_object_time(&mut self, seconds: f64) {
        self.object_time = seconds;
    }

    /// The moving objects' time of the frames drawn next (`set_object_time`).
    pub fn object_time_s(&self) -> f64 {
        self.object_time
    }

    /// What the moving objects follow in `poses` at the object time: the CAVE's tracked pose, or
    /// the headset's head and hands (None: eyes given without them).
    pub fn tracked(&self, poses: &Poses<'_>) -> Option<Tracked> {
        match poses {
            Poses::Tracked { pose, held, .. } => {
                Some(Tracked::from_pose(pose, held, self.object_time))
            }
            Poses::Eyes { tracked, .. } => tracked.map(|t| Tracked {
                time: self.object_time,
                ..*t
            }),
        }
    }

    /// Pose the moving objects where `poses` and the object time put them; `in_frame`: as the
    /// first pass of a frame being drawn, timed whenever the frame is (the pacer makes room for
    /// it from the first paced frame, the report counts it in timed ones).
    fn pose_objects(&mut self, poses: &Poses<'_>, in_frame: bool) {
        let tracked = self.tracked(poses);
        if let (Some(objects), Some(tracked)) = (&self.objects, tracked) {
            let joints = objects.joint_matrices(&tracked);
            let timestamps = match in_frame && self.acc.stamped() {
                true => {
                    self.acc.pass(Pass::Objects);
                    self.acc.timestamps()
                }
                false => None,
            };
            self.renderer.pose_objects(&joints, timestamps);
        }
    }

    /// The moving objects' pass posed from `poses`, timed `OBJECT_PROBE_ROUNDS` times (the first
    /// a warm-up): its least time, the pacer's first reserve for it. None without objects or
    /// timestamps.
    fn probe_objects(&mut self, poses: &Poses<'_>) -> Result<Option<f64>> {
        let (Some(objects), Some(tracked)) = (&self.objects, self.tracked(poses)) else {
            return Ok(None);
        };
        let joints = objects.joint_matrices(&tracked);
        let Some(mut timestamps) = Timestamps::new(&self.ctx, OBJECT_PROBE_ROUNDS) else {
            return Ok(None);
        };
        for _ in 0..OBJECT_PROBE_ROUNDS {
            self.renderer.pose_objects(&joints, Some(&mut timestamps));
        }
        let ms = timestamps.read_ms(&self.ctx)?;
        Ok(ms.into_iter().skip(1).reduce(f64::min))
    }

    /// Probe the views seen from `poses` (`render/budget.rs`) against `budget_ms`, keep the
    /// settings chosen, and pace every frame after it; with frames in flight their times come
    /// back that many frames late, so the pacer steps less (`Pacer::lagged`).
    pub fn fit_frame_time(&mut self, poses: Poses<'_>, budget_ms: f64) -> Result<()> {
        let fit = self.fit_geometry(&poses, budget_ms)?;
        self.fit = Some(fit);
        // each other geometry (a condition's scene) probed too, its pacer kept for its frames
        let active = self.geometry;
        for g in 0..self.parked.len() {
            if self.parked[g].is_some() {
                self.use_geometry(g);
                self.fit_geometry(&poses, budget_ms)?;
            }
        }
        self.use_geometry(active);
        Ok(())
    }

    /// `fit_frame_time` for the geometry drawn now: its fit, and its pacer set.
    fn fit_geometry(&mut self, poses: &Poses<'_>, budget_ms: f64) -> Result<BudgetFit> {
        let probes = (0..self.labels().len())
            .map(|i| {
                let ((view_proj, eye), _) = self.view(i, poses)?;
                let size = self.labels()[i].pixels;
                Ok(ProbeView {
                    view_proj,
                    eye,
                    size,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let mut fit = self.renderer.fit_frame_time(&probes, budget_ms)?;
        fit.objects_gpu_ms = self.probe_objects(poses)?;
        let lag = self.acc.lag() as u32;
        let most = self.renderer.paced_max_samples();
        self.pacer = Pacer::from_fit(&fit).map(|p| p.capped(most)).map(|p| {
            if lag > 0 {
                p.lagged(lag)
            } else {
                p
            }
        });
        Ok(fit)
    }

    /// View `i`'s view-projection and eye, and the wand's ray over it.
    fn view(&self, i: usize, poses: &Poses<'_>) -> Result<((Mat4, Vec3), Option<WandOverlay>)> {
        match (poses, &self.cave) {
            (Poses::Eyes { matrices: m, .. }, _) => {
                let view = m.get(i).ok_or_else(|| {
                    VlfError::Display(format!(
                        "{} views' matrices for {} views",
                        m.len(),
                        self.labels().len()
                    ))
                })?;
                Ok((*view, None))
            }
            (Poses::Tracked { pose, held, .. }, Some(cave)) => {
                let v = cave.views[i];
                let wall = &cave.config.walls[v.wall];
                // the scene drawn now (a condition's of other geometry has its own)
                let norm = &self.renderer.normalisation();
                let view = super::wall_view(cave.config, wall, v.side, pose, norm);
                let wand = held.wand.as_ref();
                let overlay =
                    super::post::wand_overlay(cave.config, wall, v.side, pose, wand, norm);
                Ok((view, overlay))
            }
            (Poses::Tracked { .. }, None) => Err(VlfError::Display(
                "a tracked pose needs walls to turn it into views; give these views' matrices"
                    .into(),
            )),
        }
    }

    /// Start a frame (`timed`: it counts in the report).
    pub fn begin(&mut self, timed: bool) -> Result<()> {
        self.acc.begin(&self.ctx, timed, self.pacer.as_mut())
    }

    /// Encode and submit every view of the frame seen from `poses`: each with its pacing, its
    /// view matrix, the wand's ray and its timestamps, and the outputs that `draw` names (the
    /// CAVE's; `Draw::Timed` times them too). `last` adds its passes to the frame's last encoder
    /// (the headset's swapchain layers). The frame's last submission, where the frame submits
    /// one (the CAVE's outputs submit each view themselves).
    pub fn draw(
        &mut self,
        poses: Poses<'_>,
        draw: Draw,
        mut last: Option<LastPasses<'_>>,
    ) -> Result<Option<wgpu::SubmissionIndex>> {
        let count = self.labels().len();
        let mut submission = None;
        self.drawn.clear();
        self.pose_objects(&poses, true);
        for i in 0..count {
            if let Some(p) = &self.pacer {
                self.renderer.set_pacing(p.setting(i));
            }
            self.apply_forced(i);
            let (view, overlay) = self.view(i, &poses)?;
            self.acc.pass(Pass::View(i));
            match &self.sink {
                Sink::Outputs { outputs, slots } => {
                    if draw == Draw::Timed {
                        for _ in 0..outputs.timed_outputs(slots[i]) {
                            self.acc.pass(Pass::Output);
                        }
                    }
                    let ts = self.acc.timestamps();
                    outputs.encode(
                        &mut self.renderer,
                        slots[i],
                        view,
                        overlay.as_ref(),
                        ts,
                        draw,
                    );
                }
                Sink::Targets(targets) => {
                    self.renderer.set_view_matrix(view.0, view.1);
                    let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
                    self.renderer
                        .encode_view(&mut encoder, &targets[i], self.acc.timestamps());
                    if i + 1 == count {
                        last_passes(&mut self.acc, &mut encoder, last.take())?;
                    }
                    submission = Some(self.ctx.queue.submit([encoder.finish()]));
                }
            }
        }
        // after the CAVE's views (submitted by their outputs), anything left gets an encoder
        if submission.is_none() && (last.is_some() || self.acc.resolves()) {
            let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
            last_passes(&mut self.acc, &mut encoder, last)?;
            submission = Some(self.ctx.queue.submit([encoder.finish()]));
        }
        let arrived = match poses {
            Poses::Tracked { arrived, .. } => arrived,
            Poses::Eyes { .. } => None,
        };
        self.acc.submitted(arrived);
        Ok(submission)
    }

    /// Draw every view again, one by one, untimed and with every output (`Draw::Everything`),
    /// and read each back: its image and its projectors' outputs.
    pub fn read_back(&mut self, poses: Poses<'_>) -> Result<Vec<ViewImages>> {
        let mut images = Vec::new();
        self.drawn.clear();
        self.refined.clear();
        self.pose_objects(&poses, false);
        for i in 0..self.labels().len() {
            self.apply_forced(i);
            let (view, overlay) = self.view(i, &poses)?;
            match &self.sink {
                Sink::Outputs { outputs, slots } => {
                    let (r, slot) = (&mut self.renderer, slots[i]);
                    outputs.encode(r, slot, view, overlay.as_ref(), None, Draw::Everything);
                    images.push(outputs.read(slot)?);
                    self.refined
                        .extend(outputs.target(slot).refined_share(&self.ctx)?);
                }
                Sink::Targets(targets) => {
                    self.renderer.set_view_matrix(view.0, view.1);
                    let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
                    self.renderer.encode_view(&mut encoder, &targets[i], None);
                    self.ctx.queue.submit([encoder.finish()]);
                    let image = super::post::read_texture(&self.ctx, &targets[i].image)?;
                    images.push((image, Vec::new()));
                    self.refined.extend(targets[i].refined_share(&self.ctx)?);
                }
            }
        }
        Ok(images)
    }

    /// A still camera's view of the scene with the moving objects posed from `poses` at the
    /// object time (a replay's third-person camera: `camera.size` pixels), at `settings`.
    pub fn read_back_camera(
        &mut self,
        poses: Poses<'_>,
        camera: &crate::scene::Camera,
        settings: ViewSettings,
    ) -> Result<Frame> {
        self.pose_objects(&poses, false);
        self.renderer.set_view_settings(settings);
        let [w, h] = camera.size;
        self.renderer.render(camera, w, h)
    }

    /// View `i`'s settings: those forced from outside, if any; then noted as drawn.
    fn apply_forced(&mut self, i: usize) {
        if let Some(s) = self.forced.as_ref().and_then(|f| f.get(i)) {
            self.renderer.set_view_settings(*s);
        }
        self.drawn.push(self.renderer.view_settings());
    }

    /// Draw the next frames' views with these settings, view by view, instead of the pacer's
    /// (`vlf replay`: what a logged frame was drawn with).
    pub fn force_view_settings(&mut self, settings: Vec<ViewSettings>) {
        self.forced = Some(settings);
    }

    /// With edge antialiasing, the share of each view's pixels it refined in the frame read
    /// back last (empty without it).
    pub fn refined_shares(&self) -> &[f64] {
        &self.refined
    }

    /// What each view of the last frame drawn was drawn with, in view order.
    pub fn drawn(&self) -> &[ViewSettings] {
        &self.drawn
    }

    /// Milliseconds since the frame began.
    pub fn elapsed_ms(&self) -> f64 {
        self.acc.elapsed_ms()
    }

    /// After the frame: its view times to the pacer (read back now, or frames later in flight)
    /// and, when timed, to the report with its CPU time `cpu_ms`.
    pub fn account(&mut self, cpu_ms: f64) -> Result<()> {
        self.acc.account(&self.ctx, cpu_ms, self.pacer.as_mut())
    }

    /// At the end of a run: the times of the frames still in flight.
    pub fn finish(&mut self) -> Result<()> {
        self.acc.finish(&self.ctx, self.pacer.as_mut())
    }

    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// View `i`'s own image, linear radiance as last drawn (the headset's eyes; None for the
    /// CAVE's views, which draw into wall images).
    pub fn view_image(&self, i: usize) -> Option<&wgpu::Texture> {
        match &self.sink {
            Sink::Targets(targets) => targets.get(i).map(|t| &t.image),
            Sink::Outputs { .. } => None,
        }
    }

    /// The CAVE's wall images and outputs (None for the headset's eyes).
    pub fn outputs(&self) -> Option<&Outputs> {
        match &self.sink {
            Sink::Outputs { outputs, .. } => Some(outputs),
            Sink::Targets(_) => None,
        }
    }

    /// The CAVE's walls and eyes in view order (none for the headset).
    pub fn wall_views(&self) -> &[WallView] {
        self.cave.as_ref().map_or(&[], |c| &c.views)
    }

    pub fn labels(&self) -> &[ViewLabel] {
        &self.acc.times.labels
    }

    pub fn times(&self) -> &FrameTimes {
        &self.acc.times
    }

    pub fn times_mut(&mut self) -> &mut FrameTimes {
        &mut self.acc.times
    }

    /// Timed frames so far.
    pub fn frames_timed(&self) -> u32 {
        self.acc.times.frames_timed() as u32
    }

    /// Live tracking: milliseconds from a pose's arrival to its frame's submission.
    pub fn latency_ms(&self) -> Option<Distribution> {
        self.acc.latency_ms()
    }

    pub fn series(&self) -> FrameSeries {
        self.acc.series()
    }

    pub fn in_flight(&self) -> Option<&InFlight> {
        self.acc.in_flight()
    }

    /// The settings every frame was drawn with.
    pub fn quality(&self) -> Quality {
        self.renderer.run_quality(self.pacer.as_ref())
    }

    pub fn fit(&self) -> Option<&BudgetFit> {
        self.fit.as_ref()
    }

    pub fn pacer_report(&self) -> Option<PacerReport> {
        self.pacer.as_ref().map(Pacer::report)
    }
}

/// The frame's last passes: `last`'s, and the resolve of a frame in flight's timestamps.
fn last_passes(
    acc: &mut Accounting,
    encoder: &mut wgpu::CommandEncoder,
    last: Option<LastPasses<'_>>,
) -> Result<()> {
    if let Some(last) = last {
        let span = acc.timestamps().and_then(|t| t.next_span());
        let timed = span.is_some();
        last(encoder, span)?;
        if timed {
            acc.pass(Pass::Output);
        }
    }
    acc.resolve(encoder);
    Ok(())
}
