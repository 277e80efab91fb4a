//! `vlf cave` with windows: one window per wall (two for a wall whose eyes go to separate
//! outputs; one per projector, and per eye, for a wall driven by projectors), fullscreen on its
//! monitor when configured, all drawn from one device and one light field and presented
//! together every frame. Each wall and eye is rendered offscreen once a frame at the wall's
//! pixel size, its outputs drawn from it by the pass `--headless` uses (`post.rs`'s `Outputs`:
//! each projector's warp and blend, the wand's ray), and put on the windows by
//! `shaders/present.wgsl` (exposure, sRGB, and a status line when tracking goes quiet). Keyboard, mouse and gamepad (gilrs) navigation;
//! Esc quits cleanly and prints the frame-time report. The app drives the frame of views
//! (`frame/`: the views drawn, paced and accounted); it keeps the events, the poses and
//! navigation, the windows and presenting, and a cluster's frame lock.

mod input;
mod report;
mod status;
mod surfaces;

pub use report::WindowReport;

use super::frame::{FrameOfViews, Poses, Slots};
use super::post::Draw;
use super::present::PresentPipeline;
use super::DisplayConfig;
use crate::error::{Result, VlfError};
use crate::framelock::{FrameLock, FrameState};
use crate::gpu::GpuContext;
use crate::lightfield::{LightField, ResidentLightField};
use crate::tracking::live::TrackingStatus;
use crate::tracking::navigator::Navigator;
use crate::tracking::pose::{HeldPoses, Pose, RawPoses};
use crate::tracking::source::PoseSource;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};
use surfaces::WallWindow;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::WindowId;

pub struct WindowOptions<'c> {
    /// stop after this many frames (None: until Esc or the windows close)
    pub frames: Option<u32>,
    /// after `frames`, keep the windows up (drawing, not timed) this long: for screenshots
    pub hold: Duration,
    pub exposure: f32,
    /// the display's conditions with their light fields made (`super::conditions`), switched
    /// by the script's `condition` command
    pub conditions: Option<&'c super::conditions::Conditions>,
}

/// Open the windows and run the frame loop until Esc, closed windows or `options.frames`.
pub fn run(
    lf: &LightField,
    resident: &ResidentLightField,
    config: &DisplayConfig,
    config_path: &Path,
    options: WindowOptions<'_>,
) -> Result<WindowReport> {
    let session = crate::study::Session::new(None, None);
    run_locked(lf, resident, config, config_path, options, None, session)
}

/// `run` as one rank of a cluster (`crate::cluster`): each frame's pose and exposure come from
/// `lock.share`, every rank waits at `lock.swap` before presenting; only rank 0 takes input
/// and decides when to stop (the others stop when its state says so). `session`: the session
/// log and the experiment script's commands (`crate::study`), frame by frame.
pub fn run_locked<'a>(
    lf: &'a LightField,
    resident: &'a ResidentLightField,
    config: &'a DisplayConfig,
    config_path: &Path,
    options: WindowOptions<'a>,
    lock: Option<&'a mut dyn FrameLock>,
    session: crate::study::Session<'a>,
) -> Result<WindowReport> {
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        return Err(VlfError::Display(
            "no display to open windows on (neither DISPLAY nor WAYLAND_DISPLAY is set); run with --headless to render every wall and eye to files, or start a virtual display (Xvfb :99 & export DISPLAY=:99)".into(),
        ));
    }
    let event_loop = EventLoop::new().map_err(|e| {
        VlfError::Display(format!(
            "cannot open the windowing system: {e}; run with --headless instead"
        ))
    })?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let poses = config.pose_source(config_path)?;
    // every wall and eye rendered once a frame into its own image; warp, blend and the wand
    // ray as headless
    let conditions = options.conditions;
    let session = session.with_conditions(super::headless::studied(config, conditions));
    let frame = FrameOfViews::cave(
        (lf, resident),
        config,
        config_path,
        &poses,
        Slots::PerView,
        conditions,
    )?;
    let mut app = App {
        resident,
        config,
        poses,
        options,
        frame,
        windows: Vec::new(),
        present: None,
        overlay: None,
        status: None,
        navigator: Navigator::default(),
        gamepads: gilrs::Gilrs::new()
            .map_err(|e| log::warn!("gamepads unavailable: {e}"))
            .ok(),
        started: Instant::now(),
        last_frame: Instant::now(),
        status_messages: Vec::new(),
        status_to_announce: None,
        error: None,
        printed_done: false,
        lock,
        shown: 0,
        session,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| VlfError::Display(format!("the window loop failed: {e}")))?;
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    Ok(app.report())
}

struct App<'a> {
    resident: &'a ResidentLightField,
    config: &'a DisplayConfig,
    poses: PoseSource,
    options: WindowOptions<'a>,
    /// the renderer, every wall and eye (in the wall images' slot order) and the outputs drawn
    /// from them (`post.rs`, shared with headless), the pacing, and every timed frame's times
    frame: FrameOfViews<'a>,
    windows: Vec<WallWindow>,
    present: Option<PresentPipeline>,
    overlay: Option<(wgpu::Texture, wgpu::TextureView)>,
    status: Option<String>,
    navigator: Navigator,
    gamepads: Option<gilrs::Gilrs>,
    started: Instant,
    last_frame: Instant,
    /// status lines shown on screen (tracking gone quiet), in order
    status_messages: Vec<String>,
    /// a new condition's status line, set for the next frame and announced once presented
    status_to_announce: Option<String>,
    error: Option<VlfError>,
    printed_done: bool,
    /// a cluster's frame lock (`crate::cluster`); None alone
    lock: Option<&'a mut dyn FrameLock>,
    /// frames drawn (the frame number shared with a cluster)
    shown: u64,
    /// the session log and the experiment script's commands
    session: crate::study::Session<'a>,
}

impl App<'_> {
    fn ctx(&self) -> &Arc<GpuContext> {
        &self.resident.ctx
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: VlfError) {
        self.error = Some(e);
        event_loop.exit();
    }

    /// Frames timed so far.
    /// The frame just shown into the session log (`shown - 1`), with its times when timed.
    /// `pose_to_submit_ms`: from the pose's arrival or sampling to the frame's submission.
    fn log_frame(
        &mut self,
        (timed, pose_to_submit_ms, object_time_s): (bool, f64, f64),
        (pose, held, raw): (Pose, HeldPoses, RawPoses),
    ) -> Result<()> {
        let (gpu_ms, cpu_ms) = match timed {
            true => self.frame.times().last_frame_ms(),
            false => (None, None),
        };
        let record = crate::study::FrameRecord {
            frame: self.shown - 1,
            time_s: self.session.time_s(),
            drawn: crate::study::log::Drawn::Shown,
            pose,
            wand: held.wand,
            left_hand: held.left_hand,
            targets: held.targets,
            gpu_ms,
            cpu_ms,
            block: 0,
            trial: 0,
            pose_to_submit_ms: Some(pose_to_submit_ms),
            pose_to_photon_ms: None,
            object_time_s: Some(object_time_s),
            raw,
            views: self.frame.drawn().to_vec(),
            events: String::new(),
            condition: String::new(),
            objects: Some(self.frame.object_switches()),
            flash: None,
            eyes: Vec::new(),
        };
        self.session.end_frame(record, None)
    }

    fn frames(&self) -> u32 {
        self.frame.frames_timed()
    }

    /// This frame's poses from the source: the head, how a live source is doing, when its
    /// state arrived (once), the wand and left hand, and the raw poses it sent.
    #[allow(clippy::type_complexity)]
    fn sample(
        &mut self,
        dt: f32,
    ) -> (
        Pose,
        Option<TrackingStatus>,
        Option<Instant>,
        (HeldPoses, RawPoses),
    ) {
        match &self.poses {
            PoseSource::Scripted(s) => {
                let t = self.started.elapsed().as_secs_f32() % s.duration().max(1e-3);
                (s.at(t), None, None, (s.held(t), RawPoses::default()))
            }
            PoseSource::Live(tracker) => {
                let mut tracker = tracker.lock().unwrap_or_else(|e| e.into_inner());
                let (state, status) = tracker.latest_state();
                self.navigator.wand(
                    &state,
                    status == TrackingStatus::Live,
                    &self.config.navigation,
                    dt,
                );
                (
                    state.pose,
                    Some(status),
                    tracker.take_fresh(),
                    (state.held(), state.raw),
                )
            }
            other => (
                other.at(0.0),
                None,
                None,
                (
                    other.held_at(&self.config.tracking, 0.0),
                    RawPoses::default(),
                ),
            ),
        }
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32().min(0.1);
        self.last_frame = now;
        let pad = self.poll_gamepads();
        let sampled = Instant::now();
        let (base, tracking, fresh, (held, raw)) = self.sample(dt);
        self.navigator
            .step(dt, &self.config.navigation, pad, base.room_yaw_deg);
        self.session.begin_frame();
        self.frame.take_study_changes(&mut self.session)?;
        let mut pose = (self.session).pose(self.navigator.apply(base), fresh.unwrap_or(sampled));
        let mut held = held;
        let mut object_time_s = self.started.elapsed().as_secs_f64();
        let mut study = (self.frame).study_state(self.session.flash(), self.session.stop);
        if let Some(lock) = self.lock.as_deref_mut() {
            let s = FrameState::new(self.shown, &pose, held, self.options.exposure)
                .with_study(object_time_s, study);
            let s = lock.share(s)?;
            if s.is_quit() {
                event_loop.exit();
                return Ok(());
            }
            (pose, held, self.options.exposure) = (s.pose(), s.held(), s.exposure);
            (object_time_s, study) = (s.object_time_s, s.study());
            if !lock.is_leader() {
                self.frame.follow_study(&study)?;
            }
        }
        self.session.follow(&study, self.frame.condition());
        self.shown += 1;
        let status = match (tracking, &self.config.tracking) {
            (Some(TrackingStatus::Quiet(d)), _) => Some(format!(
                "tracking quiet {:.0} s: holding the last pose",
                d.as_secs_f32().floor()
            )),
            (Some(TrackingStatus::Waiting), tracking) => tracking
                .live()
                .map(|s| format!("tracking: waiting for {} on {}", s.protocol, s.address)),
            _ => None,
        };
        self.set_status(status);

        let timed = self.options.frames.is_none_or(|n| self.frames() < n);
        let ctx = self.ctx().clone();
        // every view rendered, and its outputs drawn, once; then each window shows its parts
        self.frame.begin(timed)?;
        self.frame.set_object_time(object_time_s);
        let tracked = Poses::Tracked {
            pose: &pose,
            held: &held,
            arrived: fresh,
        };
        self.frame.draw(tracked, Draw::Shown, None)?;
        let pose_to_submit_ms = fresh.unwrap_or(sampled).elapsed().as_secs_f64() * 1e3;
        let outputs = self.draw_windows(&ctx, study.flash)?;
        // every window's frame is ready before any is shown: the walls change together (and
        // in a cluster, every rank's: drawn, then the swap barrier)
        if let Some(lock) = self.lock.as_deref_mut() {
            ctx.wait()?;
            lock.swap()?;
        }
        let outputs_shown = outputs.len();
        for texture in outputs {
            ctx.queue.present(texture);
        }
        ctx.wait_spinning()?;
        self.announce_presented(outputs_shown);
        self.frame.account(self.frame.elapsed_ms())?;
        self.log_frame((timed, pose_to_submit_ms, object_time_s), (pose, held, raw))?;
        // a cluster's other ranks end with rank 0's quit state (a stop is rank 0's to take)
        let follower = self.lock.as_ref().is_some_and(|l| !l.is_leader());
        if self.session.stop && !follower {
            event_loop.exit();
        }
        if let (Some(n), false) = (self.options.frames, follower) {
            if self.frames() >= n {
                if !self.printed_done {
                    status::say(&format!(
                        "presented {n} frames on {} window(s)",
                        self.windows.len()
                    ));
                    self.printed_done = true;
                    self.started = Instant::now();
                }
                if self.started.elapsed() >= self.options.hold {
                    event_loop.exit();
                }
            }
        }
        Ok(())
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.windows.is_empty() && self.error.is_none() {
            if let Err(e) = self.open_windows(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(
        &mut self,
        event_loop: &ActiveEventLoop,
        window_id: WindowId,
        event: WindowEvent,
    ) {
        let follower = self.lock.as_ref().is_some_and(|l| !l.is_leader());
        match event {
            // a cluster rank other than 0 losing its window loses its part of the CAVE
            WindowEvent::CloseRequested if follower => self.fail(
                event_loop,
                VlfError::Display("a window of this rank was closed".into()),
            ),
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                let ctx = self.ctx().clone();
                if let Some(w) = self.windows.iter_mut().find(|w| w.window.id() == window_id) {
                    w.config.width = size.width.max(1);
                    w.config.height = size.height.max(1);
                    w.surface.configure(&ctx.device, &w.config);
                }
            }
            // input belongs to rank 0 in a cluster
            WindowEvent::KeyboardInput { .. } | WindowEvent::MouseInput { .. } if follower => {}
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else {
                    return;
                };
                match (code, event.state) {
                    (KeyCode::Escape, ElementState::Pressed) => event_loop.exit(),
                    (KeyCode::Home | KeyCode::Backspace, ElementState::Pressed) => {
                        self.navigator.reset()
                    }
                    (KeyCode::KeyG, ElementState::Pressed) => {
                        self.navigator.fly = !self.navigator.fly
                    }
                    (code, ElementState::Pressed) => {
                        self.navigator.keys.insert(code);
                    }
                    (code, ElementState::Released) => {
                        self.navigator.keys.remove(&code);
                    }
                }
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => {
                self.navigator.dragging = state == ElementState::Pressed;
                self.navigator.last_cursor_x = None;
            }
            WindowEvent::CursorMoved { position, .. } if self.navigator.dragging => {
                if let Some(last) = self.navigator.last_cursor_x {
                    // a full window width of drag turns the room by 90 degrees
                    let width = self
                        .windows
                        .iter()
                        .find(|w| w.window.id() == window_id)
                        .map_or(1000.0, |w| w.config.width as f64);
                    self.navigator.mouse_turn_deg -= ((position.x - last) / width * 90.0) as f32;
                }
                self.navigator.last_cursor_x = Some(position.x);
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.windows.is_empty() || self.error.is_some() {
            return;
        }
        if let Err(e) = self.frame(event_loop) {
            self.fail(event_loop, e);
        }
    }
}
