//! `vlf cave` with windows: one window per wall (two for a wall whose eyes go to separate
//! outputs; one per projector, and per eye, for a wall driven by projectors), fullscreen on its
//! monitor when configured, all drawn from one device and one light field and presented
//! together every frame. Each wall and eye is rendered offscreen once a frame at the wall's
//! pixel size, its outputs drawn from it by the pass `--headless` uses (`post.rs`'s `Outputs`:
//! each projector's warp and blend, the wand's ray), and put on the windows by
//! `shaders/present.wgsl` (exposure, sRGB, and a status line when tracking goes quiet). Keyboard, mouse and gamepad (gilrs) navigation;
//! Esc quits cleanly and prints the frame-time report.

use super::framelock::{FrameLock, FrameState};
use super::live::{LiveState, TrackingStatus};
use super::post::{Draw, Outputs};
use super::tracking::{Pose, PoseSource};
use super::{DisplayConfig, MonitorRef, Stereo};
use crate::error::{Result, VlfError};
use crate::gpu::types::GpuPresent;
use crate::gpu::{GpuContext, MemoryLedger, Timestamps};
use crate::lightfield::{LightField, ResidentLightField};
use crate::render::Renderer;
use crate::stats::Distribution;
use glam::{Quat, Vec3};
use std::collections::HashSet;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Fullscreen, Window, WindowId};

pub struct WindowOptions {
    /// stop after this many frames (None: until Esc or the windows close)
    pub frames: Option<u32>,
    /// after `frames`, keep the windows up (drawing, not timed) this long: for screenshots
    pub hold: Duration,
    pub exposure: f32,
}

/// What a windowed run measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct WindowReport {
    pub display: String,
    pub adapter: String,
    pub windows: usize,
    pub frames: u32,
    pub views: Vec<super::headless::ViewTiming>,
    pub cpu_frame_ms: Option<Distribution>,
    /// messages shown on screen (tracking gone quiet), in order
    pub status_messages: Vec<String>,
    /// live tracking: milliseconds from a pose's arrival to the submission of the first frame
    /// drawn from it (None without live tracking)
    pub tracking_latency_ms: Option<Distribution>,
}

/// A wall seen by one eye: rendered once a frame into its slot of `App::outputs` (same
/// index), whose outputs (the wall's projectors, or the whole wall) the windows show.
struct View {
    wall: usize,
    eye: &'static str,
    side: f32,
}

/// One eye's part of a window and the bindings that put its image there.
struct WindowPart {
    /// which part of the window: 0 whole, 1 left/top half, 2 right/bottom half
    part: u8,
    params: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

struct WallWindow {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    stereo: Stereo,
    parts: Vec<WindowPart>,
}

/// Where a window goes: its title and size, its monitor's shift from the wall's monitor index
/// and its x offset from the wall's window position.
struct Placement {
    title: String,
    pixels: [u32; 2],
    shift: u32,
    x_offset: i32,
}

/// Navigation added to the tracked pose: the room moved and turned in the world.
#[derive(Default)]
pub(crate) struct Navigator {
    offset: Vec3,
    yaw_deg: f32,
    pub(crate) fly: bool,
    keys: HashSet<KeyCode>,
    dragging: bool,
    last_cursor_x: Option<f64>,
    mouse_turn_deg: f32,
    /// the tracked wand's buttons last frame (for the reset button's press)
    wand_buttons: u64,
}

impl Navigator {
    /// Move by keys held and by stick axes `pad` = [strafe right, back, turn right, sink].
    pub(crate) fn step(&mut self, dt: f32, nav: &super::Navigation, pad: [f32; 4], base_yaw: f32) {
        let key = |k: KeyCode| if self.keys.contains(&k) { 1.0f32 } else { 0.0 };
        let forward = key(KeyCode::KeyW) + key(KeyCode::ArrowUp)
            - key(KeyCode::KeyS)
            - key(KeyCode::ArrowDown)
            - pad[1];
        let strafe = key(KeyCode::KeyD) - key(KeyCode::KeyA) + pad[0];
        let turn = key(KeyCode::KeyQ) + key(KeyCode::ArrowLeft)
            - key(KeyCode::KeyE)
            - key(KeyCode::ArrowRight)
            - pad[2];
        let rise = key(KeyCode::KeyR) - key(KeyCode::KeyF) - pad[3];
        self.yaw_deg += turn * nav.turn_speed_deg * dt + std::mem::take(&mut self.mouse_turn_deg);
        let rotation = Quat::from_rotation_y((base_yaw + self.yaw_deg).to_radians());
        let ahead = rotation * Vec3::NEG_Z;
        let right = rotation * Vec3::X;
        let mut velocity = ahead * forward + right * strafe;
        if self.fly || nav.fly {
            velocity += Vec3::Y * rise;
        }
        if velocity.length() > 1.0 {
            velocity = velocity.normalize();
        }
        self.offset += velocity * nav.walk_speed * dt;
    }

    pub(crate) fn apply(&self, base: Pose) -> Pose {
        Pose {
            room_position: base.room_position + self.offset,
            room_yaw_deg: base.room_yaw_deg + self.yaw_deg,
            ..base
        }
    }

    pub(crate) fn reset(&mut self) {
        self.offset = Vec3::ZERO;
        self.yaw_deg = 0.0;
    }

    /// The tracked wand (`wand.rs`): its reset button resets; while the source is live its
    /// joystick flies along the wand and turns about the head (a quiet source's last joystick
    /// value is not acted on).
    pub(crate) fn wand(&mut self, state: &LiveState, live: bool, nav: &super::Navigation, dt: f32) {
        if super::wand::pressed(self.wand_buttons, state.buttons, nav.wand_reset_button) {
            self.reset();
        }
        self.wand_buttons = state.buttons;
        if let (Some(wand), true) = (&state.wand, live) {
            let pose = self.apply(state.pose);
            let (position, yaw) =
                super::wand::step(&pose, wand, state.joystick, nav, self.fly || nav.fly, dt);
            self.offset += position - pose.room_position;
            self.yaw_deg += yaw - pose.room_yaw_deg;
        }
    }
}

/// Open the windows and run the frame loop until Esc, closed windows or `options.frames`.
pub fn run(
    lf: &LightField,
    resident: &ResidentLightField,
    config: &DisplayConfig,
    config_path: &Path,
    options: WindowOptions,
) -> Result<WindowReport> {
    run_locked(lf, resident, config, config_path, options, None)
}

/// `run` as one rank of a cluster (`cluster.rs`): each frame's pose and exposure come from
/// `lock.share`, every rank waits at `lock.swap` before presenting; only rank 0 takes input
/// and decides when to stop (the others stop when its state says so).
pub fn run_locked<'a>(
    lf: &'a LightField,
    resident: &'a ResidentLightField,
    config: &'a DisplayConfig,
    config_path: &Path,
    options: WindowOptions,
    lock: Option<&'a mut dyn FrameLock>,
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
    let poses = PoseSource::from_config(config, config_path)?;
    let mut renderer = Renderer::new(resident, lf, &MemoryLedger::default())?;
    renderer.set_samples_per_pixel(config.antialiasing)?;
    // every wall and eye rendered once a frame; warp, blend and the wand ray as headless
    let views: Vec<View> = (config.walls.iter().enumerate())
        .flat_map(|(wall, w)| {
            (w.eyes().into_iter()).map(move |(eye, side)| View { wall, eye, side })
        })
        .collect();
    let specs = super::warp::load_outputs(config, config_path)?;
    let walls: Vec<usize> = views.iter().map(|v| v.wall).collect();
    let post = Outputs::needed(config, &specs, poses.may_have_wand(&config.tracking));
    let outputs = Outputs::new(&resident.ctx, &renderer, config, &specs, &walls, post)?;
    let mut app = App {
        lf,
        resident,
        config,
        poses,
        options,
        renderer,
        gpu: vec![Vec::new(); views.len()],
        views,
        outputs,
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
        frames: 0,
        cpu: Vec::new(),
        status_messages: Vec::new(),
        latency: Vec::new(),
        error: None,
        printed_done: false,
        lock,
        shown: 0,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| VlfError::Display(format!("the window loop failed: {e}")))?;
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    Ok(app.report())
}

pub(crate) struct PresentPipeline {
    pub(crate) pipeline: wgpu::RenderPipeline,
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) surface_is_srgb: bool,
}

struct App<'a> {
    lf: &'a LightField,
    resident: &'a ResidentLightField,
    config: &'a DisplayConfig,
    poses: PoseSource,
    options: WindowOptions,
    renderer: Renderer,
    /// every wall and eye, in `outputs`' slot order
    views: Vec<View>,
    /// the wall images and the outputs drawn from them (`post.rs`, shared with headless)
    outputs: Outputs,
    windows: Vec<WallWindow>,
    present: Option<PresentPipeline>,
    overlay: Option<(wgpu::Texture, wgpu::TextureView)>,
    status: Option<String>,
    navigator: Navigator,
    gamepads: Option<gilrs::Gilrs>,
    started: Instant,
    last_frame: Instant,
    frames: u32,
    /// GPU milliseconds per view (in `views` order) per timed frame
    gpu: Vec<Vec<f64>>,
    cpu: Vec<f64>,
    status_messages: Vec<String>,
    /// milliseconds from a live pose's arrival to the frame drawn from it
    latency: Vec<f64>,
    error: Option<VlfError>,
    printed_done: bool,
    /// a cluster's frame lock (`cluster.rs`); None alone
    lock: Option<&'a mut dyn FrameLock>,
    /// frames drawn (the frame number shared with a cluster)
    shown: u64,
}

impl App<'_> {
    fn ctx(&self) -> &Arc<GpuContext> {
        &self.resident.ctx
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: VlfError) {
        self.error = Some(e);
        event_loop.exit();
    }

    fn open_windows(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let monitors: Vec<winit::monitor::MonitorHandle> =
            event_loop.available_monitors().collect();
        let names: Vec<String> = monitors
            .iter()
            .enumerate()
            .map(|(i, m)| m.name().unwrap_or_else(|| format!("monitor {i}")))
            .collect();
        self.config
            .check_outputs(&names)
            .map_err(VlfError::Display)?;
        for (wall_index, wall) in self.config.walls.iter().enumerate() {
            // a wall whose eyes go to separate outputs gets a window per eye; one driven by
            // projectors a window per projector (per eye): each shows what headless writes as
            // <wall>-<eye>-<projector>.png, on the next monitor or beside the previous window
            let mut groups: Vec<(&'static str, Vec<(&'static str, u8)>)> = match wall.stereo {
                Stereo::Mono => vec![("", vec![("mono", 0)])],
                Stereo::Separate => {
                    vec![("left", vec![("left", 0)]), ("right", vec![("right", 0)])]
                }
                Stereo::SideBySide | Stereo::TopBottom => {
                    vec![("", vec![("left", 1), ("right", 2)])]
                }
            };
            // a cluster rank drawing one eye of the wall (`Wall::only_eye`) opens its window only
            let drawn = wall.eyes();
            groups.retain(|(_, eyes)| eyes.iter().all(|e| drawn.iter().any(|d| d.0 == e.0)));
            let outputs: Vec<(Option<usize>, [u32; 2])> = if wall.projectors.is_empty() {
                vec![(None, wall.pixels)]
            } else {
                (wall.projectors.iter().enumerate())
                    .map(|(k, p)| (Some(k), p.pixels))
                    .collect()
            };
            let mut shift = 0;
            let mut x_offset = 0;
            for (suffix, eyes) in groups {
                for &(projector, pixels) in &outputs {
                    let qualifiers: Vec<String> = [
                        (!suffix.is_empty()).then(|| format!("{suffix} eye")),
                        projector.map(|k| format!("projector {}", wall.projectors[k].name)),
                    ]
                    .into_iter()
                    .flatten()
                    .collect();
                    let title = match qualifiers.is_empty() {
                        true => format!("vlf: {}", wall.name),
                        false => format!("vlf: {} ({})", wall.name, qualifiers.join(", ")),
                    };
                    let place = Placement {
                        title,
                        pixels,
                        shift,
                        x_offset,
                    };
                    let (window, surface, surface_config) =
                        self.create_window(event_loop, &monitors, &names, wall_index, place)?;
                    let parts = eyes
                        .iter()
                        .map(|&(eye, part)| {
                            let slot = self.slot_of(wall_index, eye);
                            self.window_part(slot, projector, part)
                        })
                        .collect::<Result<Vec<_>>>()?;
                    self.windows.push(WallWindow {
                        window,
                        surface,
                        config: surface_config,
                        stereo: wall.stereo,
                        parts,
                    });
                    shift += 1;
                    x_offset += pixels[0] as i32;
                }
            }
        }
        Ok(())
    }

    /// The slot (view) of `wall` seen by `eye`.
    fn slot_of(&self, wall: usize, eye: &str) -> usize {
        self.views
            .iter()
            .position(|v| v.wall == wall && v.eye == eye)
            .expect("a view per wall and eye")
    }

    /// One window of a wall, placed on its monitor (index + `shift` when there is one) or at
    /// its window position (+ `x_offset`), with its surface configured.
    fn create_window(
        &mut self,
        event_loop: &ActiveEventLoop,
        monitors: &[winit::monitor::MonitorHandle],
        names: &[String],
        wall_index: usize,
        place: Placement,
    ) -> Result<(
        Arc<Window>,
        wgpu::Surface<'static>,
        wgpu::SurfaceConfiguration,
    )> {
        let ctx = self.ctx().clone();
        let wall = &self.config.walls[wall_index];
        let monitor = match &wall.output.monitor {
            Some(MonitorRef::Index(n)) => monitors
                .get((*n + place.shift) as usize)
                .or(monitors.get(*n as usize))
                .cloned(),
            Some(MonitorRef::Name(name)) => monitors
                .iter()
                .zip(names)
                .find(|(_, n)| *n == name)
                .map(|(m, _)| m.clone()),
            None => None,
        };
        let mut attributes = Window::default_attributes()
            .with_title(place.title)
            .with_inner_size(winit::dpi::PhysicalSize::new(
                place.pixels[0],
                place.pixels[1],
            ));
        let origin = monitor
            .as_ref()
            .map(|m| m.position())
            .unwrap_or(winit::dpi::PhysicalPosition::new(0, 0));
        if let Some([x, y]) = wall.output.window {
            attributes = attributes.with_position(winit::dpi::PhysicalPosition::new(
                origin.x + x + place.x_offset,
                origin.y + y,
            ));
        } else {
            attributes = attributes.with_position(origin);
        }
        if wall.output.fullscreen {
            attributes = attributes.with_fullscreen(Some(Fullscreen::Borderless(monitor.clone())));
        }
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| {
            VlfError::Display(format!("wall {:?}: cannot open a window: {e}", wall.name))
        })?);
        let surface = ctx.instance.create_surface(window.clone()).map_err(|e| {
            VlfError::Display(format!(
                "wall {:?}: no GPU surface for its window: {e}",
                wall.name
            ))
        })?;
        if !ctx.adapter.is_surface_supported(&surface) {
            return Err(VlfError::Display(format!(
                "the adapter {} cannot present to wall {:?}'s window",
                ctx.summary.name, wall.name
            )));
        }
        let caps = surface.get_capabilities(&ctx.adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or(caps.formats.first().copied())
            .ok_or_else(|| {
                VlfError::Display(format!(
                    "wall {:?}: the window's surface offers no format",
                    wall.name
                ))
            })?;
        let size = window.inner_size();
        let surface_config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&ctx.device, &surface_config);
        if self.present.is_none() {
            self.present = Some(present_pipeline(&ctx, format)?);
        }
        Ok((window, surface, surface_config))
    }

    fn overlay_view(&mut self) -> &wgpu::TextureView {
        if self.overlay.is_none() {
            let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
            let texture = crate::render::texture_2d(
                &self.ctx().device,
                "status overlay",
                OVERLAY_SIZE,
                wgpu::TextureFormat::Rgba8Unorm,
                usage,
            );
            let view = texture.create_view(&Default::default());
            self.overlay = Some((texture, view));
        }
        &self.overlay.as_ref().unwrap().1
    }

    /// One eye's part of a window: it shows `projector`'s output of `slot` (None: the wall).
    fn window_part(
        &mut self,
        slot: usize,
        projector: Option<usize>,
        part: u8,
    ) -> Result<WindowPart> {
        let ctx = self.ctx().clone();
        let params = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("present parameters"),
            size: std::mem::size_of::<GpuPresent>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let overlay = self.overlay_view().clone();
        let layout = &self
            .present
            .as_ref()
            .expect("present pipeline made with the first window")
            .layout;
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("present"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(
                        self.outputs.shown(slot, projector),
                    ),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&overlay),
                },
            ],
        });
        Ok(WindowPart {
            part,
            params,
            bind_group,
        })
    }

    fn poll_gamepads(&mut self) -> [f32; 4] {
        let Some(g) = self.gamepads.as_mut() else {
            return [0.0; 4];
        };
        let mut reset = false;
        while let Some(event) = g.next_event() {
            if let gilrs::EventType::ButtonPressed(gilrs::Button::Start, _) = event.event {
                reset = true;
            }
            if let gilrs::EventType::ButtonPressed(gilrs::Button::North, _) = event.event {
                self.navigator.fly = !self.navigator.fly;
            }
        }
        if reset {
            self.navigator.reset();
        }
        let dead = |v: f32| if v.abs() < 0.15 { 0.0 } else { v };
        let mut axes = [0.0f32; 4];
        for (_, pad) in g.gamepads() {
            axes[0] += dead(pad.value(gilrs::Axis::LeftStickX));
            axes[1] -= dead(pad.value(gilrs::Axis::LeftStickY));
            axes[2] += dead(pad.value(gilrs::Axis::RightStickX));
            axes[3] -= dead(pad.value(gilrs::Axis::RightStickY));
        }
        axes
    }

    fn set_status(&mut self, text: Option<String>) {
        if text == self.status {
            return;
        }
        // log a new condition once; the seconds counting up only redraw the line
        let kind = |t: &Option<String>| {
            t.as_ref().map(|t| {
                t.split(|c: char| c.is_ascii_digit())
                    .next()
                    .unwrap_or_default()
                    .to_string()
            })
        };
        if let (Some(t), true) = (&text, kind(&text) != kind(&self.status)) {
            log::warn!("{t}");
            self.status_messages.push(t.clone());
        }
        for w in &self.windows {
            let base = w.window.title();
            let base = base.split(" | ").next().unwrap_or_default().to_string();
            w.window.set_title(&match &text {
                Some(t) => format!("{base} | {t}"),
                None => base,
            });
        }
        if let Some(t) = &text {
            let pixels = rasterise_status(t);
            let (texture, _) = self
                .overlay
                .as_ref()
                .expect("overlay made with the first window");
            self.ctx().queue.write_texture(
                texture.as_image_copy(),
                &pixels,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(OVERLAY_SIZE[0] * 4),
                    rows_per_image: Some(OVERLAY_SIZE[1]),
                },
                wgpu::Extent3d {
                    width: OVERLAY_SIZE[0],
                    height: OVERLAY_SIZE[1],
                    depth_or_array_layers: 1,
                },
            );
        }
        self.status = text;
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32().min(0.1);
        self.last_frame = now;
        let pad = self.poll_gamepads();
        let (base, tracking, fresh, wand) = match &self.poses {
            PoseSource::Scripted(s) => {
                let t = self.started.elapsed().as_secs_f32() % s.duration().max(1e-3);
                (s.at(t), None, None, s.wand_at(t))
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
                (state.pose, Some(status), tracker.take_fresh(), state.wand)
            }
            other => (
                other.at(0.0),
                None,
                None,
                other.wand_at(&self.config.tracking, 0.0),
            ),
        };
        self.navigator
            .step(dt, &self.config.navigation, pad, base.room_yaw_deg);
        let mut pose = self.navigator.apply(base);
        let mut wand = wand;
        if let Some(lock) = self.lock.as_deref_mut() {
            let s = FrameState::new(self.shown, &pose, wand.as_ref(), self.options.exposure);
            let s = lock.share(s)?;
            if s.is_quit() {
                event_loop.exit();
                return Ok(());
            }
            (pose, wand, self.options.exposure) = (s.pose(), s.wand(), s.exposure);
        }
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

        let timed = self.options.frames.is_none_or(|n| self.frames < n);
        let ctx = self.ctx().clone();
        let mut timestamps = if timed {
            Timestamps::new(&ctx, self.views.len() as u32)
        } else {
            None
        };
        let started = Instant::now();
        // every view rendered, and its outputs drawn, once; then each window shows its parts
        for (slot, v) in self.views.iter().enumerate() {
            let wall = &self.config.walls[v.wall];
            let norm = &self.lf.meta.normalisation;
            let view = super::wall_view(self.config, wall, v.side, &pose, norm);
            let overlay =
                super::post::wand_overlay(self.config, wall, v.side, &pose, wand.as_ref(), norm);
            self.outputs.encode(
                &mut self.renderer,
                slot,
                view,
                overlay.as_ref(),
                timestamps.as_mut(),
                Draw::Shown,
            );
        }
        let outputs = self.draw_windows(&ctx)?;
        if let (Some(arrived), true) = (fresh, timed) {
            self.latency.push(arrived.elapsed().as_secs_f64() * 1e3);
        }
        // every window's frame is ready before any is shown: the walls change together (and
        // in a cluster, every rank's: drawn, then the swap barrier)
        if let Some(lock) = self.lock.as_deref_mut() {
            ctx.wait()?;
            lock.swap()?;
        }
        for texture in outputs {
            ctx.queue.present(texture);
        }
        ctx.wait()?;
        if timed {
            self.cpu.push(started.elapsed().as_secs_f64() * 1e3);
            if let Some(t) = timestamps.as_mut() {
                for (v, ms) in t.read_ms(&ctx)?.into_iter().enumerate() {
                    if let Some(series) = self.gpu.get_mut(v) {
                        series.push(ms);
                    }
                }
            }
            self.frames += 1;
        }
        let follower = self.lock.as_ref().is_some_and(|l| !l.is_leader());
        if let (Some(n), false) = (self.options.frames, follower) {
            if self.frames >= n {
                if !self.printed_done {
                    println!("presented {n} frames on {} window(s)", self.windows.len());
                    use std::io::Write;
                    let _ = std::io::stdout().flush();
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

    /// Each window's parts drawn from the views' images onto its next surface texture, and
    /// submitted; the textures to present (a window without one this frame is left out).
    fn draw_windows(&mut self, ctx: &GpuContext) -> Result<Vec<wgpu::SurfaceTexture>> {
        let present = self.present.as_ref().expect("windows open");
        let mut outputs = Vec::new();
        for w in &mut self.windows {
            let Some(texture) = next_texture(ctx, w)? else {
                continue;
            };
            let (width, height) = (w.config.width as f32, w.config.height as f32);
            for p in &w.parts {
                let (origin, size) = viewport(w.stereo, p.part, width, height);
                let params = GpuPresent {
                    viewport_origin: origin,
                    viewport_size: size,
                    exposure: self.options.exposure,
                    encode_srgb: (!present.surface_is_srgb) as u32,
                    show_overlay: (self.status.is_some() && p.part < 2) as u32,
                    _pad0: 0,
                };
                ctx.queue
                    .write_buffer(&p.params, 0, bytemuck::bytes_of(&params));
            }
            let view = texture.texture.create_view(&Default::default());
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let mut pass =
                    present_pass(&mut encoder, &view, wgpu::LoadOp::Clear(wgpu::Color::BLACK));
                pass.set_pipeline(&present.pipeline);
                for p in &w.parts {
                    let (origin, size) = viewport(w.stereo, p.part, width, height);
                    pass.set_viewport(origin[0], origin[1], size[0], size[1], 0.0, 1.0);
                    pass.set_bind_group(0, &p.bind_group, &[]);
                    pass.draw(0..3, 0..1);
                }
            }
            ctx.queue.submit([encoder.finish()]);
            outputs.push(texture);
        }
        Ok(outputs)
    }

    fn report(&self) -> WindowReport {
        let views = (self.views.iter().enumerate())
            .map(|(v, view)| {
                let wall = &self.config.walls[view.wall];
                let label = super::frame::ViewLabel {
                    wall: wall.name.clone(),
                    eye: view.eye,
                    pixels: wall.eye_pixels(),
                };
                super::frame::ViewTiming::of(&label, self.gpu.get(v).map_or(&[][..], |s| s))
            })
            .collect();
        WindowReport {
            display: self.config.name.clone(),
            adapter: self.resident.ctx.summary.name.clone(),
            windows: self.windows.len(),
            frames: self.frames,
            views,
            cpu_frame_ms: (!self.cpu.is_empty()).then(|| Distribution::of(&self.cpu)),
            status_messages: self.status_messages.clone(),
            tracking_latency_ms: (!self.latency.is_empty())
                .then(|| Distribution::of(&self.latency)),
        }
    }
}

/// The window's next surface texture; None when there is none this frame (the surface is
/// reconfigured when it went out of date).
fn next_texture(ctx: &GpuContext, w: &mut WallWindow) -> Result<Option<wgpu::SurfaceTexture>> {
    match w.surface.get_current_texture() {
        wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
            Ok(Some(t))
        }
        wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
            let size = w.window.inner_size();
            w.config.width = size.width.max(1);
            w.config.height = size.height.max(1);
            w.surface.configure(&ctx.device, &w.config);
            Ok(None)
        }
        wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => Ok(None),
        wgpu::CurrentSurfaceTexture::Validation => Err(VlfError::Display(
            "the window's surface failed validation".into(),
        )),
    }
}

/// The eye's part of a window: (origin, size) in pixels.
fn viewport(stereo: Stereo, part: u8, width: f32, height: f32) -> ([f32; 2], [f32; 2]) {
    match (stereo, part) {
        (Stereo::SideBySide, 1) => ([0.0, 0.0], [width / 2.0, height]),
        (Stereo::SideBySide, _) => ([width / 2.0, 0.0], [width / 2.0, height]),
        (Stereo::TopBottom, 1) => ([0.0, 0.0], [width, height / 2.0]),
        (Stereo::TopBottom, _) => ([0.0, height / 2.0], [width, height / 2.0]),
        _ => ([0.0, 0.0], [width, height]),
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

/// A render pass onto one colour target (a window's surface, a headset's swapchain image),
/// stored at the end.
pub(crate) fn present_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("present"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load,
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

pub(crate) fn present_pipeline(
    ctx: &GpuContext,
    format: wgpu::TextureFormat,
) -> Result<PresentPipeline> {
    let device = &ctx.device;
    let module = crate::gpu::shaders::module(device, "present.wgsl")?;
    // params, the eye's image, the status overlay: as present.wgsl declares them
    let layout = crate::gpu::reflect::layout(device, "present.wgsl", 0)?;
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("present"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("present"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_present"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    });
    Ok(PresentPipeline {
        pipeline,
        layout,
        surface_is_srgb: format.is_srgb(),
    })
}

const OVERLAY_SIZE: [u32; 2] = [720, 30];

/// The status line as RGBA8 (white text on a translucent black band), with DejaVu Sans.
fn rasterise_status(text: &str) -> Vec<u8> {
    use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
    let [w, h] = OVERLAY_SIZE;
    let mut pixels = vec![0u8; (w * h * 4) as usize];
    let Ok(font) = FontRef::try_from_slice(dejavu::sans::regular()) else {
        return pixels;
    };
    let scale = PxScale::from(16.0);
    let scaled = font.as_scaled(scale);
    let mut x = 8.0f32;
    let baseline = 6.0 + scaled.ascent();
    let mut coverage = vec![0f32; (w * h) as usize];
    for c in text.chars() {
        let glyph = scaled.scaled_glyph(c);
        let advance = scaled.h_advance(glyph.id);
        let glyph = glyph
            .id
            .with_scale_and_position(scale, ab_glyph::point(x, baseline));
        if let Some(outline) = font.outline_glyph(glyph) {
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, c| {
                let (px, py) = (
                    bounds.min.x as i32 + gx as i32,
                    bounds.min.y as i32 + gy as i32,
                );
                if px >= 0 && py >= 0 && (px as u32) < w && (py as u32) < h {
                    let i = (py as u32 * w + px as u32) as usize;
                    coverage[i] = coverage[i].max(c);
                }
            });
        }
        x += advance;
    }
    let band = (x + 8.0).min(w as f32) as u32;
    for py in 0..h {
        for px in 0..band {
            let i = (py * w + px) as usize;
            let c = coverage[i];
            let v = (255.0 * c) as u8;
            pixels[i * 4..i * 4 + 4].copy_from_slice(&[
                v,
                v,
                (255.0 * c * 0.6) as u8,
                (150.0 + 105.0 * c) as u8,
            ]);
        }
    }
    pixels
}

impl WindowReport {
    pub fn table(&self) -> String {
        let mut s = format!(
            "  display {} on {}: {} window(s), {} frames timed\n",
            self.display, self.adapter, self.windows, self.frames
        );
        for v in &self.views {
            if let Some(d) = &v.gpu_ms {
                s.push_str(&format!(
                    "  {:<10} {:<6} {}x{}  GPU p50 {:.3} ms  p99 {:.3}  max {:.3}\n",
                    v.wall, v.eye, v.pixels[0], v.pixels[1], d.median, d.p99, d.max
                ));
            }
        }
        if let Some(d) = &self.cpu_frame_ms {
            s.push_str(&format!(
                "  CPU frame time (all windows presented): median {:.3} ms, p99 {:.3} ms\n",
                d.median, d.p99
            ));
        }
        if let Some(d) = &self.tracking_latency_ms {
            s.push_str(&format!("  tracking latency (pose received -> frame submitted): p50 {:.3} ms, p99 {:.3} ms ({} poses)\n", d.median, d.p99, d.samples));
        }
        for m in &self.status_messages {
            s.push_str(&format!("  shown on screen: {m}\n"));
        }
        s
    }
}
