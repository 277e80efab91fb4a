//! The OpenXR session: the eyes' swapchains on the runtime's Vulkan device (`layers`), the frame loop paced
//! by the runtime (xrWaitFrame / xrBeginFrame / xrEndFrame at the predicted display time), the
//! session states, thumbstick navigation through an action set, the left eye's screenshot and
//! the per-eye frame-time report, with when the GPU finished each frame on the runtime's clock
//! (what the runtime's account of late and dropped frames rests on: `report::display_account`).
//! Both eyes are a frame of views (`crate::display::frame::FrameOfViews`, their times read back
//! frames in flight): each rendered by the CAVE's renderer (one compute pass, constant work per
//! pixel) into an offscreen image and depth from the runtime's eye poses (`eye_view`), and both
//! put on the swapchain images by `layers` in the frame's last encoder.

use super::body::{self, BodyFrame, BodyReport};
use super::controls::{controls, Controls, Grips};
use super::eyes::{copy_to_buffer, write_screenshot};
use super::layers::Layers;
use super::report::{compositor_lead_ns, display_account, refresh_period_ns, ShownFrame, XrReport};
use super::{eye_view, xr_error, Fov, XrOptions, XrPose, XrRuntime, VIEW_TYPE};
use crate::display::conditions::{Conditions, ConditionsFile, MainField};
use crate::display::frame::{frame_limits, FrameOfViews, Limit, Poses, ViewLabel};
use crate::display::post::Draw;
use crate::display::present::present_pass;
use crate::dynamic::{Objects, Tracked};
use crate::error::{Result, VlfError};
use crate::gpu::{GpuContext, MemoryLedger, PairSpan};
use crate::lightfield::{LightField, ResidentLightField};
use crate::render::probes::ObjectLighting;
use crate::render::{ObjectsToDraw, Renderer};
use crate::stats::Distribution;
use crate::tracking::navigator::Navigator;
use crate::tracking::source::Pose;
use glam::{Quat, Vec3};
use openxr as xr;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// metres: the near plane of both eyes
const NEAR: f32 = 0.05;
/// metres: the near and far plane of the eyes' depth (the depth layer's nearZ and farZ)
const DEPTH_RANGE: (f32, f32) = (NEAR, NEAR * super::FAR_OVER_NEAR);

/// Where the stage stands in the world so that the head, as first tracked, is at the scene
/// camera's eye and looks along its direction (yaw only; the floor stays level).
fn start_room(camera: &crate::scene::Camera, views: &[xr::View]) -> Pose {
    let head = views
        .iter()
        .map(|v| Vec3::new(v.pose.position.x, v.pose.position.y, v.pose.position.z))
        .sum::<Vec3>()
        / views.len().max(1) as f32;
    let o = views[0].pose.orientation;
    let head_forward = Quat::from_xyzw(o.x, o.y, o.z, o.w).normalize() * Vec3::NEG_Z;
    let yaw_of = |f: Vec3| (-f.x).atan2(-f.z);
    let camera_forward = Vec3::from(camera.target) - Vec3::from(camera.eye);
    let yaw = if camera_forward.x.abs() + camera_forward.z.abs() > 1e-6 {
        yaw_of(camera_forward)
    } else {
        0.0
    };
    let head_yaw = if head_forward.x.abs() + head_forward.z.abs() > 1e-6 {
        yaw_of(head_forward)
    } else {
        0.0
    };
    let room_yaw = yaw - head_yaw;
    Pose::new(
        head,
        Vec3::from(camera.eye) - Quat::from_rotation_y(room_yaw) * head,
        room_yaw.to_degrees(),
    )
}

/// The session's fixed parts: the reference space, the blend mode and the swapchain formats.
struct Setup {
    space_type: xr::ReferenceSpaceType,
    space: xr::Space,
    blend: xr::EnvironmentBlendMode,
    vk_format: ash::vk::Format,
    format: wgpu::TextureFormat,
    /// the depth swapchain's format, or why the runtime gets no depth
    depth: std::result::Result<(ash::vk::Format, wgpu::TextureFormat), String>,
}

fn setup(
    instance: &xr::Instance,
    system: xr::SystemId,
    session: &xr::Session<xr::Vulkan>,
    runtime: &XrRuntime,
) -> Result<Setup> {
    let spaces = session
        .enumerate_reference_spaces()
        .map_err(xr_error("reference spaces"))?;
    let space_type = if spaces.contains(&xr::ReferenceSpaceType::STAGE) {
        xr::ReferenceSpaceType::STAGE
    } else {
        xr::ReferenceSpaceType::LOCAL
    };
    let space = session
        .create_reference_space(space_type, xr::Posef::IDENTITY)
        .map_err(xr_error("xrCreateReferenceSpace"))?;
    let blend_modes = instance
        .enumerate_environment_blend_modes(system, VIEW_TYPE)
        .map_err(xr_error("blend modes"))?;
    let blend = if blend_modes.contains(&xr::EnvironmentBlendMode::OPAQUE) {
        xr::EnvironmentBlendMode::OPAQUE
    } else {
        blend_modes[0]
    };
    let formats = session
        .enumerate_swapchain_formats()
        .map_err(xr_error("swapchain formats"))?;
    let (vk_format, format) = super::vulkan::SWAPCHAIN_FORMATS
        .iter()
        .copied()
        .find(|(vk, _)| formats.contains(&(vk.as_raw() as u32)))
        .ok_or_else(|| VlfError::Display(format!("the OpenXR runtime offers no swapchain format vlf can draw into (offered Vulkan formats {formats:?}; vlf needs RGBA8 or BGRA8, sRGB or UNORM)")))?;
    let depth = match runtime.depth {
        false => Err("not offered by the runtime (no XR_KHR_composition_layer_depth)".into()),
        true => (super::vulkan::DEPTH_FORMATS.iter().copied())
            .find(|(vk, _)| formats.contains(&(vk.as_raw() as u32)))
            .ok_or_else(|| format!("not submitted: the runtime offers no depth format vlf writes (D32_SFLOAT or D16_UNORM; offered {formats:?})")),
    };
    Ok(Setup {
        space_type,
        space,
        blend,
        vk_format,
        format,
        depth,
    })
}

/// How many frames the CPU may record ahead of the GPU: frame N+1 is recorded while N is drawn.
const FRAMES_IN_FLIGHT: usize = 2;

/// Run the session until the runtime ends it (or `options.frames` have been shown). The light
/// field is made on the runtime's device by `make_light_field`; the moving `objects` (with how
/// they are lit), where given, follow the head and the controllers.
pub fn run(
    (instance, system, runtime): (xr::Instance, xr::SystemId, XrRuntime),
    make_light_field: &mut super::MakeLightField<'_>,
    (objects, conditions): (Option<(Objects, ObjectLighting)>, Option<ConditionsFile>),
    options: &XrOptions,
) -> Result<XrReport> {
    let vulkan = super::vulkan::create(&instance, system)?;
    let ctx = vulkan.ctx.clone();
    eprintln!(
        "OpenXR: {} ({}) on {}",
        runtime.runtime, runtime.system, ctx.summary.name
    );
    let (lf, resident) = make_light_field(&ctx)?;
    let prepared = prepare_conditions(conditions.as_ref(), options, (&lf, &resident))?;
    let camera = lf.camera(options.camera.as_deref())?.clone();
    let to_draw = objects.as_ref().map(|(o, lighting)| ObjectsToDraw {
        mesh: o.mesh(),
        lighting: *lighting,
    });
    let mut renderer = Renderer::with_objects(&resident, &lf, &MemoryLedger::default(), to_draw)?;
    renderer.set_samples_per_pixel(options.antialiasing)?;
    renderer.set_first_hits(options.first_hits)?;
    renderer.set_edge_antialiasing(options.edge_antialiasing)?;
    let controls = controls(&instance)?;

    // SAFETY: the session info names the instance, device and queue the runtime created for
    // this system; they outlive the session (dropped at the end of this function, after it).
    let (session, frame_waiter, frame_stream) =
        unsafe { instance.create_session::<xr::Vulkan>(system, &vulkan.session_info) }
            .map_err(xr_error("xrCreateSession"))?;
    session
        .attach_action_sets(&[&controls.set])
        .map_err(xr_error("xrAttachSessionActionSets"))?;
    // the hands are located for objects to follow, and for the session log
    let grips = match objects.is_some() || options.study.log.is_some() {
        true => Some(controls.grip_spaces(&session)?),
        false => None,
    };
    let setup = setup(&instance, system, &session, &runtime)?;
    let eyes = super::eyes::create((&instance, system), &renderer, options)?;
    let layers = Layers::create(
        &ctx,
        &session,
        &eyes.iter().map(|e| &e.targets).collect::<Vec<_>>(),
        ((setup.vk_format, setup.format), setup.depth.clone()),
        options,
    )?;
    eprintln!(
        "OpenXR eyes: {}; depth: {}",
        layers.eyes_text(),
        layers.depth_text(DEPTH_RANGE)
    );
    // from here on Ctrl-C ends the session cleanly, with the report (warm-up included)
    interrupt_flag();
    super::eyes::warm_up(&ctx, &mut renderer, &eyes, (&camera, &lf), &layers)?;
    let eyes = (eyes.into_iter())
        .map(|e| {
            let label = ViewLabel {
                wall: "headset".into(),
                eye: e.name,
                pixels: e.size,
            };
            (label, e.targets)
        })
        .collect();
    let objects = objects.map(|(o, _)| o);
    let mut frame = FrameOfViews::eyes(&ctx, renderer, eyes, FRAMES_IN_FLIGHT, objects);
    if let Some(c) = &prepared {
        frame.use_conditions(c)?;
    }
    let adapter = ctx.summary.name.clone();
    let mut parts = super::study::open(options, (&lf, &adapter, &runtime), frame.labels(), NEAR)?;
    let study = super::study::session(&mut parts, &frame, conditions.as_ref());

    let mut headset = Headset {
        instance: &instance,
        session: &session,
        frame_waiter,
        frame_stream,
        setup: &setup,
        ctx: &ctx,
        frame,
        layers,
        controls,
        grips,
        camera: &camera,
        runtime: &runtime,
        study,
    };
    let mut state = LoopState::new(&ctx, runtime.clock);
    let ended = headset.run_loop(&mut state, options)?;
    let report = state.report(&mut headset, ended, options)?;
    // the swapchains and the session go before the device they were made on
    ctx.wait()?;
    let Headset {
        frame,
        layers,
        controls,
        grips,
        frame_stream,
        frame_waiter,
        study,
        ..
    } = headset;
    // the log's last rows onto the disk
    drop(study);
    drop(parts);
    drop(layers);
    drop((grips, controls, frame_stream, frame_waiter));
    drop(setup);
    drop(session);
    // the renderer and the eyes' images it drew into, and the conditions' light fields
    drop(frame);
    drop((prepared, resident, lf));
    drop(ctx);
    drop(vulkan);
    drop(instance);
    Ok(report)
}

/// The conditions of `--conditions` with their light fields made beside the `--scene`'s
/// (`lf`, `resident`) before the first frame, each said on stderr with its GPU memory.
fn prepare_conditions(
    file: Option<&ConditionsFile>,
    options: &XrOptions,
    (lf, resident): (&LightField, &ResidentLightField),
) -> Result<Option<Conditions>> {
    let (Some(file), Some((path, scene))) = (file, &options.study.conditions) else {
        return Ok(None);
    };
    let main = MainField {
        source: scene,
        lf,
        resident,
    };
    let list = (&file.conditions[..], file.default_condition.as_deref());
    let prepared = Conditions::prepare_list(list, path, main, &crate::progress::Silent)?;
    for f in prepared.iter().flat_map(|c| &c.fields) {
        eprintln!("conditions: light field {}", f.describe());
    }
    Ok(prepared)
}

/// What the frame loop draws with.
/// (`'c`: the conditions the frame draws, dropped after it)
struct Headset<'a, 'c> {
    instance: &'a xr::Instance,
    session: &'a xr::Session<xr::Vulkan>,
    frame_waiter: xr::FrameWaiter,
    frame_stream: xr::FrameStream<xr::Vulkan>,
    setup: &'a Setup,
    ctx: &'a Arc<GpuContext>,
    /// the renderer, both eyes' images, their pacing and times (frames in flight)
    frame: FrameOfViews<'c>,
    /// the swapchains the eyes go on
    layers: Layers,
    controls: Controls,
    /// the controllers' grip spaces, where objects follow the hands
    grips: Option<Grips>,
    camera: &'a crate::scene::Camera,
    runtime: &'a XrRuntime,
    /// the study's commands, log and LSL outlets (`super::study`)
    study: crate::study::Session<'a>,
}

/// Everything the frame loop counts and keeps between frames.
struct LoopState {
    navigator: Navigator,
    room: Option<Pose>,
    running: bool,
    exit_requested: bool,
    states: Vec<String>,
    lost: bool,
    frames: u32,
    skipped: u32,
    /// every timed frame's predicted display time, period and clock reference
    shown: Vec<FrameClock>,
    /// when the GPU finished each timed frame (with the runtime's clock only)
    gpu_done: Option<GpuDone>,
    last_display_time: Option<i64>,
    period_ms: f64,
    screenshot_written: Option<String>,
    screenshot_writer: Option<std::thread::JoinHandle<Result<()>>>,
    waiting_since: Instant,
    /// the first drawn frame's predicted display time: keyframed objects' time counts from it
    first_display_ns: Option<i64>,
    /// frames drawn whose left and right grips the runtime located
    grips_located: [u32; 2],
    /// the last frame's navigated pose and what its objects followed
    last_tracked: Option<(Pose, Tracked)>,
    /// the controllers' grips (left, right) in the stage, as this frame located them
    hands: [Option<crate::tracking::pose::WandPose>; 2],
    /// frames still to end without layers after the frame-time fit (`FRAMES_AFTER_FIT`)
    empty_frames_left: u32,
}

/// Frames ended without layers after the frame-time fit. The fit's probe takes many refresh
/// periods, so xrWaitFrame hands back the frame after it at once, wherever the refresh is: drawn,
/// its GPU work would start up to a period behind the runtime's rhythm, and with the eyes filling
/// most of a period the frames after it would stay behind for dozens of frames (on an H200 the
/// glossy classroom's GPU frame was 10.96 ms of 11.11 while the layers' pass still cleared its
/// images: late frames drained 0.15 ms a frame, 5-43 of them shown late in 10 of 11 runs; it is
/// 9.70 ms now). The frame after an empty one is paced by the runtime;
/// a second one covers runtimes that hand back two frames at once after a stall.
const FRAMES_AFTER_FIT: u32 = 2;

/// What the display showed of the timed frames (`display_account`).
struct Display {
    account: super::report::DisplayAccount,
    /// the refresh period the account stepped by (`refresh_period_ns`), ms
    period_ms: Option<f64>,
    /// with the runtime's clock: what depends on when the GPU finished each frame
    done: Option<DisplayDone>,
    /// with the runtime's clock: per timed frame, from its pose (xrLocateViews) to its
    /// predicted display time, ms
    pose_to_photon_ms: Option<crate::stats::Distribution>,
}

struct DisplayDone {
    late: u64,
    dropped: u64,
    lead_ms: f64,
    before_display_ms: crate::stats::Distribution,
    after_display: u64,
    /// the first timed frames one by one (`XrReport::first_frames`)
    first_frames: Vec<super::report::FrameStart>,
}

/// The first timed frames (`XrReport::first_frames`): each one's predicted display time after
/// the first's, how long before it xrWaitFrame returned, and how long before it the GPU finished
/// (`before_display_ms`, per frame).
fn first_frames(shown: &[FrameClock], before_display_ms: &[f64]) -> Vec<super::report::FrameStart> {
    let Some(first) = shown.first() else {
        return Vec::new();
    };
    (shown.iter().zip(before_display_ms))
        .take(super::report::FIRST_FRAMES)
        .filter_map(|(f, &gpu)| {
            let (_, woke) = f.clock?;
            Some(super::report::FrameStart {
                display_ms: (f.display_ns - first.display_ns) as f64 * 1e-6,
                woke_before_display_ms: (f.display_ns - woke) as f64 * 1e-6,
                gpu_done_before_display_ms: gpu,
                // from the GPU's clock, once the frames' timestamps are read (`report`)
                gpu_span_ms: None,
                gpu_before_ms: None,
            })
        })
        .collect()
}

/// A timed frame's predicted display time and period (XrTime, ns), and an instant on this
/// process's monotonic clock with the runtime's time at it, taken when xrWaitFrame returned (with
/// the runtime's clock only): the frame's GPU completion goes onto the runtime's clock through it.
struct FrameClock {
    display_ns: i64,
    period_ns: i64,
    clock: Option<(Instant, i64)>,
    /// when xrLocateViews gave the frame's head pose (predicted for its display time)
    located: Instant,
}

/// When the GPU finished each timed frame: a thread polls for the frame's last submission and
/// notes the time, as the runtime waits for the frame's semaphore before it may show the frame.
struct GpuDone {
    frames: Option<std::sync::mpsc::Sender<(usize, wgpu::SubmissionIndex)>>,
    thread: Option<std::thread::JoinHandle<Vec<(usize, Instant)>>>,
}

impl GpuDone {
    fn new(device: &wgpu::Device, software: bool) -> GpuDone {
        let (frames, submitted) = std::sync::mpsc::channel::<(usize, wgpu::SubmissionIndex)>();
        let device = device.clone();
        // polled without sleeping on a GPU; on a software adapter the GPU is the CPU, and a
        // spinning thread would take a core from it
        let spin = !software;
        let thread = std::thread::Builder::new()
            .name("vlf xr: GPU done".into())
            .spawn(move || {
                let mut done = Vec::new();
                for (frame, submission) in submitted {
                    // polled without sleeping: a thread put to sleep is woken milliseconds
                    // late now and then, and the frame would be counted late
                    let waited = loop {
                        let poll = device.poll(wgpu::PollType::Wait {
                            submission_index: Some(submission.clone()),
                            timeout: spin.then_some(Duration::ZERO),
                        });
                        match poll {
                            Err(wgpu::PollError::Timeout) => std::hint::spin_loop(),
                            other => break other,
                        }
                    };
                    if waited.is_ok() {
                        done.push((frame, Instant::now()));
                    }
                }
                done
            })
            .ok();
        GpuDone {
            frames: Some(frames),
            thread,
        }
    }

    /// Note when the GPU finishes `submission`, the last of timed frame `frame` (0-based).
    fn watch(&self, frame: usize, submission: wgpu::SubmissionIndex) {
        if let Some(f) = &self.frames {
            let _ = f.send((frame, submission));
        }
    }

    /// When the GPU finished each of the first `frames` timed frames (None: not watched, or the
    /// wait failed); the thread has ended.
    fn finish(&mut self, frames: usize) -> Vec<Option<Instant>> {
        drop(self.frames.take());
        let mut out = vec![None; frames];
        if let Some(done) = self.thread.take().and_then(|t| t.join().ok()) {
            for (n, at) in done {
                if let Some(slot) = out.get_mut(n) {
                    *slot = Some(at);
                }
            }
        }
        out
    }
}

impl Drop for GpuDone {
    /// The thread holds the device: it ends before the device and the runtime's session go.
    fn drop(&mut self) {
        self.finish(0);
    }
}

impl LoopState {
    fn new(ctx: &GpuContext, clock: bool) -> LoopState {
        LoopState {
            navigator: Navigator::default(),
            room: None,
            running: false,
            exit_requested: false,
            states: Vec::new(),
            lost: false,
            frames: 0,
            skipped: 0,
            shown: Vec::new(),
            gpu_done: clock.then(|| GpuDone::new(&ctx.device, ctx.summary.software)),
            last_display_time: None,
            period_ms: 0.0,
            screenshot_written: None,
            screenshot_writer: None,
            waiting_since: Instant::now(),
            first_display_ns: None,
            grips_located: [0; 2],
            hands: [None; 2],
            last_tracked: None,
            empty_frames_left: 0,
        }
    }

    /// The time since the last frame's predicted display time, in seconds.
    fn since_last_frame(&mut self, frame_state: &xr::FrameState) -> f32 {
        let display_time = frame_state.predicted_display_time.as_nanos();
        let period = frame_state.predicted_display_period.as_nanos().max(1);
        self.period_ms = period as f64 * 1e-6;
        let dt = self
            .last_display_time
            .map(|l| ((display_time - l) as f64 * 1e-9) as f32)
            .unwrap_or(0.0)
            .clamp(0.0, 0.1);
        self.last_display_time = Some(display_time);
        dt
    }

    /// The runtime's account of the timed frames (`display_account`), from when the GPU
    /// finished each on the runtime's clock; without that clock, only the gaps in its
    /// predictions.
    fn display(&mut self) -> Display {
        let n = self.shown.len();
        let finished = self.gpu_done.as_mut().map(|g| g.finish(n));
        let done_ns = |(f, at): (&FrameClock, Option<Instant>)| {
            let (then, xr_then) = f.clock?;
            Some(xr_then + at?.saturating_duration_since(then).as_nanos() as i64)
        };
        let done: Option<Vec<i64>> = finished.and_then(|at| {
            self.shown
                .iter()
                .zip(at)
                .map(done_ns)
                .collect::<Option<_>>()
        });
        let frames: Vec<ShownFrame> = (self.shown.iter().enumerate())
            .map(|(k, f)| ShownFrame {
                display_ns: f.display_ns,
                period_ns: f.period_ns,
                // without the clock every frame counts as ready at once: the gaps only
                gpu_done_ns: done.as_ref().map_or(i64::MIN, |d| d[k]),
            })
            .collect();
        let period = refresh_period_ns(&frames);
        let lead = compositor_lead_ns(period);
        let account = display_account(&frames, if done.is_some() { lead } else { 0 });
        let done = done.filter(|d| !d.is_empty()).map(|d| {
            let before: Vec<f64> = (frames.iter().zip(&d))
                .map(|(f, t)| (f.display_ns - t) as f64 * 1e-6)
                .collect();
            DisplayDone {
                late: account.late,
                dropped: account.dropped,
                lead_ms: lead as f64 * 1e-6,
                after_display: before.iter().filter(|&&b| b < 0.0).count() as u64,
                first_frames: first_frames(&self.shown, &before),
                before_display_ms: crate::stats::Distribution::of(&before),
            }
        });
        let period_ms = (!frames.is_empty()).then_some(period as f64 * 1e-6);
        // the pose's time on the runtime's clock, through the clock pair taken at xrWaitFrame
        let photon_ms = |f: &FrameClock| {
            let (then, xr_then) = f.clock?;
            let located = xr_then + f.located.saturating_duration_since(then).as_nanos() as i64;
            Some((f.display_ns - located) as f64 * 1e-6)
        };
        let photon: Option<Vec<f64>> = self.shown.iter().map(photon_ms).collect();
        Display {
            account,
            period_ms,
            done,
            pose_to_photon_ms: photon
                .filter(|p| !p.is_empty())
                .map(|p| crate::stats::Distribution::of(&p)),
        }
    }

    fn report(
        mut self,
        headset: &mut Headset,
        ended: String,
        options: &XrOptions,
    ) -> Result<XrReport> {
        // when the GPU finished the last frames, before anything here waits for the device: a
        // thread blocked in a device wait holds wgpu's device lock, and the GPU-done thread would
        // note the last frames milliseconds late (counted as a missed refresh)
        let display = self.display();
        headset.frame.finish()?;
        if let Some(writer) = self.screenshot_writer.take() {
            writer
                .join()
                .map_err(|_| VlfError::Display("the screenshot writer failed".into()))??;
        }
        if let (Some(path), None, false) =
            (&options.screenshot, &self.screenshot_written, self.lost)
        {
            return Err(VlfError::Display(format!(
                "the session ended after {} frames, before frame {} that --screenshot {} asked for",
                self.frames,
                options.screenshot_frame,
                path.display()
            )));
        }
        let times = headset.frame.times();
        let eyes = times.views();
        let (spans, between) = times.gpu_spans();
        let mut first_frames = display
            .done
            .as_ref()
            .map_or_else(Vec::new, |d| d.first_frames.clone());
        for (k, f) in first_frames.iter_mut().enumerate() {
            f.gpu_span_ms = spans.get(k).copied();
            f.gpu_before_ms = between.get(k).copied().flatten();
        }
        let between: Vec<f64> = between.iter().flatten().copied().collect();
        let mut limits = frame_limits(&eyes, None, None);
        limits.push(Limit::check(
            "missed display refreshes",
            display.account.missed as f64,
            0.0,
        ));
        if let Some(done) = &display.done {
            limits.push(Limit::check("frames shown late", done.late as f64, 0.0));
            limits.push(Limit::check("frames dropped", done.dropped as f64, 0.0));
        }
        let in_flight = headset.frame.in_flight();
        Ok(XrReport {
            runtime: headset.runtime.runtime.clone(),
            system: headset.runtime.system.clone(),
            adapter: headset.ctx.summary.name.clone(),
            reference_space: format!("{:?}", headset.setup.space_type).to_lowercase(),
            swapchain_format: format!("{:?}", headset.setup.format),
            swapchains: match headset.layers.shape {
                super::layers::Shape::PerEye => "per-eye".into(),
                super::layers::Shape::Array { .. } => "array".into(),
            },
            multiview: headset.layers.shape == super::layers::Shape::Array { multiview: true },
            eye_layers: headset.layers.eyes_text(),
            depth_submitted: headset.layers.depth_format.is_ok(),
            depth: headset.layers.depth_text(DEPTH_RANGE),
            interaction_profiles: headset.controls.profiles.clone(),
            body: self.body_report(headset),
            frames: self.frames,
            frames_skipped: self.skipped,
            missed_frames: display.account.missed,
            missed_after_frames: display.account.missed_after,
            prediction_gaps: display.account.gaps,
            late_frames: display.done.as_ref().map(|d| d.late),
            dropped_frames: display.done.as_ref().map(|d| d.dropped),
            compositor_lead_ms: display.done.as_ref().map(|d| d.lead_ms),
            gpu_done_before_display_ms: display.done.as_ref().map(|d| d.before_display_ms.clone()),
            first_frames,
            pose_to_photon_ms: display.pose_to_photon_ms.clone(),
            gpu_done_after_display: display.done.as_ref().map(|d| d.after_display),
            display_period_ms: display.period_ms.unwrap_or(self.period_ms),
            eyes,
            objects_gpu_ms: times.objects_gpu_ms(),
            layers_gpu_ms: times.output_gpu_ms(),
            frame_gpu_span_ms: (!spans.is_empty()).then(|| Distribution::of(spans)),
            gpu_between_frames_ms: (!between.is_empty()).then(|| Distribution::of(&between)),
            cpu_frame_ms: times.cpu_ms(),
            frames_in_flight: FRAMES_IN_FLIGHT as u32,
            overlapped_frames: in_flight.map_or(0, |f| f.overlapped),
            serial_frames: in_flight.map_or(0, |f| f.serial),
            waited_for_gpu: in_flight.map_or(0, |f| f.waited),
            limits,
            quality: headset.frame.quality(),
            pacer: headset.frame.pacer_report(),
            fit: headset.frame.fit().cloned(),
            states: self.states,
            ended,
            lost: self.lost,
            screenshot: self.screenshot_written,
        })
    }
}

impl LoopState {
    /// With objects: how often the hands were tracked, and where the last frame put the head,
    /// the grips and the avatar's hands.
    fn body_report(&self, headset: &Headset) -> Option<BodyReport> {
        let objects = headset.frame.objects()?;
        let last = self.last_tracked.as_ref().map(|(pose, tracked)| BodyFrame {
            room_position: pose.room_position.to_array(),
            room_yaw_deg: pose.room_yaw_deg,
            head: tracked.head.into(),
            left_grip: tracked.left_hand.map(Into::into),
            right_grip: tracked.wand.map(Into::into),
            avatar_hands: objects
                .avatar_hands(tracked)
                .map(|hands| hands.map(|h| h.to_array())),
        });
        Some(BodyReport {
            objects: (objects.configs().iter()).map(|o| o.name.clone()).collect(),
            frames_with_left_grip: self.grips_located[0],
            frames_with_right_grip: self.grips_located[1],
            last,
        })
    }
}

impl Headset<'_, '_> {
    /// Frames until the session ends; how it ended.
    fn run_loop(&mut self, st: &mut LoopState, options: &XrOptions) -> Result<String> {
        let mut event_buffer = xr::EventDataBuffer::new();
        let interrupted = interrupt_flag();
        eprintln!("OpenXR frames: running (Ctrl-C ends the session cleanly, with the report)");
        loop {
            if let Some(ended) = self.poll_events(st, &mut event_buffer, options, &interrupted)? {
                return Ok(ended);
            }
            if !st.running {
                if st.waiting_since.elapsed() > Duration::from_secs(5) {
                    eprintln!(
                        "waiting for the OpenXR runtime to make the session ready (states so far: {})",
                        st.states.join(" -> ")
                    );
                    st.waiting_since = Instant::now();
                }
                std::thread::sleep(Duration::from_millis(5));
                continue;
            }
            self.frame(st, options)?;
            let enough = options.frames.is_some_and(|n| st.frames >= n);
            let stop = interrupted.load(std::sync::atomic::Ordering::Relaxed);
            if (enough || stop || self.study.stop) && !st.exit_requested {
                if stop {
                    eprintln!("interrupted: ending the OpenXR session");
                }
                self.session
                    .request_exit()
                    .map_err(xr_error("xrRequestExitSession"))?;
                st.exit_requested = true;
            }
        }
    }

    /// The runtime's events: session states begin and end the session; Some(how it ended)
    /// once it has.
    fn poll_events(
        &mut self,
        st: &mut LoopState,
        buffer: &mut xr::EventDataBuffer,
        options: &XrOptions,
        interrupted: &std::sync::atomic::AtomicBool,
    ) -> Result<Option<String>> {
        while let Some(event) = self
            .instance
            .poll_event(buffer)
            .map_err(xr_error("xrPollEvent"))?
        {
            let frames = st.frames;
            match event {
                xr::Event::SessionStateChanged(e) => {
                    let state = e.state();
                    st.states.push(format!("{state:?}").to_lowercase());
                    match state {
                        xr::SessionState::READY => {
                            self.session
                                .begin(VIEW_TYPE)
                                .map_err(xr_error("xrBeginSession"))?;
                            st.running = true;
                        }
                        xr::SessionState::STOPPING => {
                            self.session.end().map_err(xr_error("xrEndSession"))?;
                            st.running = false;
                        }
                        xr::SessionState::EXITING => {
                            let stopped = interrupted.load(std::sync::atomic::Ordering::Relaxed);
                            return Ok(Some(match (st.exit_requested, stopped) {
                                (true, true) => {
                                    format!("cleanly, interrupted (Ctrl-C) after {frames} frames")
                                }
                                (true, false) => format!(
                                    "cleanly, after the {} frames asked for",
                                    options.frames.unwrap_or(frames)
                                ),
                                _ => "cleanly, the runtime or the user ended the session".into(),
                            }));
                        }
                        xr::SessionState::LOSS_PENDING => {
                            st.lost = true;
                            return Ok(Some(format!("the runtime lost the session after {frames} frames (headset disconnected or runtime stopped)")));
                        }
                        _ => {}
                    }
                }
                xr::Event::InstanceLossPending(_) => {
                    st.lost = true;
                    return Ok(Some(format!("the OpenXR runtime went away after {frames} frames (instance loss pending)")));
                }
                _ => {}
            }
        }
        Ok(None)
    }

    /// The first frame with `fit_frame_time`: the eyes probed (render/budget.rs) against the
    /// runtime's display period, and nothing shown (the probe takes longer than a frame; no
    /// frame is timed yet).
    fn fit_frame(
        &mut self,
        frame_state: &xr::FrameState,
        views: &[xr::View],
        (pose, tracked): (&Pose, Option<&Tracked>),
    ) -> Result<()> {
        let matrices = self.eye_matrices(views, pose);
        let period_ms = frame_state.predicted_display_period.as_nanos() as f64 * 1e-6;
        let eyes = Poses::Eyes {
            matrices: &matrices,
            tracked,
        };
        (self.frame).fit_frame_time(eyes, period_ms)?;
        self.end_empty(frame_state)
    }

    /// End the frame begun for `frame_state` with no layers: the runtime shows nothing new.
    fn end_empty(&mut self, frame_state: &xr::FrameState) -> Result<()> {
        self.frame_stream
            .end(frame_state.predicted_display_time, self.setup.blend, &[])
            .map_err(xr_error("xrEndFrame"))
    }

    /// Each eye's view-projection and position in the light field's space (`eye_view`).
    fn eye_matrices(&self, views: &[xr::View], pose: &Pose) -> Vec<(glam::Mat4, Vec3)> {
        // the scene drawn now (a condition's of other geometry has its own)
        let norm = &self.frame.renderer().normalisation();
        (views.iter())
            .map(|view| eye_view(xr_pose(view), xr_fov(view), pose, norm, NEAR))
            .collect()
    }

    /// One frame, paced by the runtime: wait, begin, draw both eyes, end. The GPU's work is not
    /// waited for: its timestamps come back frames later (`InFlight`).
    fn frame(&mut self, st: &mut LoopState, options: &XrOptions) -> Result<()> {
        let frame_state = self.frame_waiter.wait().map_err(xr_error("xrWaitFrame"))?;
        let woke = self.clock()?;
        let dt = st.since_last_frame(&frame_state);
        let begun = Instant::now();
        self.frame_stream
            .begin()
            .map_err(xr_error("xrBeginFrame"))?;
        if !frame_state.should_render {
            st.skipped += 1;
            return self.end_empty(&frame_state);
        }
        if st.empty_frames_left > 0 {
            st.empty_frames_left -= 1;
            return self.end_empty(&frame_state);
        }
        // what the script sent takes effect from this frame
        self.study.begin_frame();
        self.frame.take_study_changes(&mut self.study)?;
        // a condition's exposure on top of --exposure
        (self.layers).set_exposure(self.ctx, options.exposure * self.frame.exposure());
        let pad = self.controls.read(self.session, &mut st.navigator)?;
        let (_, views) = self
            .session
            .locate_views(
                VIEW_TYPE,
                frame_state.predicted_display_time,
                &self.setup.space,
            )
            .map_err(xr_error("xrLocateViews"))?;
        let located = Instant::now();
        let base = *st
            .room
            .get_or_insert_with(|| start_room(self.camera, &views));
        let navigation = crate::tracking::Navigation::default();
        st.navigator.step(dt, &navigation, pad, base.room_yaw_deg);
        let pose = self.study.pose(st.navigator.apply(base), located);
        let tracked = self.track_body(st, &views, &pose, frame_state.predicted_display_time)?;
        if options.fit_frame_time && self.frame.fit().is_none() {
            st.empty_frames_left = FRAMES_AFTER_FIT;
            return self.fit_frame(&frame_state, &views, (&pose, tracked.as_ref()));
        }
        if let Some(t) = &tracked {
            st.grips_located[0] += u32::from(t.left_hand.is_some());
            st.grips_located[1] += u32::from(t.wand.is_some());
        }
        let timed = options.frames.is_none_or(|n| st.frames < n);
        if timed {
            st.shown.push(FrameClock {
                display_ns: frame_state.predicted_display_time.as_nanos(),
                period_ns: frame_state.predicted_display_period.as_nanos(),
                clock: woke,
                located,
            });
        }
        // a timed frame takes a slot of the frames in flight; those the GPU has finished are
        // read (their times to the pacer and the report)
        self.frame.begin(timed)?;
        let capture = options.screenshot.is_some() && st.frames + 1 == options.screenshot_frame;
        // a .exr screenshot is the left eye's linear radiance as drawn (`vlf replay --exr`
        // draws the same), a .png what went onto its swapchain
        let linear = (options.screenshot.as_deref()).is_some_and(crate::render::image_io::is_exr);
        let poses = (&pose, tracked.as_ref());
        let readback = self.draw_eyes(st, &views, poses, (timed, capture && !linear))?;
        if let (true, true, Some(path)) = (capture, linear, &options.screenshot) {
            let left = self.frame.view_image(0).expect("the eyes' own images");
            let image = crate::display::post::read_texture(self.ctx, left)?;
            crate::render::image_io::write_image(&image, path, 1.0)?;
            st.screenshot_written = Some(path.display().to_string());
        }
        let pose_to_submit_ms = located.elapsed().as_secs_f64() * 1e3;
        let fixed = (&frame_state, self.setup.blend, &self.setup.space);
        (self.layers).end_frame(&mut self.frame_stream, fixed, &views, DEPTH_RANGE)?;
        self.ctx.check_errors()?;
        st.frames += 1;
        let cpu_ms = begun.elapsed().as_secs_f64() * 1e3;
        self.frame.account(cpu_ms)?;
        let display_ns = frame_state.predicted_display_time.as_nanos();
        self.study.display_due(super::study::due(woke, display_ns));
        let drew = super::study::Drew {
            frame: st.frames as u64 - 1,
            room: pose,
            head: head_of(&views),
            hands: st.hands,
            eyes: (views.iter())
                .map(|v| crate::display::headset_view::eye_record(xr_pose(v), xr_fov(v)))
                .collect(),
            cpu_ms,
            pose_to_submit_ms,
            object_time_s: tracked.as_ref().map(|t| t.time),
        };
        let time_s = self.study.time_s();
        let record = super::study::record(drew, time_s, &self.frame);
        self.study.end_frame(record, None)?;
        if let (Some((buffer, padded_row)), Some(path)) = (readback, options.screenshot.as_ref()) {
            self.write_screenshot(st, &buffer, padded_row, path)?;
        }
        Ok(())
    }

    /// With objects: what they follow at this frame's display time (the head between the eyes,
    /// the controllers' grips, in the world through the navigated `pose`), and the object time
    /// from the first frame's display time.
    fn track_body(
        &mut self,
        st: &mut LoopState,
        views: &[xr::View],
        pose: &Pose,
        display_time: xr::Time,
    ) -> Result<Option<Tracked>> {
        let Some(grips) = &self.grips else {
            return Ok(None);
        };
        let hands = grips.locate(&self.setup.space, display_time)?;
        st.hands = hands;
        let head = head_of(views);
        let first = *st.first_display_ns.get_or_insert(display_time.as_nanos());
        let seconds = (display_time.as_nanos() - first) as f64 * 1e-9;
        self.frame.set_object_time(seconds);
        let tracked = body::tracked(
            pose,
            head,
            hands.map(|h| h.map(body::hand_in_stage)),
            seconds,
        );
        st.last_tracked = Some((*pose, tracked));
        Ok(Some(tracked))
    }

    /// Now on this process's monotonic clock and on the runtime's (None without
    /// XR_KHR_convert_timespec_time).
    fn clock(&self) -> Result<Option<(Instant, i64)>> {
        if !self.runtime.clock {
            return Ok(None);
        }
        let at = Instant::now();
        let now = (self.instance.now()).map_err(xr_error("xrConvertTimespecTimeToTimeKHR"))?;
        Ok(Some((at, now.as_nanos())))
    }

    /// Render both eyes (a compute pass and submission each: they share the renderer's view
    /// buffer) and put them on this frame's swapchain images with the last; the left eye's image
    /// copied for the screenshot when `capture`.
    fn draw_eyes(
        &mut self,
        st: &mut LoopState,
        views: &[xr::View],
        (pose, tracked): (&Pose, Option<&Tracked>),
        (timed, capture): (bool, bool),
    ) -> Result<Option<(wgpu::Buffer, u32)>> {
        let matrices = self.eye_matrices(views, pose);
        let left_size = self.frame.labels()[0].pixels;
        let (ctx, layers) = (self.ctx, &mut self.layers);
        let mut readback = None;
        let mut onto_swapchains =
            |encoder: &mut wgpu::CommandEncoder, span: Option<PairSpan<'_>>| -> Result<()> {
                layers.acquire()?;
                let (colour, depth) = layers.acquired();
                layers.draw(encoder, (&colour, &depth), span);
                if capture {
                    let (texture, target) = layers.left();
                    readback = Some(copy_to_buffer(ctx, encoder, texture, left_size));
                    // the runtime expects its image back as a colour attachment: an empty pass
                    // that keeps the image leaves it in that layout
                    drop(present_pass(encoder, &target, wgpu::LoadOp::Load));
                }
                Ok(())
            };
        let last = Some(&mut onto_swapchains as crate::display::frame::LastPasses<'_>);
        let eyes = Poses::Eyes {
            matrices: &matrices,
            tracked,
        };
        let submission = self.frame.draw(eyes, Draw::Shown, last)?;
        if let (true, Some(s), Some(g)) = (timed, submission, st.gpu_done.as_ref()) {
            g.watch(st.shown.len() - 1, s);
        }
        self.layers.release()?;
        Ok(readback)
    }

    /// The left eye's image of this frame, read back once the GPU has drawn it (this frame
    /// only) and encoded on a thread.
    fn write_screenshot(
        &self,
        st: &mut LoopState,
        buffer: &wgpu::Buffer,
        padded_row: u32,
        path: &std::path::Path,
    ) -> Result<()> {
        let size = self.frame.labels()[0].pixels;
        let bytes: Vec<u8> = self
            .ctx
            .read_buffer(buffer, padded_row as u64 * size[1] as u64)?;
        let (format, path) = (self.setup.format, path.to_path_buf());
        st.screenshot_written = Some(path.display().to_string());
        st.screenshot_writer = Some(std::thread::spawn(move || {
            write_screenshot(&bytes, padded_row, size, format, &path)
        }));
        Ok(())
    }
}

/// The head in the stage: the point between the eyes, turned halfway between them.
fn head_of(views: &[xr::View]) -> glam::Affine3A {
    let eye = |v: &xr::View| {
        let XrPose {
            orientation,
            position,
        } = xr_pose(v);
        (Quat::from_array(orientation), Vec3::from(position))
    };
    body::head_between([eye(&views[0]), eye(&views[1])])
}

fn xr_pose(view: &xr::View) -> XrPose {
    let (o, p) = (view.pose.orientation, view.pose.position);
    XrPose {
        orientation: [o.x, o.y, o.z, o.w],
        position: [p.x, p.y, p.z],
    }
}

fn xr_fov(view: &xr::View) -> Fov {
    Fov {
        angle_left: view.fov.angle_left,
        angle_right: view.fov.angle_right,
        angle_up: view.fov.angle_up,
        angle_down: view.fov.angle_down,
    }
}

/// Set by Ctrl-C: the session is asked to end (the runtime then stops it), so the report is
/// still printed. Installed once per process.
fn interrupt_flag() -> Arc<std::sync::atomic::AtomicBool> {
    static FLAG: std::sync::OnceLock<Arc<std::sync::atomic::AtomicBool>> =
        std::sync::OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let setter = flag.clone();
        if let Err(e) =
            ctrlc::set_handler(move || setter.store(true, std::sync::atomic::Ordering::Relaxed))
        {
            log::warn!("Ctrl-C will not end the OpenXR session cleanly: {e}");
        }
        flag
    })
    .clone()
}
