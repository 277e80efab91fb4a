//! The OpenXR session: a swapchain per eye on the runtime's Vulkan device, the frame loop paced
//! by the runtime (xrWaitFrame / xrBeginFrame / xrEndFrame at the predicted display time), the
//! session states, thumbstick navigation through an action set, the left eye's screenshot and
//! the per-eye frame-time report. Each eye is rendered by the CAVE's renderer (one compute pass,
//! constant work per pixel) into an offscreen image and put on the swapchain image by
//! `shaders/present.wgsl`.

use super::{eye_view, Fov, XrPose, XrRuntime};
use crate::display::headless::ViewTiming;
use crate::display::tracking::Pose;
use crate::display::window::{present_pass, present_pipeline, Navigator};
use crate::error::{Result, VlfError};
use crate::gpu::types::GpuPresent;
use crate::gpu::{GpuContext, MemoryLedger, Timestamps};
use crate::render::{Renderer, ViewTargets};
use crate::stats::Distribution;
use glam::{Quat, Vec3};
use openxr as xr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

const VIEW_TYPE: xr::ViewConfigurationType = xr::ViewConfigurationType::PRIMARY_STEREO;
/// metres: the near plane of both eyes
const NEAR: f32 = 0.05;

pub struct XrOptions {
    /// request the end of the session after this many rendered frames (None: until the
    /// runtime ends it)
    pub frames: Option<u32>,
    /// write the left eye's swapchain image of frame `screenshot_frame` (1-based) as PNG
    pub screenshot: Option<PathBuf>,
    pub screenshot_frame: u32,
    pub exposure: f32,
    /// the scene camera the viewer starts at (None: the first)
    pub camera: Option<String>,
    /// per-eye resolution relative to the runtime's recommendation (1.0: as recommended;
    /// above 1 supersamples), clamped to the runtime's maximum
    pub resolution_scale: f32,
    /// antialiasing: eye rays per pixel (1 = off)
    pub antialiasing: u32,
}

/// What a headset run measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct XrReport {
    pub runtime: String,
    pub system: String,
    pub adapter: String,
    pub reference_space: String,
    pub swapchain_format: String,
    pub interaction_profiles: Vec<String>,
    /// frames rendered and submitted
    pub frames: u32,
    /// frames the runtime said not to render (should_render false)
    pub frames_skipped: u32,
    /// display refreshes between consecutive predicted display times that no frame was
    /// submitted for
    pub missed_frames: u64,
    /// the frames (1-based) after which refreshes were missed, the first 100
    pub missed_after_frames: Vec<u32>,
    /// frames whose xrEndFrame came after their predicted display time (None: the runtime
    /// cannot convert the system clock to XrTime)
    pub late_frames: Option<u64>,
    pub display_period_ms: f64,
    /// per eye: GPU time of the eye's render pass (timestamp queries)
    pub eyes: Vec<ViewTiming>,
    /// CPU time from xrBeginFrame to xrEndFrame
    pub cpu_frame_ms: Option<Distribution>,
    /// the session states in the order the runtime reported them
    pub states: Vec<String>,
    pub ended: String,
    /// the runtime lost the session (headset unplugged, runtime gone) rather than ending it
    pub lost: bool,
    pub screenshot: Option<String>,
}

impl XrReport {
    pub fn table(&self) -> String {
        let mut s = format!(
            "OpenXR runtime {} | headset {} | GPU {} | {} space | swapchain {}\n",
            self.runtime, self.system, self.adapter, self.reference_space, self.swapchain_format
        );
        s.push_str(&format!(
            "{} frames rendered, {} skipped by the runtime, {} missed display refreshes (period {:.2} ms)\n",
            self.frames, self.frames_skipped, self.missed_frames, self.display_period_ms
        ));
        if let Some(late) = self.late_frames {
            s.push_str(&format!(
                "{late} frames submitted after their predicted display time\n"
            ));
        }
        if !self.missed_after_frames.is_empty() {
            let list: Vec<String> = self
                .missed_after_frames
                .iter()
                .map(|f| f.to_string())
                .collect();
            s.push_str(&format!("missed after frame(s): {}\n", list.join(", ")));
        }
        s.push_str("eye    pixels      GPU p50 ms  p99 ms   max ms   p99/p50\n");
        for e in &self.eyes {
            match &e.gpu_ms {
                Some(d) => s.push_str(&format!(
                    "{:<6} {:>4}x{:<6} {:>9.3} {:>8.3} {:>8.3} {:>8.3}\n",
                    e.eye,
                    e.pixels[0],
                    e.pixels[1],
                    d.median,
                    d.p99,
                    d.max,
                    d.p99 / d.median.max(1e-12)
                )),
                None => s.push_str(&format!(
                    "{:<6} {:>4}x{:<6} (no GPU timestamps on this adapter)\n",
                    e.eye, e.pixels[0], e.pixels[1]
                )),
            }
        }
        if let Some(c) = &self.cpu_frame_ms {
            s.push_str(&format!(
                "CPU frame (begin to end): p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms\n",
                c.median, c.p99, c.max
            ));
        }
        s.push_str(&format!(
            "session states: {}\nended: {}\n",
            self.states.join(" -> "),
            self.ended
        ));
        if let Some(p) = &self.screenshot {
            s.push_str(&format!("screenshot (left eye): {p}\n"));
        }
        s
    }
}

fn xr_error(what: &str) -> impl Fn(xr::sys::Result) -> VlfError + '_ {
    move |e| VlfError::Display(format!("OpenXR {what}: {e}"))
}

/// One eye: the runtime's swapchain, its images as wgpu textures, and the offscreen image the
/// renderer draws into.
struct Eye {
    name: &'static str,
    /// before `swapchain`: fields drop in order, and the runtime frees the images with it
    images: Vec<wgpu::Texture>,
    swapchain: xr::Swapchain<xr::Vulkan>,
    size: [u32; 2],
    targets: ViewTargets,
    params: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

/// Thumbstick navigation: left stick walks and strafes, right stick turns (x) and rises or
/// sinks (y, in fly mode); a button resets to the start.
struct Controls {
    set: xr::ActionSet,
    walk: xr::Action<xr::Vector2f>,
    turn: xr::Action<xr::Vector2f>,
    reset: xr::Action<bool>,
    fly: xr::Action<bool>,
    profiles: Vec<String>,
}

fn controls(instance: &xr::Instance) -> Result<Controls> {
    let err = xr_error("action set");
    let set = instance
        .create_action_set("navigation", "Navigation", 0)
        .map_err(&err)?;
    let walk = set
        .create_action::<xr::Vector2f>("walk", "Walk (left thumbstick)", &[])
        .map_err(&err)?;
    let turn = set
        .create_action::<xr::Vector2f>("turn", "Turn and rise (right thumbstick)", &[])
        .map_err(&err)?;
    let reset = set
        .create_action::<bool>("reset", "Back to the start", &[])
        .map_err(&err)?;
    let fly = set
        .create_action::<bool>("fly", "Toggle flying", &[])
        .map_err(&err)?;
    let path = |p: &str| instance.string_to_path(p).map_err(xr_error("path"));
    // (profile, walk, turn, reset, fly): thumbsticks where the controller has them, the
    // trackpad on Vive wands
    let suggestions = [
        (
            "/interaction_profiles/oculus/touch_controller",
            "thumbstick",
            "thumbstick",
            "/user/hand/left/input/x/click",
            "/user/hand/right/input/a/click",
        ),
        (
            "/interaction_profiles/valve/index_controller",
            "thumbstick",
            "thumbstick",
            "/user/hand/left/input/a/click",
            "/user/hand/right/input/a/click",
        ),
        (
            "/interaction_profiles/microsoft/motion_controller",
            "thumbstick",
            "thumbstick",
            "/user/hand/left/input/menu/click",
            "/user/hand/right/input/menu/click",
        ),
        (
            "/interaction_profiles/htc/vive_controller",
            "trackpad",
            "trackpad",
            "/user/hand/left/input/menu/click",
            "/user/hand/right/input/menu/click",
        ),
    ];
    let mut profiles = Vec::new();
    for (profile, walk_input, turn_input, reset_input, fly_input) in suggestions {
        let bindings = [
            xr::Binding::new(&walk, path(&format!("/user/hand/left/input/{walk_input}"))?),
            xr::Binding::new(
                &turn,
                path(&format!("/user/hand/right/input/{turn_input}"))?,
            ),
            xr::Binding::new(&reset, path(reset_input)?),
            xr::Binding::new(&fly, path(fly_input)?),
        ];
        // a runtime that does not know a profile refuses it; the others still work
        match instance.suggest_interaction_profile_bindings(path(profile)?, &bindings) {
            Ok(()) => profiles.push(
                profile
                    .trim_start_matches("/interaction_profiles/")
                    .to_string(),
            ),
            Err(e) => log::info!("OpenXR runtime refused bindings for {profile}: {e}"),
        }
    }
    if profiles.is_empty() {
        log::warn!(
            "the OpenXR runtime accepted no controller bindings: navigation by thumbstick is off"
        );
    }
    Ok(Controls {
        set,
        walk,
        turn,
        reset,
        fly,
        profiles,
    })
}

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

/// Run the session until the runtime ends it (or `options.frames` have been shown). The light
/// field is made on the runtime's device by `make_light_field`.
pub fn run(
    instance: xr::Instance,
    system: xr::SystemId,
    runtime: XrRuntime,
    make_light_field: &mut super::MakeLightField<'_>,
    options: &XrOptions,
) -> Result<XrReport> {
    let vulkan = super::vulkan::create(&instance, system)?;
    let ctx = vulkan.ctx.clone();
    eprintln!(
        "OpenXR: {} ({}) on {}",
        runtime.runtime, runtime.system, ctx.summary.name
    );
    let (lf, resident) = make_light_field(&ctx)?;
    let camera = lf.camera(options.camera.as_deref())?.clone();
    let mut renderer = Renderer::new(&resident, &lf, &MemoryLedger::default())?;
    renderer.set_samples_per_pixel(options.antialiasing)?;
    let controls = controls(&instance)?;

    // SAFETY: the session info names the instance, device and queue the runtime created for
    // this system; they outlive the session (dropped at the end of this function, after it).
    let (session, mut frame_waiter, mut frame_stream) =
        unsafe { instance.create_session::<xr::Vulkan>(system, &vulkan.session_info) }
            .map_err(xr_error("xrCreateSession"))?;
    session
        .attach_action_sets(&[&controls.set])
        .map_err(xr_error("xrAttachSessionActionSets"))?;
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
    let present = present_pipeline(&ctx, format)?;
    let overlay = crate::render::texture_2d(
        &ctx.device,
        "no overlay",
        [1, 1],
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let overlay_view = overlay.create_view(&Default::default());
    let view_configs = instance
        .enumerate_view_configuration_views(system, VIEW_TYPE)
        .map_err(xr_error("view configuration"))?;
    if view_configs.len() != 2 {
        return Err(VlfError::Display(format!(
            "the OpenXR headset has {} views in its primary stereo configuration, expected 2",
            view_configs.len()
        )));
    }
    let mut eyes = Vec::new();
    for (i, vc) in view_configs.iter().enumerate() {
        let name = ["left", "right"][i];
        let scaled = |recommended: u32, max: u32| {
            ((recommended as f32 * options.resolution_scale).round() as u32).clamp(1, max.max(1))
        };
        let size = [
            scaled(vc.recommended_image_rect_width, vc.max_image_rect_width),
            scaled(vc.recommended_image_rect_height, vc.max_image_rect_height),
        ];
        let swapchain = session
            .create_swapchain(&xr::SwapchainCreateInfo {
                create_flags: xr::SwapchainCreateFlags::EMPTY,
                usage_flags: xr::SwapchainUsageFlags::COLOR_ATTACHMENT
                    | xr::SwapchainUsageFlags::TRANSFER_SRC,
                format: vk_format.as_raw() as u32,
                sample_count: 1,
                width: size[0],
                height: size[1],
                face_count: 1,
                array_size: 1,
                mip_count: 1,
            })
            .map_err(xr_error("xrCreateSwapchain"))?;
        let images = swapchain
            .enumerate_images()
            .map_err(xr_error("swapchain images"))?
            .into_iter()
            .enumerate()
            .map(|(n, image)| {
                super::vulkan::wrap_swapchain_image(
                    &ctx,
                    image,
                    format,
                    size,
                    &format!("{name} eye swapchain image {n}"),
                )
            })
            .collect::<Result<Vec<_>>>()?;
        let targets = renderer.view_targets(size[0], size[1]);
        let params = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("present parameters"),
            size: std::mem::size_of::<GpuPresent>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("present"),
            layout: &present.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&targets.image_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&overlay_view),
                },
            ],
        });
        let p = GpuPresent {
            viewport_origin: [0.0, 0.0],
            viewport_size: [size[0] as f32, size[1] as f32],
            exposure: options.exposure,
            encode_srgb: (!present.surface_is_srgb) as u32,
            show_overlay: 0,
            _pad0: 0,
        };
        ctx.queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
        eyes.push(Eye {
            name,
            images,
            swapchain,
            size,
            targets,
            params,
            bind_group,
        });
    }
    // one untimed frame before the session: the first use of every pipeline and image costs
    // more than a display period, and would otherwise be the first frame the headset shows
    // (timestamps included: their first read-back sets up more of the driver)
    let scratch = crate::render::texture_2d(
        &ctx.device,
        "warm-up",
        eyes[0].size,
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let scratch_view = scratch.create_view(&Default::default());
    let mut timestamps = Timestamps::new(&ctx, 2);
    for eye in &eyes {
        let view_proj = crate::render::view_projection(
            &camera,
            &lf.meta.normalisation,
            eye.size[0],
            eye.size[1],
        );
        renderer.set_view_matrix(
            view_proj,
            lf.meta.normalisation.to_unit(camera.eye).as_vec3(),
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        renderer.encode_view(&mut encoder, &eye.targets, timestamps.as_mut());
        draw_to(
            &mut encoder,
            &scratch_view,
            &present.pipeline,
            &eye.bind_group,
        );
        ctx.queue.submit([encoder.finish()]);
    }
    ctx.wait()?;
    if let Some(t) = timestamps.as_mut() {
        t.read_ms(&ctx)?;
    }
    drop((scratch_view, scratch));
    ctx.check_errors()?;

    let navigation = crate::display::Navigation::default();
    let mut navigator = Navigator::default();
    let mut room: Option<Pose> = None;
    let mut event_buffer = xr::EventDataBuffer::new();
    let mut running = false;
    let mut exit_requested = false;
    let mut states = Vec::new();
    let ended;
    let mut lost = false;
    let interrupted = interrupt_flag();
    let (mut frames, mut skipped, mut missed) = (0u32, 0u32, 0u64);
    let mut missed_after = Vec::new();
    let mut late = 0u64;
    let mut gpu: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut cpu = Vec::new();
    let mut last_display_time: Option<i64> = None;
    let mut period_ms = 0.0;
    let mut screenshot_written = None;
    let mut screenshot_writer: Option<std::thread::JoinHandle<Result<()>>> = None;
    let mut waiting_since = Instant::now();
    let mut reset_was_down = false;
    let mut fly_was_down = false;
    'session: loop {
        while let Some(event) = instance
            .poll_event(&mut event_buffer)
            .map_err(xr_error("xrPollEvent"))?
        {
            match event {
                xr::Event::SessionStateChanged(e) => {
                    let state = e.state();
                    states.push(format!("{state:?}").to_lowercase());
                    match state {
                        xr::SessionState::READY => {
                            session
                                .begin(VIEW_TYPE)
                                .map_err(xr_error("xrBeginSession"))?;
                            running = true;
                        }
                        xr::SessionState::STOPPING => {
                            session.end().map_err(xr_error("xrEndSession"))?;
                            running = false;
                        }
                        xr::SessionState::EXITING => {
                            if exit_requested
                                && interrupted.load(std::sync::atomic::Ordering::Relaxed)
                            {
                                ended =
                                    format!("cleanly, interrupted (Ctrl-C) after {frames} frames");
                            } else if exit_requested {
                                ended = format!(
                                    "cleanly, after the {} frames asked for",
                                    options.frames.unwrap_or(frames)
                                );
                            } else {
                                ended = "cleanly, the runtime or the user ended the session".into();
                            }
                            break 'session;
                        }
                        xr::SessionState::LOSS_PENDING => {
                            ended = format!("the runtime lost the session after {frames} frames (headset disconnected or runtime stopped)");
                            lost = true;
                            break 'session;
                        }
                        _ => {}
                    }
                }
                xr::Event::InstanceLossPending(_) => {
                    ended = format!("the OpenXR runtime went away after {frames} frames (instance loss pending)");
                    lost = true;
                    break 'session;
                }
                _ => {}
            }
        }
        if !running {
            if waiting_since.elapsed() > Duration::from_secs(5) {
                eprintln!(
                    "waiting for the OpenXR runtime to make the session ready (states so far: {})",
                    states.join(" -> ")
                );
                waiting_since = Instant::now();
            }
            std::thread::sleep(Duration::from_millis(5));
            continue;
        }
        let frame_state = frame_waiter.wait().map_err(xr_error("xrWaitFrame"))?;
        let display_time = frame_state.predicted_display_time.as_nanos();
        let period = frame_state.predicted_display_period.as_nanos().max(1);
        period_ms = period as f64 * 1e-6;
        if let Some(last) = last_display_time {
            let refreshes = ((display_time - last) as f64 / period as f64).round() as i64;
            if refreshes > 1 {
                missed += (refreshes - 1) as u64;
                if missed_after.len() < 100 {
                    missed_after.push(frames);
                }
            }
        }
        let dt = last_display_time
            .map(|l| ((display_time - l) as f64 * 1e-9) as f32)
            .unwrap_or(0.0)
            .clamp(0.0, 0.1);
        last_display_time = Some(display_time);
        let begun = Instant::now();
        frame_stream.begin().map_err(xr_error("xrBeginFrame"))?;
        if !frame_state.should_render {
            skipped += 1;
            frame_stream
                .end(frame_state.predicted_display_time, blend, &[])
                .map_err(xr_error("xrEndFrame"))?;
            continue;
        }
        session
            .sync_actions(&[xr::ActiveActionSet::new(&controls.set)])
            .map_err(xr_error("xrSyncActions"))?;
        let stick = |a: &xr::Action<xr::Vector2f>| {
            a.state(&session, xr::Path::NULL).map(|s| {
                if s.is_active {
                    s.current_state
                } else {
                    xr::Vector2f::default()
                }
            })
        };
        let walk = stick(&controls.walk).map_err(xr_error("thumbstick"))?;
        let turn = stick(&controls.turn).map_err(xr_error("thumbstick"))?;
        let button = |a: &xr::Action<bool>| {
            a.state(&session, xr::Path::NULL)
                .map(|s| s.is_active && s.current_state)
        };
        let reset_down = button(&controls.reset).map_err(xr_error("button"))?;
        let fly_down = button(&controls.fly).map_err(xr_error("button"))?;
        if reset_down && !reset_was_down {
            navigator.reset();
        }
        if fly_down && !fly_was_down {
            navigator.fly = !navigator.fly;
        }
        (reset_was_down, fly_was_down) = (reset_down, fly_down);
        let dead = |v: f32| if v.abs() < 0.15 { 0.0 } else { v };

        let (_, views) = session
            .locate_views(VIEW_TYPE, frame_state.predicted_display_time, &space)
            .map_err(xr_error("xrLocateViews"))?;
        let base = *room.get_or_insert_with(|| start_room(&camera, &views));
        navigator.step(
            dt,
            &navigation,
            [dead(walk.x), -dead(walk.y), dead(turn.x), -dead(turn.y)],
            base.room_yaw_deg,
        );
        let pose = navigator.apply(base);
        let timed = options.frames.is_none_or(|n| frames < n);
        let mut timestamps = if timed {
            Timestamps::new(&ctx, 2)
        } else {
            None
        };
        let capture = options.screenshot.is_some() && frames + 1 == options.screenshot_frame;
        let mut readback = None;
        for (eye, view) in eyes.iter_mut().zip(&views) {
            let xr_pose = XrPose {
                orientation: [
                    view.pose.orientation.x,
                    view.pose.orientation.y,
                    view.pose.orientation.z,
                    view.pose.orientation.w,
                ],
                position: [
                    view.pose.position.x,
                    view.pose.position.y,
                    view.pose.position.z,
                ],
            };
            let fov = Fov {
                angle_left: view.fov.angle_left,
                angle_right: view.fov.angle_right,
                angle_up: view.fov.angle_up,
                angle_down: view.fov.angle_down,
            };
            let (view_proj, eye_position) =
                eye_view(xr_pose, fov, &pose, &lf.meta.normalisation, NEAR);
            renderer.set_view_matrix(view_proj, eye_position);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            renderer.encode_view(&mut encoder, &eye.targets, timestamps.as_mut());
            let index = eye
                .swapchain
                .acquire_image()
                .map_err(xr_error("xrAcquireSwapchainImage"))?;
            eye.swapchain
                .wait_image(xr::Duration::INFINITE)
                .map_err(xr_error("xrWaitSwapchainImage"))?;
            let texture = &eye.images[index as usize];
            let view = texture.create_view(&Default::default());
            draw_to(&mut encoder, &view, &present.pipeline, &eye.bind_group);
            if capture && eye.name == "left" {
                readback = Some(copy_to_buffer(&ctx, &mut encoder, texture, eye.size));
                // the runtime expects its image back as a colour attachment: an empty pass that
                // keeps the image leaves it in that layout
                drop(present_pass(&mut encoder, &view, wgpu::LoadOp::Load));
            }
            ctx.queue.submit([encoder.finish()]);
            eye.swapchain
                .release_image()
                .map_err(xr_error("xrReleaseSwapchainImage"))?;
        }
        let projection_views: Vec<xr::CompositionLayerProjectionView<xr::Vulkan>> = eyes
            .iter()
            .zip(&views)
            .map(|(eye, view)| {
                xr::CompositionLayerProjectionView::new()
                    .pose(view.pose)
                    .fov(view.fov)
                    .sub_image(
                        xr::SwapchainSubImage::new()
                            .swapchain(&eye.swapchain)
                            .image_array_index(0)
                            .image_rect(xr::Rect2Di {
                                offset: xr::Offset2Di { x: 0, y: 0 },
                                extent: xr::Extent2Di {
                                    width: eye.size[0] as i32,
                                    height: eye.size[1] as i32,
                                },
                            }),
                    )
            })
            .collect();
        let layer = xr::CompositionLayerProjection::new()
            .space(&space)
            .views(&projection_views);
        frame_stream
            .end(frame_state.predicted_display_time, blend, &[&layer])
            .map_err(xr_error("xrEndFrame"))?;
        if runtime.clock {
            let now = instance
                .now()
                .map_err(xr_error("xrConvertTimespecTimeToTimeKHR"))?;
            if timed && now.as_nanos() > display_time {
                late += 1;
            }
        }
        ctx.wait()?;
        ctx.check_errors()?;
        frames += 1;
        if timed {
            cpu.push(begun.elapsed().as_secs_f64() * 1e3);
            if let Some(t) = timestamps.as_mut() {
                for (series, ms) in gpu.iter_mut().zip(t.read_ms(&ctx)?) {
                    series.push(ms);
                }
            }
        }
        if let (Some((buffer, padded_row)), Some(path)) = (readback, options.screenshot.as_ref()) {
            // encoding and writing the PNG would hold up the next frame: a thread does it
            let bytes: Vec<u8> =
                ctx.read_buffer(&buffer, padded_row as u64 * eyes[0].size[1] as u64)?;
            let (size, path) = (eyes[0].size, path.clone());
            screenshot_writer = Some(std::thread::spawn(move || {
                write_screenshot(&bytes, padded_row, size, format, &path)
            }));
            screenshot_written = Some(
                options
                    .screenshot
                    .as_ref()
                    .expect("checked")
                    .display()
                    .to_string(),
            );
        }
        let enough = options.frames.is_some_and(|n| frames >= n);
        let stop = interrupted.load(std::sync::atomic::Ordering::Relaxed);
        if (enough || stop) && !exit_requested {
            if stop {
                eprintln!("interrupted: ending the OpenXR session");
            }
            session
                .request_exit()
                .map_err(xr_error("xrRequestExitSession"))?;
            exit_requested = true;
        }
    }
    if let Some(writer) = screenshot_writer {
        writer
            .join()
            .map_err(|_| VlfError::Display("the screenshot writer failed".into()))??;
    }
    if let (Some(path), None, false) = (&options.screenshot, &screenshot_written, lost) {
        return Err(VlfError::Display(format!(
            "the session ended after {frames} frames, before frame {} that --screenshot {} asked for",
            options.screenshot_frame,
            path.display()
        )));
    }
    let report = XrReport {
        runtime: runtime.runtime,
        system: runtime.system,
        adapter: ctx.summary.name.clone(),
        reference_space: format!("{space_type:?}").to_lowercase(),
        swapchain_format: format!("{format:?}"),
        interaction_profiles: controls.profiles.clone(),
        frames,
        frames_skipped: skipped,
        missed_frames: missed,
        missed_after_frames: missed_after,
        late_frames: runtime.clock.then_some(late),
        display_period_ms: period_ms,
        eyes: eyes
            .iter()
            .zip(&gpu)
            .map(|(eye, series)| {
                let label = crate::display::frame::ViewLabel {
                    wall: "headset".into(),
                    eye: eye.name,
                    pixels: eye.size,
                };
                ViewTiming::of(&label, series)
            })
            .collect(),
        cpu_frame_ms: (!cpu.is_empty()).then(|| Distribution::of(&cpu)),
        states,
        ended,
        lost,
        screenshot: screenshot_written,
    };
    // the swapchains and the session go before the device they were made on
    ctx.wait()?;
    for eye in eyes {
        drop(eye.images);
        drop(eye.swapchain);
        drop((eye.targets, eye.params, eye.bind_group));
    }
    drop((space, controls, frame_stream, frame_waiter, session));
    drop((renderer, resident, lf));
    drop(ctx);
    drop(vulkan);
    drop(instance);
    Ok(report)
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

/// The eye's offscreen image onto a swapchain image, cleared first.
fn draw_to(
    encoder: &mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    pipeline: &wgpu::RenderPipeline,
    bind_group: &wgpu::BindGroup,
) {
    let mut pass = present_pass(encoder, view, wgpu::LoadOp::Clear(wgpu::Color::BLACK));
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.draw(0..3, 0..1);
}

fn copy_to_buffer(
    ctx: &GpuContext,
    encoder: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    [width, height]: [u32; 2],
) -> (wgpu::Buffer, u32) {
    let padded_row = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
        * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("left eye screenshot"),
        size: padded_row as u64 * height as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    (buffer, padded_row)
}

/// The swapchain image as the runtime got it (8-bit, sRGB-encoded) to PNG, written atomically.
fn write_screenshot(
    bytes: &[u8],
    padded_row: u32,
    [width, height]: [u32; 2],
    format: wgpu::TextureFormat,
    path: &std::path::Path,
) -> Result<()> {
    let bgra = matches!(
        format,
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let mut rgba = Vec::with_capacity((width * height * 4) as usize);
    for row in bytes.chunks_exact(padded_row as usize) {
        for px in row[..(width * 4) as usize].chunks_exact(4) {
            let (r, b) = if bgra { (px[2], px[0]) } else { (px[0], px[2]) };
            rgba.extend_from_slice(&[r, px[1], b, 255]);
        }
    }
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &rgba,
        width,
        height,
        image::ExtendedColorType::Rgba8,
    )
    .map_err(|e| VlfError::Display(format!("{}: cannot encode PNG: {e}", path.display())))?;
    crate::lightfield::file::write_atomic(path, &png)
}
