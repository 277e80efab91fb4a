//! A headless OpenXR runtime for vlf's tests. It implements what an application rendering a
//! stereo projection layer with Vulkan uses (XR_KHR_vulkan_enable2, swapchains, the frame loop,
//! session states, reference spaces, actions, XR_KHR_convert_timespec_time with XrTime on
//! CLOCK_MONOTONIC), enforces the rules of those calls the way a
//! runtime must (call order, image acquire/wait/release, layer contents, the graphics
//! requirements call before the session), and simulates a headset:
//!
//! - 90 Hz display: xrWaitFrame blocks until the frame should start and predicts display times
//!   on that grid, so a slow application misses refreshes;
//! - a head at 1.6 m on the stage, swaying slowly, eyes 64 mm apart, asymmetric fields of view;
//! - Oculus Touch controllers whose thumbsticks read `VLF_TEST_XR_LEFT_STICK` /
//!   `VLF_TEST_XR_RIGHT_STICK` ("x,y", default 0,0), and whose grip poses (action spaces
//!   located in the stage or local space) read `VLF_TEST_XR_LEFT_GRIP` / `VLF_TEST_XR_RIGHT_GRIP`
//!   ("x,y,z" stage metres, or "x,y,z,yaw,pitch,roll" with degrees; unset: not tracked);
//! - `VLF_TEST_XR_EYE_PIXELS` ("WxH", default 256x224) recommended per eye;
//! - `VLF_TEST_XR_STILL_HEAD` set: the head stands still (two runs see the same views);
//! - `VLF_TEST_XR_LOCKSTEP` set: the display waits for the application, one refresh per frame
//!   however long the frame took, so motion per frame is the same on any machine;
//! - `VLF_TEST_XR_END_AFTER` = N: the runtime ends the session itself after N frames, as a user
//!   quitting from the headset's menu would;
//! - `VLF_TEST_XR_LOSE_AFTER` = N: the session is lost after N frames (LOSS_PENDING), as when
//!   a headset is unplugged;
//! - array swapchains (a layer per eye) and depth swapchains (D32_SFLOAT) are accepted, and
//!   XR_KHR_composition_layer_depth is offered; `VLF_TEST_XR_NO_ARRAY` set: swapchains with more
//!   than one layer are refused (XR_ERROR_FEATURE_UNSUPPORTED); `VLF_TEST_XR_NO_DEPTH` set: the
//!   depth extension is not offered. Depth chained into projection views is checked, and the
//!   left eye's depth image of one frame is read back and its values checked;
//! - `VLF_TEST_XR_REPORT` = file: at xrDestroySession, one `key=value` line per count of what
//!   the application did (frames, layers checked, states, swapchains, depth) for the tests to
//!   assert on.
//!
//! The first rule violation is written to the report (`violation=...`) and returned as the
//! error the specification names. `vulkan.rs` holds the Vulkan objects and swapchains,
//! `session.rs` the session states, views and frame loop, `actions.rs` paths and actions.

#![allow(clippy::missing_safety_doc)]

mod actions;
mod session;
mod vulkan;

use actions::*;
use ash::vk;
use openxr_sys as xr;
use openxr_sys::pfn;
use session::*;
use std::collections::{HashMap, VecDeque};
use std::ffi::{c_char, CStr};
use std::sync::{LazyLock, Mutex, MutexGuard};
use std::time::Duration;
use vulkan::*;

pub(crate) const RUNTIME_NAME: &str = "vlf headless test runtime";
pub(crate) const SYSTEM_NAME: &str = "vlf simulated headset";
pub(crate) const SYSTEM_ID: u64 = 1;
pub(crate) const PERIOD_NS: i64 = 11_111_111;
pub(crate) const VULKAN_EXTENSION: &str = "XR_KHR_vulkan_enable2";
pub(crate) const CLOCK_EXTENSION: &str = "XR_KHR_convert_timespec_time";
pub(crate) const DEPTH_EXTENSION: &str = "XR_KHR_composition_layer_depth";
/// the depth swapchain format offered (beside the colour formats)
pub(crate) const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
pub(crate) const PROFILE: &str = "/interaction_profiles/oculus/touch_controller";
pub(crate) const SWAPCHAIN_FORMATS: [vk::Format; 4] = [
    vk::Format::R8G8B8A8_SRGB,
    vk::Format::B8G8R8A8_SRGB,
    vk::Format::R8G8B8A8_UNORM,
    vk::Format::B8G8R8A8_UNORM,
];

pub(crate) struct Vulkan {
    pub(crate) instance: ash::Instance,
    pub(crate) physical_device: vk::PhysicalDevice,
    pub(crate) device: Option<ash::Device>,
}

pub(crate) struct Session {
    pub(crate) state: xr::SessionState,
    pub(crate) running: bool,
    pub(crate) exit_requested: bool,
    pub(crate) device: ash::Device,
    /// the queue the application named in XrGraphicsBindingVulkanKHR (depth read-back)
    pub(crate) queue: (u32, u32),
    /// predicted display time index of the last xrWaitFrame, and whether a frame is begun
    pub(crate) waited: Option<i64>,
    pub(crate) begun: bool,
    pub(crate) last_display_index: i64,
    pub(crate) attached: bool,
}

pub(crate) struct Swapchain {
    pub(crate) session: u64,
    pub(crate) images: Vec<(vk::Image, vk::DeviceMemory)>,
    pub(crate) size: [u32; 2],
    pub(crate) layers: u32,
    /// a depth swapchain (DEPTH_FORMAT)
    pub(crate) depth: bool,
    /// the image released last
    pub(crate) last_released: Option<usize>,
    pub(crate) next: usize,
    pub(crate) acquired: VecDeque<usize>,
    pub(crate) waited: bool,
    pub(crate) released_since_end: bool,
}

#[derive(Default)]
pub(crate) struct Counters {
    pub(crate) frames_waited: u64,
    pub(crate) frames_ended: u64,
    pub(crate) layers_checked: u64,
    pub(crate) images_released: u64,
    pub(crate) states: Vec<String>,
    pub(crate) violation: Option<String>,
    /// swapchains created: colour (with their layers) and depth
    pub(crate) colour_swapchains: Vec<u32>,
    pub(crate) depth_swapchains: Vec<u32>,
    /// array swapchains refused (VLF_TEST_XR_NO_ARRAY)
    pub(crate) arrays_refused: u64,
    /// projection views that carried XrCompositionLayerDepthInfoKHR, and those that did not
    pub(crate) depth_views: u64,
    pub(crate) views_without_depth: u64,
    /// the left eye's depth image of the last frame, read back before its swapchain goes: (frame, min, max, share at far, share
    /// outside [0, 1] or not a number)
    pub(crate) depth_left: Option<(u64, f32, f32, f64, f64)>,
    /// the right eye's depth, read back in the same frame: (mean of the values in [0, 1], share
    /// of pixels whose depth differs from the left eye's: 0 if both layers got one eye)
    pub(crate) depth_right: Option<(f64, f64)>,
}

/// XrTime of this runtime: CLOCK_MONOTONIC in nanoseconds, so timespec conversion is exact.
pub(crate) fn monotonic_ns() -> i64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes the timespec it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut t) };
    t.tv_sec * 1_000_000_000 + t.tv_nsec
}

pub(crate) struct Runtime {
    pub(crate) next_handle: u64,
    pub(crate) instance: Option<u64>,
    /// the application enabled XR_KHR_composition_layer_depth
    pub(crate) depth_enabled: bool,
    /// the depth sub-images (swapchain, layer) of each view of the last frame ended, read back
    /// when the first of them is destroyed: a read-back inside xrEndFrame would stall the frame
    /// it measures, and one at xrEndSession can overlap the application's last frames
    pub(crate) last_depth: Vec<Option<(u64, u32)>>,
    pub(crate) requirements_queried: bool,
    pub(crate) vulkan: Option<Vulkan>,
    pub(crate) sessions: HashMap<u64, Session>,
    pub(crate) swapchains: HashMap<u64, Swapchain>,
    pub(crate) spaces: HashMap<u64, xr::ReferenceSpaceType>,
    /// action space -> its pose action
    pub(crate) action_spaces: HashMap<u64, u64>,
    pub(crate) paths: Vec<String>,
    pub(crate) action_sets: HashMap<u64, String>,
    /// action -> (set, type, bindings in the simulated controller's profile)
    pub(crate) actions: HashMap<u64, (u64, xr::ActionType, Vec<String>)>,
    pub(crate) events: VecDeque<(u64, xr::SessionState)>,
    pub(crate) counters: Counters,
}

pub(crate) static RUNTIME: LazyLock<Mutex<Runtime>> = LazyLock::new(|| {
    Mutex::new(Runtime {
        next_handle: 1,
        instance: None,
        depth_enabled: false,
        last_depth: Vec::new(),
        requirements_queried: false,
        vulkan: None,
        sessions: HashMap::new(),
        swapchains: HashMap::new(),
        spaces: HashMap::new(),
        action_spaces: HashMap::new(),
        paths: vec![String::new()],
        action_sets: HashMap::new(),
        actions: HashMap::new(),
        events: VecDeque::new(),
        counters: Counters::default(),
    })
});

pub(crate) fn runtime() -> MutexGuard<'static, Runtime> {
    RUNTIME.lock().unwrap_or_else(|e| e.into_inner())
}

impl Runtime {
    pub(crate) fn handle(&mut self) -> u64 {
        self.next_handle += 1;
        self.next_handle
    }
    pub(crate) fn now(&self) -> i64 {
        monotonic_ns()
    }
    pub(crate) fn violation(&mut self, what: &str, result: xr::Result) -> xr::Result {
        if self.counters.violation.is_none() {
            self.counters.violation = Some(format!("{what} ({result:?})"));
        }
        eprintln!("[{RUNTIME_NAME}] {what}");
        result
    }
    pub(crate) fn set_state(&mut self, session: u64, state: xr::SessionState) {
        if let Some(s) = self.sessions.get_mut(&session) {
            s.state = state;
        }
        self.counters
            .states
            .push(format!("{state:?}").to_lowercase());
        self.events.push_back((session, state));
    }
    pub(crate) fn instance_ok(&self, instance: xr::Instance) -> bool {
        self.instance == Some(instance.into_raw())
    }
}

pub(crate) fn env_pair(name: &str, default: [f32; 2]) -> [f32; 2] {
    std::env::var(name)
        .ok()
        .and_then(|v| {
            let mut it = v.split([',', 'x']).map(|p| p.trim().parse::<f32>());
            Some([it.next()?.ok()?, it.next()?.ok()?])
        })
        .unwrap_or(default)
}

pub(crate) unsafe fn write_str(dst: &mut [c_char], s: &str) {
    for (d, b) in dst.iter_mut().zip(s.bytes().chain(std::iter::once(0))) {
        *d = b as c_char;
    }
    if let Some(last) = dst.last_mut() {
        *last = 0;
    }
}

pub(crate) unsafe fn read_str(src: &[c_char]) -> String {
    CStr::from_ptr(src.as_ptr()).to_string_lossy().into_owned()
}

/// The two-call idiom: report the count, fill when there is room.
pub(crate) unsafe fn two_call<T>(
    capacity: u32,
    count: *mut u32,
    out: *mut T,
    n: usize,
    mut fill: impl FnMut(usize, &mut T),
) -> xr::Result {
    if count.is_null() {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    *count = n as u32;
    if capacity == 0 {
        return xr::Result::SUCCESS;
    }
    if (capacity as usize) < n {
        return xr::Result::ERROR_SIZE_INSUFFICIENT;
    }
    for i in 0..n {
        fill(i, &mut *out.add(i));
    }
    xr::Result::SUCCESS
}

// ---- loader negotiation, instance, system --------------------------------------------------

#[no_mangle]
pub unsafe extern "system" fn xrNegotiateLoaderRuntimeInterface(
    info: *const xr::NegotiateLoaderInfo,
    request: *mut xr::NegotiateRuntimeRequest,
) -> xr::Result {
    if info.is_null() || request.is_null() || (*info).min_interface_version > 1 {
        return xr::Result::ERROR_INITIALIZATION_FAILED;
    }
    (*request).runtime_interface_version = 1;
    (*request).runtime_api_version = xr::Version::new(1, 0, 0);
    (*request).get_instance_proc_addr = Some(get_instance_proc_addr);
    xr::Result::SUCCESS
}

macro_rules! proc_table {
    ($name:expr; $($s:literal => $ty:ident = $f:ident),* $(,)?) => {
        match $name {
            $($s => { let f: pfn::$ty = $f; Some(std::mem::transmute::<pfn::$ty, pfn::VoidFunction>(f)) })*
            _ => None,
        }
    };
}

unsafe extern "system" fn get_instance_proc_addr(
    instance: xr::Instance,
    name: *const c_char,
    function: *mut Option<pfn::VoidFunction>,
) -> xr::Result {
    if name.is_null() || function.is_null() {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    let name = CStr::from_ptr(name).to_str().unwrap_or("");
    let global = matches!(
        name,
        "xrEnumerateInstanceExtensionProperties"
            | "xrEnumerateApiLayerProperties"
            | "xrCreateInstance"
            | "xrGetInstanceProcAddr"
    );
    if instance == xr::Instance::NULL && !global {
        *function = None;
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let f = proc_table!(name;
        "xrGetInstanceProcAddr" => GetInstanceProcAddr = get_instance_proc_addr,
        "xrEnumerateInstanceExtensionProperties" => EnumerateInstanceExtensionProperties = enumerate_instance_extension_properties,
        "xrEnumerateApiLayerProperties" => EnumerateApiLayerProperties = enumerate_api_layer_properties,
        "xrCreateInstance" => CreateInstance = create_instance,
        "xrDestroyInstance" => DestroyInstance = destroy_instance,
        "xrGetInstanceProperties" => GetInstanceProperties = get_instance_properties,
        "xrPollEvent" => PollEvent = poll_event,
        "xrResultToString" => ResultToString = result_to_string,
        "xrGetSystem" => GetSystem = get_system,
        "xrGetSystemProperties" => GetSystemProperties = get_system_properties,
        "xrEnumerateViewConfigurations" => EnumerateViewConfigurations = enumerate_view_configurations,
        "xrEnumerateViewConfigurationViews" => EnumerateViewConfigurationViews = enumerate_view_configuration_views,
        "xrEnumerateEnvironmentBlendModes" => EnumerateEnvironmentBlendModes = enumerate_environment_blend_modes,
        "xrGetVulkanGraphicsRequirements2KHR" => GetVulkanGraphicsRequirements2KHR = get_vulkan_graphics_requirements2,
        "xrCreateVulkanInstanceKHR" => CreateVulkanInstanceKHR = create_vulkan_instance,
        "xrGetVulkanGraphicsDevice2KHR" => GetVulkanGraphicsDevice2KHR = get_vulkan_graphics_device2,
        "xrCreateVulkanDeviceKHR" => CreateVulkanDeviceKHR = create_vulkan_device,
        "xrCreateSession" => CreateSession = create_session,
        "xrDestroySession" => DestroySession = destroy_session,
        "xrBeginSession" => BeginSession = begin_session,
        "xrEndSession" => EndSession = end_session,
        "xrRequestExitSession" => RequestExitSession = request_exit_session,
        "xrEnumerateReferenceSpaces" => EnumerateReferenceSpaces = enumerate_reference_spaces,
        "xrCreateReferenceSpace" => CreateReferenceSpace = create_reference_space,
        "xrDestroySpace" => DestroySpace = destroy_space,
        "xrCreateActionSpace" => CreateActionSpace = create_action_space,
        "xrLocateSpace" => LocateSpace = locate_space,
        "xrEnumerateSwapchainFormats" => EnumerateSwapchainFormats = enumerate_swapchain_formats,
        "xrCreateSwapchain" => CreateSwapchain = create_swapchain,
        "xrDestroySwapchain" => DestroySwapchain = destroy_swapchain,
        "xrEnumerateSwapchainImages" => EnumerateSwapchainImages = enumerate_swapchain_images,
        "xrAcquireSwapchainImage" => AcquireSwapchainImage = acquire_swapchain_image,
        "xrWaitSwapchainImage" => WaitSwapchainImage = wait_swapchain_image,
        "xrReleaseSwapchainImage" => ReleaseSwapchainImage = release_swapchain_image,
        "xrWaitFrame" => WaitFrame = wait_frame,
        "xrBeginFrame" => BeginFrame = begin_frame,
        "xrEndFrame" => EndFrame = end_frame,
        "xrLocateViews" => LocateViews = locate_views,
        "xrStringToPath" => StringToPath = string_to_path,
        "xrPathToString" => PathToString = path_to_string,
        "xrCreateActionSet" => CreateActionSet = create_action_set,
        "xrDestroyActionSet" => DestroyActionSet = destroy_action_set,
        "xrCreateAction" => CreateAction = create_action,
        "xrDestroyAction" => DestroyAction = destroy_action,
        "xrSuggestInteractionProfileBindings" => SuggestInteractionProfileBindings = suggest_interaction_profile_bindings,
        "xrAttachSessionActionSets" => AttachSessionActionSets = attach_session_action_sets,
        "xrSyncActions" => SyncActions = sync_actions,
        "xrGetActionStateBoolean" => GetActionStateBoolean = get_action_state_boolean,
        "xrGetActionStateVector2f" => GetActionStateVector2f = get_action_state_vector2f,
        "xrConvertTimespecTimeToTimeKHR" => ConvertTimespecTimeToTimeKHR = convert_timespec_time_to_time,
        "xrConvertTimeToTimespecTimeKHR" => ConvertTimeToTimespecTimeKHR = convert_time_to_timespec_time,
    );
    // Applications (the openxr crate among them) resolve every core function up front; the
    // ones this runtime does not implement answer XR_ERROR_FUNCTION_UNSUPPORTED when called.
    // Extension functions it does not offer are reported missing, as the loader expects.
    *function = match f {
        Some(f) => Some(f),
        None if CORE_1_0.contains(&name) => Some(std::mem::transmute::<
            unsafe extern "system" fn() -> xr::Result,
            pfn::VoidFunction,
        >(unsupported)),
        None => None,
    };
    if (*function).is_some() {
        xr::Result::SUCCESS
    } else {
        xr::Result::ERROR_FUNCTION_UNSUPPORTED
    }
}

/// Called in place of a core function this runtime leaves out. Every OpenXR function returns
/// XrResult in the same register whatever its parameters, so one body serves them all.
unsafe extern "system" fn unsupported() -> xr::Result {
    xr::Result::ERROR_FUNCTION_UNSUPPORTED
}

/// The OpenXR 1.0 core functions not implemented above.
pub(crate) const CORE_1_0: [&str; 10] = [
    "xrStructureTypeToString",
    "xrGetReferenceSpaceBoundsRect",
    "xrGetViewConfigurationProperties",
    "xrGetActionStateFloat",
    "xrGetActionStatePose",
    "xrGetCurrentInteractionProfile",
    "xrEnumerateBoundSourcesForAction",
    "xrGetInputSourceLocalizedName",
    "xrApplyHapticFeedback",
    "xrStopHapticFeedback",
];

unsafe extern "system" fn enumerate_instance_extension_properties(
    layer: *const c_char,
    capacity: u32,
    count: *mut u32,
    out: *mut xr::ExtensionProperties,
) -> xr::Result {
    if !layer.is_null() {
        return xr::Result::ERROR_API_LAYER_NOT_PRESENT;
    }
    let mut extensions = vec![(VULKAN_EXTENSION, 2), (CLOCK_EXTENSION, 1)];
    if std::env::var_os("VLF_TEST_XR_NO_DEPTH").is_none() {
        extensions.push((DEPTH_EXTENSION, 6));
    }
    two_call(capacity, count, out, extensions.len(), |i, p| {
        write_str(&mut p.extension_name, extensions[i].0);
        p.extension_version = extensions[i].1;
    })
}

unsafe extern "system" fn enumerate_api_layer_properties(
    capacity: u32,
    count: *mut u32,
    out: *mut xr::ApiLayerProperties,
) -> xr::Result {
    two_call(capacity, count, out, 0, |_, _| {})
}

unsafe extern "system" fn create_instance(
    info: *const xr::InstanceCreateInfo,
    instance: *mut xr::Instance,
) -> xr::Result {
    let mut rt = runtime();
    if info.is_null() || instance.is_null() {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    if rt.instance.is_some() {
        return rt.violation(
            "a second XrInstance while one exists",
            xr::Result::ERROR_LIMIT_REACHED,
        );
    }
    let info = &*info;
    let depth_offered = std::env::var_os("VLF_TEST_XR_NO_DEPTH").is_none();
    let mut depth_enabled = false;
    for i in 0..info.enabled_extension_count as usize {
        let name = CStr::from_ptr(*info.enabled_extension_names.add(i)).to_string_lossy();
        if name == DEPTH_EXTENSION && depth_offered {
            depth_enabled = true;
        } else if name != VULKAN_EXTENSION && name != CLOCK_EXTENSION {
            return xr::Result::ERROR_EXTENSION_NOT_PRESENT;
        }
    }
    rt.depth_enabled = depth_enabled;
    if info.application_info.api_version.major() != 1 {
        return xr::Result::ERROR_API_VERSION_UNSUPPORTED;
    }
    let h = rt.handle();
    rt.instance = Some(h);
    *instance = xr::Instance::from_raw(h);
    xr::Result::SUCCESS
}

unsafe extern "system" fn destroy_instance(instance: xr::Instance) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    if !rt.sessions.is_empty() {
        rt.violation(
            "xrDestroyInstance with a session still alive",
            xr::Result::ERROR_VALIDATION_FAILURE,
        );
    }
    rt.instance = None;
    xr::Result::SUCCESS
}

unsafe extern "system" fn get_instance_properties(
    instance: xr::Instance,
    props: *mut xr::InstanceProperties,
) -> xr::Result {
    if !runtime().instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    (*props).runtime_version = xr::Version::new(0, 1, 0);
    write_str(&mut (*props).runtime_name, RUNTIME_NAME);
    xr::Result::SUCCESS
}

unsafe extern "system" fn result_to_string(
    _instance: xr::Instance,
    value: xr::Result,
    buffer: *mut c_char,
) -> xr::Result {
    let text = format!("{value:?}");
    write_str(
        std::slice::from_raw_parts_mut(buffer, xr::MAX_RESULT_STRING_SIZE),
        &text,
    );
    xr::Result::SUCCESS
}

unsafe extern "system" fn get_system(
    instance: xr::Instance,
    info: *const xr::SystemGetInfo,
    system: *mut xr::SystemId,
) -> xr::Result {
    if !runtime().instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    if (*info).form_factor != xr::FormFactor::HEAD_MOUNTED_DISPLAY {
        return xr::Result::ERROR_FORM_FACTOR_UNSUPPORTED;
    }
    *system = xr::SystemId::from_raw(SYSTEM_ID);
    xr::Result::SUCCESS
}

unsafe extern "system" fn get_system_properties(
    _instance: xr::Instance,
    system: xr::SystemId,
    props: *mut xr::SystemProperties,
) -> xr::Result {
    if system.into_raw() != SYSTEM_ID {
        return xr::Result::ERROR_SYSTEM_INVALID;
    }
    let p = &mut *props;
    p.system_id = system;
    p.vendor_id = 0;
    write_str(&mut p.system_name, SYSTEM_NAME);
    p.graphics_properties = xr::SystemGraphicsProperties {
        max_swapchain_image_height: 4096,
        max_swapchain_image_width: 4096,
        max_layer_count: 16,
    };
    p.tracking_properties = xr::SystemTrackingProperties {
        orientation_tracking: xr::TRUE,
        position_tracking: xr::TRUE,
    };
    xr::Result::SUCCESS
}

unsafe extern "system" fn enumerate_view_configurations(
    _i: xr::Instance,
    _s: xr::SystemId,
    capacity: u32,
    count: *mut u32,
    out: *mut xr::ViewConfigurationType,
) -> xr::Result {
    two_call(capacity, count, out, 1, |_, v| {
        *v = xr::ViewConfigurationType::PRIMARY_STEREO
    })
}

unsafe extern "system" fn enumerate_view_configuration_views(
    _i: xr::Instance,
    _s: xr::SystemId,
    ty: xr::ViewConfigurationType,
    capacity: u32,
    count: *mut u32,
    out: *mut xr::ViewConfigurationView,
) -> xr::Result {
    if ty != xr::ViewConfigurationType::PRIMARY_STEREO {
        return xr::Result::ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
    }
    let [w, h] = env_pair("VLF_TEST_XR_EYE_PIXELS", [256.0, 224.0]);
    two_call(capacity, count, out, 2, |_, v| {
        v.recommended_image_rect_width = w as u32;
        v.recommended_image_rect_height = h as u32;
        v.max_image_rect_width = 4096;
        v.max_image_rect_height = 4096;
        v.recommended_swapchain_sample_count = 1;
        v.max_swapchain_sample_count = 1;
    })
}

unsafe extern "system" fn enumerate_environment_blend_modes(
    _i: xr::Instance,
    _s: xr::SystemId,
    _ty: xr::ViewConfigurationType,
    capacity: u32,
    count: *mut u32,
    out: *mut xr::EnvironmentBlendMode,
) -> xr::Result {
    two_call(capacity, count, out, 1, |_, v| {
        *v = xr::EnvironmentBlendMode::OPAQUE
    })
}

unsafe extern "system" fn poll_event(
    instance: xr::Instance,
    buffer: *mut xr::EventDataBuffer,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let Some((session, state)) = rt.events.pop_front() else {
        return xr::Result::EVENT_UNAVAILABLE;
    };
    let time = xr::Time::from_nanos(rt.now());
    let event = buffer as *mut xr::EventDataSessionStateChanged;
    event.write(xr::EventDataSessionStateChanged {
        ty: xr::EventDataSessionStateChanged::TYPE,
        next: std::ptr::null(),
        session: xr::Session::from_raw(session),
        state,
        time,
    });
    xr::Result::SUCCESS
}
