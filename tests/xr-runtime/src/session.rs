//! The session: its states, reference spaces, the simulated head and eyes, and the frame loop
//! (xrWaitFrame pacing, xrBeginFrame / xrEndFrame with the layer checks, the clock).

use crate::*;
use ash::vk::Handle;
use openxr_sys as xr;

// ---- session and its states ------------------------------------------------------------------

pub(crate) unsafe extern "system" fn create_session(
    instance: xr::Instance,
    info: *const xr::SessionCreateInfo,
    session: *mut xr::Session,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    if !rt.requirements_queried {
        return rt.violation(
            "xrCreateSession before xrGetVulkanGraphicsRequirements2KHR",
            xr::Result::ERROR_GRAPHICS_REQUIREMENTS_CALL_MISSING,
        );
    }
    let binding = (*info).next as *const xr::GraphicsBindingVulkanKHR;
    if binding.is_null() || (*binding).ty != xr::GraphicsBindingVulkanKHR::TYPE {
        return rt.violation(
            "xrCreateSession without XrGraphicsBindingVulkanKHR",
            xr::Result::ERROR_GRAPHICS_DEVICE_INVALID,
        );
    }
    let binding = &*binding;
    let Some(device) = rt.vulkan.as_ref().and_then(|v| v.device.clone()) else {
        return rt.violation(
            "xrCreateSession before xrCreateVulkanDeviceKHR",
            xr::Result::ERROR_GRAPHICS_DEVICE_INVALID,
        );
    };
    if binding.device as u64 != device.handle().as_raw() {
        return rt.violation(
            "XrGraphicsBindingVulkanKHR names a device the runtime did not create",
            xr::Result::ERROR_GRAPHICS_DEVICE_INVALID,
        );
    }
    let h = rt.handle();
    rt.sessions.insert(
        h,
        Session {
            state: xr::SessionState::IDLE,
            running: false,
            exit_requested: false,
            device,
            queue: (binding.queue_family_index, binding.queue_index),
            waited: None,
            begun: false,
            last_display_index: 0,
            attached: false,
        },
    );
    rt.set_state(h, xr::SessionState::IDLE);
    rt.set_state(h, xr::SessionState::READY);
    *session = xr::Session::from_raw(h);
    xr::Result::SUCCESS
}

pub(crate) fn write_report(rt: &Runtime) {
    let Some(path) = std::env::var_os("VLF_TEST_XR_REPORT") else {
        return;
    };
    let c = &rt.counters;
    let mut text = format!(
        "frames_waited={}\nframes_ended={}\nlayers_checked={}\nimages_released={}\nstates={}\nviolation={}\n",
        c.frames_waited,
        c.frames_ended,
        c.layers_checked,
        c.images_released,
        c.states.join(","),
        c.violation.clone().unwrap_or_else(|| "none".into())
    );
    text.push_str(&format!(
        "swapchains={}\ncolour_swapchains={}\ncolour_layers={}\ndepth_swapchains={}\narrays_refused={}\n",
        swapchains_text(c),
        c.colour_swapchains.len(),
        c.colour_swapchains.iter().sum::<u32>(),
        c.depth_swapchains.len(),
        c.arrays_refused
    ));
    let offered = std::env::var_os("VLF_TEST_XR_NO_DEPTH").is_none();
    text.push_str(&format!(
        "depth_extension={}\ndepth_views={}\nviews_without_depth={}\n",
        match (offered, rt.depth_enabled) {
            (true, true) => "enabled",
            (true, false) => "offered, not enabled",
            _ => "not offered",
        },
        c.depth_views,
        c.views_without_depth
    ));
    if let Some((frame, min, max, far, outside)) = c.depth_left {
        text.push_str(&format!(
            "depth_left_frame={frame}\ndepth_left_min={min}\ndepth_left_max={max}\ndepth_left_far_share={far}\ndepth_left_outside_share={outside}\n"
        ));
    }
    if let Some((mean, differ)) = c.depth_right {
        text.push_str(&format!(
            "depth_right_mean={mean}\ndepth_eyes_differ_share={differ}\n"
        ));
    }
    let _ = std::fs::write(path, text);
}

/// The swapchains the application made, in words: "1 array (2 layers) + depth", "2 per-eye".
fn swapchains_text(c: &Counters) -> String {
    let colour = &c.colour_swapchains;
    let mut text = match colour.as_slice() {
        [layers] if *layers > 1 => format!("1 array ({layers} layers)"),
        _ if colour.iter().all(|&l| l == 1) => format!("{} per-eye", colour.len()),
        _ => format!("{} ({colour:?} layers)", colour.len()),
    };
    if !c.depth_swapchains.is_empty() {
        text.push_str(" + depth");
    }
    text
}

pub(crate) unsafe extern "system" fn destroy_session(session: xr::Session) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    if !rt.sessions.contains_key(&h) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let chains: Vec<u64> = rt
        .swapchains
        .iter()
        .filter(|(_, s)| s.session == h)
        .map(|(k, _)| *k)
        .collect();
    for k in chains {
        // the application should have destroyed them; a runtime cleans up anyway
        if let Some(s) = rt.swapchains.remove(&k) {
            let device = rt.sessions[&h].device.clone();
            free_images(&device, &s);
        }
    }
    rt.sessions.remove(&h);
    write_report(&rt);
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn begin_session(
    session: xr::Session,
    info: *const xr::SessionBeginInfo,
) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.sessions.get_mut(&session.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if (*info).primary_view_configuration_type != xr::ViewConfigurationType::PRIMARY_STEREO {
        return xr::Result::ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
    }
    if s.running {
        return xr::Result::ERROR_SESSION_RUNNING;
    }
    if s.state != xr::SessionState::READY {
        return rt.violation(
            "xrBeginSession before the session was READY",
            xr::Result::ERROR_SESSION_NOT_READY,
        );
    }
    s.running = true;
    xr::Result::SUCCESS
}

pub(crate) fn stop(rt: &mut Runtime, h: u64) {
    let state = rt.sessions[&h].state;
    if state == xr::SessionState::FOCUSED {
        rt.set_state(h, xr::SessionState::VISIBLE);
    }
    if matches!(state, xr::SessionState::FOCUSED | xr::SessionState::VISIBLE) {
        rt.set_state(h, xr::SessionState::SYNCHRONIZED);
    }
    rt.set_state(h, xr::SessionState::STOPPING);
}

pub(crate) unsafe extern "system" fn request_exit_session(session: xr::Session) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    let Some(s) = rt.sessions.get_mut(&h) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if !s.running {
        return xr::Result::ERROR_SESSION_NOT_RUNNING;
    }
    if !s.exit_requested {
        s.exit_requested = true;
        stop(&mut rt, h);
    }
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn end_session(session: xr::Session) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    let Some(s) = rt.sessions.get_mut(&h) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if !s.running {
        return xr::Result::ERROR_SESSION_NOT_RUNNING;
    }
    if s.state != xr::SessionState::STOPPING {
        return rt.violation(
            "xrEndSession before the session was STOPPING",
            xr::Result::ERROR_SESSION_NOT_STOPPING,
        );
    }
    s.running = false;
    rt.set_state(h, xr::SessionState::IDLE);
    rt.set_state(h, xr::SessionState::EXITING);
    xr::Result::SUCCESS
}

// ---- spaces and views -----------------------------------------------------------------------

pub(crate) unsafe extern "system" fn enumerate_reference_spaces(
    session: xr::Session,
    capacity: u32,
    count: *mut u32,
    out: *mut xr::ReferenceSpaceType,
) -> xr::Result {
    if !runtime().sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let spaces = [
        xr::ReferenceSpaceType::VIEW,
        xr::ReferenceSpaceType::LOCAL,
        xr::ReferenceSpaceType::STAGE,
    ];
    two_call(capacity, count, out, spaces.len(), |i, v| *v = spaces[i])
}

pub(crate) unsafe extern "system" fn create_reference_space(
    session: xr::Session,
    info: *const xr::ReferenceSpaceCreateInfo,
    space: *mut xr::Space,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let ty = (*info).reference_space_type;
    if ![
        xr::ReferenceSpaceType::VIEW,
        xr::ReferenceSpaceType::LOCAL,
        xr::ReferenceSpaceType::STAGE,
    ]
    .contains(&ty)
    {
        return xr::Result::ERROR_REFERENCE_SPACE_UNSUPPORTED;
    }
    let h = rt.handle();
    rt.spaces.insert(h, ty);
    *space = xr::Space::from_raw(h);
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn destroy_space(space: xr::Space) -> xr::Result {
    let mut rt = runtime();
    let reference = rt.spaces.remove(&space.into_raw()).is_some();
    let action = rt.action_spaces.remove(&space.into_raw()).is_some();
    match reference || action {
        true => xr::Result::SUCCESS,
        false => xr::Result::ERROR_HANDLE_INVALID,
    }
}

pub(crate) unsafe extern "system" fn create_action_space(
    session: xr::Session,
    info: *const xr::ActionSpaceCreateInfo,
    space: *mut xr::Space,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let action = (*info).action.into_raw();
    match rt.actions.get(&action) {
        None => return xr::Result::ERROR_HANDLE_INVALID,
        Some((_, ty, _)) if *ty != xr::ActionType::POSE_INPUT => {
            return xr::Result::ERROR_ACTION_TYPE_MISMATCH
        }
        Some(_) => {}
    }
    let h = rt.handle();
    rt.action_spaces.insert(h, action);
    *space = xr::Space::from_raw(h);
    xr::Result::SUCCESS
}

/// A controller's grip in the stage as `VLF_TEST_XR_LEFT_GRIP` / `VLF_TEST_XR_RIGHT_GRIP` script
/// it: "x,y,z" metres, or "x,y,z,yaw,pitch,roll" with degrees as the head's (yaw about +y, then
/// pitch about x, then roll about z; identity points along -z). Unset: not tracked.
pub(crate) fn scripted_grip(binding: &str) -> Option<([f32; 3], [f32; 4])> {
    let name = match binding {
        "/user/hand/left/input/grip/pose" => "VLF_TEST_XR_LEFT_GRIP",
        "/user/hand/right/input/grip/pose" => "VLF_TEST_XR_RIGHT_GRIP",
        _ => return None,
    };
    let numbers: Vec<f32> = (std::env::var(name).ok()?.split(','))
        .map(|v| v.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .ok()?;
    let (position, angles) = match numbers.as_slice() {
        [x, y, z] => ([*x, *y, *z], [0.0; 3]),
        [x, y, z, yaw, pitch, roll] => ([*x, *y, *z], [*yaw, *pitch, *roll]),
        _ => return None,
    };
    let half = |deg: f32| (deg.to_radians() / 2.0).sin_cos();
    let ((sy, cy), (sp, cp), (sr, cr)) = (half(angles[0]), half(angles[1]), half(angles[2]));
    // q = yaw(y) * pitch(x) * roll(z), as x, y, z, w
    let x = cy * sp * cr + sy * cp * sr;
    let y = sy * cp * cr - cy * sp * sr;
    let z = cy * cp * sr - sy * sp * cr;
    let w = cy * cp * cr + sy * sp * sr;
    Some((position, [x, y, z, w]))
}

pub(crate) unsafe extern "system" fn locate_space(
    space: xr::Space,
    base: xr::Space,
    time: xr::Time,
    location: *mut xr::SpaceLocation,
) -> xr::Result {
    let rt = runtime();
    let (Some(action), Some(base)) = (
        rt.action_spaces.get(&space.into_raw()),
        rt.spaces.get(&base.into_raw()),
    ) else {
        // the simulated controllers are located in a reference space; nothing else is
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if time.as_nanos() <= 0 {
        return xr::Result::ERROR_TIME_INVALID;
    }
    let focused = (rt.sessions.values()).any(|s| s.state == xr::SessionState::FOCUSED);
    let bound = rt.actions.get(action).and_then(|a| a.2.first());
    let grip = bound.filter(|_| focused).and_then(|b| scripted_grip(b));
    let out = &mut *location;
    out.location_flags = xr::SpaceLocationFlags::EMPTY;
    out.pose = xr::Posef::IDENTITY;
    if let Some((mut position, [x, y, z, w])) = grip {
        match *base {
            xr::ReferenceSpaceType::STAGE => {}
            // LOCAL's origin is at the head's height (`locate_views`)
            xr::ReferenceSpaceType::LOCAL => position[1] -= head(0.0).0[1],
            _ => return xr::Result::SUCCESS,
        }
        out.location_flags = xr::SpaceLocationFlags::POSITION_VALID
            | xr::SpaceLocationFlags::ORIENTATION_VALID
            | xr::SpaceLocationFlags::POSITION_TRACKED
            | xr::SpaceLocationFlags::ORIENTATION_TRACKED;
        out.pose = xr::Posef {
            orientation: xr::Quaternionf { x, y, z, w },
            position: xr::Vector3f {
                x: position[0],
                y: position[1],
                z: position[2],
            },
        };
    }
    xr::Result::SUCCESS
}

/// The simulated head at display time `t` (seconds) in the stage: standing at 1.6 m, swaying
/// 5 cm and turning a few degrees, so consecutive frames differ.
pub(crate) fn head(t: f64) -> ([f32; 3], f32) {
    let sway = (t * 0.8).sin() as f32;
    ([0.05 * sway, 1.6, 0.0], 0.05 * sway)
}

pub(crate) unsafe extern "system" fn locate_views(
    session: xr::Session,
    info: *const xr::ViewLocateInfo,
    state: *mut xr::ViewState,
    capacity: u32,
    count: *mut u32,
    out: *mut xr::View,
) -> xr::Result {
    let rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let info = &*info;
    let Some(space) = rt.spaces.get(&info.space.into_raw()).copied() else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if info.display_time.as_nanos() <= 0 {
        return xr::Result::ERROR_TIME_INVALID;
    }
    // VLF_TEST_XR_STILL_HEAD: the head stands still, so that two runs see the same views
    let t = match std::env::var_os("VLF_TEST_XR_STILL_HEAD") {
        Some(_) => 0.0,
        None => info.display_time.as_nanos() as f64 * 1e-9,
    };
    let (mut position, yaw) = head(t);
    match space {
        xr::ReferenceSpaceType::LOCAL => position[1] = 0.0,
        xr::ReferenceSpaceType::VIEW => position = [0.0; 3],
        _ => {}
    }
    let yaw = if space == xr::ReferenceSpaceType::VIEW {
        0.0
    } else {
        yaw
    };
    let orientation = xr::Quaternionf {
        x: 0.0,
        y: (yaw / 2.0).sin(),
        z: 0.0,
        w: (yaw / 2.0).cos(),
    };
    (*state).view_state_flags = xr::ViewStateFlags::ORIENTATION_VALID
        | xr::ViewStateFlags::POSITION_VALID
        | xr::ViewStateFlags::ORIENTATION_TRACKED
        | xr::ViewStateFlags::POSITION_TRACKED;
    two_call(capacity, count, out, 2, |i, v| {
        let side = if i == 0 { -1.0f32 } else { 1.0 };
        let offset = 0.032 * side;
        v.pose = xr::Posef {
            orientation,
            position: xr::Vector3f {
                x: position[0] + offset * yaw.cos(),
                y: position[1],
                z: position[2] - offset * yaw.sin(),
            },
        };
        // wider towards the temple than towards the nose, as in real headsets
        let (outer, inner) = (0.942, 0.698);
        v.fov = xr::Fovf {
            angle_left: if i == 0 { -outer } else { -inner },
            angle_right: if i == 0 { inner } else { outer },
            angle_up: 0.768,
            angle_down: -0.855,
        };
    })
}

// ---- the frame loop -------------------------------------------------------------------------

pub(crate) unsafe extern "system" fn wait_frame(
    session: xr::Session,
    _info: *const xr::FrameWaitInfo,
    state: *mut xr::FrameState,
) -> xr::Result {
    let h = session.into_raw();
    let index = {
        let mut rt = runtime();
        let Some(s) = rt.sessions.get_mut(&h) else {
            return xr::Result::ERROR_HANDLE_INVALID;
        };
        if !s.running {
            return xr::Result::ERROR_SESSION_NOT_RUNNING;
        }
        // the next refresh after now, and never the same one twice
        let lockstep = std::env::var_os("VLF_TEST_XR_LOCKSTEP").is_some();
        let index = if lockstep && s.last_display_index > 0 {
            s.last_display_index + 1
        } else {
            (monotonic_ns() / PERIOD_NS + 1).max(s.last_display_index + 1)
        };
        s.last_display_index = index;
        s.waited = Some(index);
        index
    };
    // the frame starts one period before its refresh, and is shown one period after it
    let begin_at = (index - 1) * PERIOD_NS;
    let wait = begin_at - monotonic_ns();
    if wait > 0 {
        std::thread::sleep(Duration::from_nanos(wait as u64));
    }
    let mut rt = runtime();
    rt.counters.frames_waited += 1;
    if rt.sessions[&h].state == xr::SessionState::READY {
        rt.set_state(h, xr::SessionState::SYNCHRONIZED);
    }
    let render = matches!(
        rt.sessions[&h].state,
        xr::SessionState::VISIBLE | xr::SessionState::FOCUSED
    );
    (*state).predicted_display_time = xr::Time::from_nanos(index * PERIOD_NS + PERIOD_NS);
    (*state).predicted_display_period = xr::Duration::from_nanos(PERIOD_NS);
    (*state).should_render = render.into();
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn begin_frame(
    session: xr::Session,
    _info: *const xr::FrameBeginInfo,
) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.sessions.get_mut(&session.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if s.waited.is_none() {
        return rt.violation(
            "xrBeginFrame without xrWaitFrame",
            xr::Result::ERROR_CALL_ORDER_INVALID,
        );
    }
    let discarded = s.begun;
    s.begun = true;
    if discarded {
        xr::Result::FRAME_DISCARDED
    } else {
        xr::Result::SUCCESS
    }
}

pub(crate) unsafe extern "system" fn convert_timespec_time_to_time(
    instance: xr::Instance,
    timespec: *const libc::timespec,
    time: *mut xr::Time,
) -> xr::Result {
    if !runtime().instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let t = &*timespec;
    *time = xr::Time::from_nanos(t.tv_sec * 1_000_000_000 + t.tv_nsec);
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn convert_time_to_timespec_time(
    instance: xr::Instance,
    time: xr::Time,
    timespec: *mut libc::timespec,
) -> xr::Result {
    if !runtime().instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let ns = time.as_nanos();
    *timespec = libc::timespec {
        tv_sec: ns.div_euclid(1_000_000_000),
        tv_nsec: ns.rem_euclid(1_000_000_000),
    };
    xr::Result::SUCCESS
}

/// What a projection layer carried besides its colour: per view, its depth sub-image
/// (swapchain, layer) if any.
pub(crate) struct LayerSeen {
    pub(crate) depth: Vec<Option<(u64, u32)>>,
}

/// A sub-image: a known swapchain of the right kind with an image released this frame, the
/// rectangle inside it and the layer one it has. `what` names it in the error.
pub(crate) fn check_sub_image(
    rt: &Runtime,
    sub: &xr::SwapchainSubImage,
    depth: bool,
    what: &str,
) -> Result<(), String> {
    let Some(chain) = rt.swapchains.get(&sub.swapchain.into_raw()) else {
        return Err(format!("{what}: unknown swapchain"));
    };
    if chain.depth != depth {
        let kind = if depth { "a colour" } else { "a depth" };
        return Err(format!("{what}: {kind} swapchain"));
    }
    if !chain.released_since_end || !chain.acquired.is_empty() {
        return Err(format!(
            "{what}: its swapchain has no released image this frame"
        ));
    }
    let r = sub.image_rect;
    if r.offset.x < 0
        || r.offset.y < 0
        || r.extent.width <= 0
        || r.extent.height <= 0
        || (r.offset.x + r.extent.width) as u32 > chain.size[0]
        || (r.offset.y + r.extent.height) as u32 > chain.size[1]
    {
        return Err(format!("{what}: image rect outside the swapchain"));
    }
    if sub.image_array_index >= chain.layers {
        return Err(format!(
            "{what}: image array index {} in a swapchain of {} layer(s)",
            sub.image_array_index, chain.layers
        ));
    }
    Ok(())
}

/// XrCompositionLayerDepthInfoKHR chained into projection view `i`, if any: only with the
/// extension enabled, a depth sub-image of the same size and layer as the colour's, a depth
/// range within [0, 1] and near and far planes that are positive, finite and apart.
pub(crate) unsafe fn check_depth(
    rt: &Runtime,
    view: &xr::CompositionLayerProjectionView,
    i: usize,
) -> Result<Option<(u64, u32)>, String> {
    let mut next = view.next as *const xr::BaseInStructure;
    while !next.is_null() && (*next).ty != xr::CompositionLayerDepthInfoKHR::TYPE {
        next = (*next).next;
    }
    if next.is_null() {
        return Ok(None);
    }
    if !rt.depth_enabled {
        return Err(format!("projection view {i}: XrCompositionLayerDepthInfoKHR without XR_KHR_composition_layer_depth enabled"));
    }
    let d = &*(next as *const xr::CompositionLayerDepthInfoKHR);
    check_sub_image(
        rt,
        &d.sub_image,
        true,
        &format!("projection view {i}'s depth"),
    )?;
    if d.sub_image.image_rect.extent.width != view.sub_image.image_rect.extent.width
        || d.sub_image.image_rect.extent.height != view.sub_image.image_rect.extent.height
        || d.sub_image.image_array_index != view.sub_image.image_array_index
    {
        return Err(format!(
            "projection view {i}: depth sub-image of another size or layer than the colour's"
        ));
    }
    let range_ok = (0.0..=1.0).contains(&d.min_depth)
        && (0.0..=1.0).contains(&d.max_depth)
        && d.min_depth < d.max_depth;
    let planes_ok = d.near_z.is_finite()
        && d.far_z.is_finite()
        && d.near_z > 0.0
        && d.far_z > 0.0
        && d.near_z != d.far_z;
    if !range_ok || !planes_ok {
        return Err(format!(
            "projection view {i}: depth range {}..{}, near {} far {}",
            d.min_depth, d.max_depth, d.near_z, d.far_z
        ));
    }
    Ok(Some((
        d.sub_image.swapchain.into_raw(),
        d.sub_image.image_array_index,
    )))
}

pub(crate) unsafe fn check_layer(
    rt: &Runtime,
    layer: *const xr::CompositionLayerBaseHeader,
) -> Result<LayerSeen, String> {
    if (*layer).ty != xr::CompositionLayerProjection::TYPE {
        return Err(format!(
            "layer of type {:?}: this runtime composes projection layers only",
            (*layer).ty
        ));
    }
    let projection = &*(layer as *const xr::CompositionLayerProjection);
    if !rt.spaces.contains_key(&projection.space.into_raw()) {
        return Err("projection layer in an unknown space".into());
    }
    if projection.view_count != 2 {
        return Err(format!(
            "projection layer with {} views, the stereo configuration has 2",
            projection.view_count
        ));
    }
    let mut seen = LayerSeen { depth: Vec::new() };
    let mut places = Vec::new();
    for i in 0..2 {
        let view = &*projection.views.add(i);
        if view.ty != xr::CompositionLayerProjectionView::TYPE {
            return Err(format!("projection view {i}: wrong structure type"));
        }
        check_sub_image(rt, &view.sub_image, false, &format!("projection view {i}"))?;
        // two eyes on one image would show one eye's picture to both
        let place = (
            view.sub_image.swapchain.into_raw(),
            view.sub_image.image_array_index,
        );
        if places.contains(&place) {
            return Err(format!(
                "projection view {i}: the same swapchain and layer as another view"
            ));
        }
        places.push(place);
        seen.depth.push(check_depth(rt, view, i)?);
        let f = view.fov;
        if !(f.angle_left < f.angle_right && f.angle_down < f.angle_up) {
            return Err(format!("projection view {i}: empty field of view"));
        }
        let q = view.pose.orientation;
        let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
        if (norm - 1.0).abs() > 1e-3 {
            return Err(format!(
                "projection view {i}: orientation not a unit quaternion"
            ));
        }
    }
    Ok(seen)
}

/// Read back both eyes' depth of the last frame ended (when the application destroys the first
/// depth swapchain: after its last frame and its own account of the frames, which a read-back on
/// its queue could disturb) and note what the left holds and how the right differs from it (a layer given
/// the wrong eye shows as no difference).
pub(crate) unsafe fn check_eye_depths(rt: &mut Runtime) {
    let Some(Some(left)) = rt.last_depth.first().copied() else {
        return;
    };
    let right = rt.last_depth.get(1).copied().flatten();
    let read = |rt: &Runtime, (chain, layer): (u64, u32)| read_depth(rt, chain, layer);
    let values = read(rt, left).and_then(|l| match right {
        Some(r) => read(rt, r).map(|r| (l, Some(r))),
        None => Ok((l, None)),
    });
    match values {
        Ok((values, right)) => {
            let n = values.len().max(1) as f64;
            let inside = values.iter().filter(|v| (0.0..=1.0).contains(*v));
            let (min, max) =
                inside.fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            let far = values.iter().filter(|&&v| v == 1.0).count() as f64 / n;
            let outside = values.iter().filter(|v| !(0.0..=1.0).contains(*v)).count() as f64 / n;
            let frame = rt.counters.frames_ended;
            rt.counters.depth_left = Some((frame, min, max, far, outside));
            rt.counters.depth_right = right.map(|r| {
                let inside: Vec<f64> = (r.iter().filter(|v| (0.0..=1.0).contains(*v)))
                    .map(|&v| v as f64)
                    .collect();
                let mean = inside.iter().sum::<f64>() / inside.len().max(1) as f64;
                let differ = values.iter().zip(&r).filter(|(a, b)| a != b).count() as f64 / n;
                (mean, differ)
            });
        }
        Err(e) => {
            rt.violation(
                &format!("reading back the eyes' depth: {e}"),
                xr::Result::ERROR_RUNTIME_FAILURE,
            );
        }
    }
}

pub(crate) unsafe extern "system" fn end_frame(
    session: xr::Session,
    info: *const xr::FrameEndInfo,
) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    let Some(s) = rt.sessions.get(&h) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if !s.begun {
        return rt.violation(
            "xrEndFrame without xrBeginFrame",
            xr::Result::ERROR_CALL_ORDER_INVALID,
        );
    }
    let info = &*info;
    let expected = s.waited.map(|i| i * PERIOD_NS + PERIOD_NS).unwrap_or(0);
    if info.display_time.as_nanos() != expected {
        return rt.violation(
            "xrEndFrame with a display time other than xrWaitFrame's prediction",
            xr::Result::ERROR_TIME_INVALID,
        );
    }
    if info.environment_blend_mode != xr::EnvironmentBlendMode::OPAQUE {
        return xr::Result::ERROR_ENVIRONMENT_BLEND_MODE_UNSUPPORTED;
    }
    for i in 0..info.layer_count as usize {
        let seen = match check_layer(&rt, *info.layers.add(i)) {
            Ok(seen) => seen,
            Err(e) => {
                return rt.violation(&format!("xrEndFrame: {e}"), xr::Result::ERROR_LAYER_INVALID)
            }
        };
        rt.counters.layers_checked += 1;
        let with_depth = seen.depth.iter().filter(|d| d.is_some()).count() as u64;
        rt.counters.depth_views += with_depth;
        rt.counters.views_without_depth += seen.depth.len() as u64 - with_depth;
        rt.last_depth = seen.depth;
    }
    for chain in rt.swapchains.values_mut().filter(|c| c.session == h) {
        chain.released_since_end = false;
    }
    let s = rt.sessions.get_mut(&h).expect("checked above");
    s.begun = false;
    s.waited = None;
    let exit_requested = s.exit_requested;
    rt.counters.frames_ended += 1;
    if rt.sessions[&h].state == xr::SessionState::SYNCHRONIZED && !exit_requested {
        rt.set_state(h, xr::SessionState::VISIBLE);
        rt.set_state(h, xr::SessionState::FOCUSED);
    }
    let lose_after = std::env::var("VLF_TEST_XR_LOSE_AFTER")
        .ok()
        .and_then(|v| v.parse::<u64>().ok());
    if lose_after == Some(rt.counters.frames_ended) {
        rt.set_state(h, xr::SessionState::LOSS_PENDING);
    }
    let end_after = std::env::var("VLF_TEST_XR_END_AFTER")
        .ok()
        .and_then(|v| v.parse::<u64>().ok());
    if end_after.is_some_and(|n| rt.counters.frames_ended >= n) && !exit_requested {
        rt.sessions
            .get_mut(&h)
            .expect("checked above")
            .exit_requested = true;
        stop(&mut rt, h);
    }
    xr::Result::SUCCESS
}
