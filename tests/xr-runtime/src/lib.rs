//! A headless OpenXR runtime for vlf's tests. It implements what an application rendering a
//! stereo projection layer with Vulkan uses (XR_KHR_vulkan_enable2, swapchains, the frame loop,
//! session states, reference spaces, actions), enforces the rules of those calls the way a
//! runtime must (call order, image acquire/wait/release, layer contents, the graphics
//! requirements call before the session), and simulates a headset:
//!
//! - 90 Hz display: xrWaitFrame blocks until the frame should start and predicts display times
//!   on that grid, so a slow application misses refreshes;
//! - a head at 1.6 m on the stage, swaying slowly, eyes 64 mm apart, asymmetric fields of view;
//! - Oculus Touch controllers whose thumbsticks read `VLF_TEST_XR_LEFT_STICK` /
//!   `VLF_TEST_XR_RIGHT_STICK` ("x,y", default 0,0);
//! - `VLF_TEST_XR_EYE_PIXELS` ("WxH", default 256x224) recommended per eye;
//! - `VLF_TEST_XR_LOCKSTEP` set: the display waits for the application, one refresh per frame
//!   however long the frame took, so motion per frame is the same on any machine;
//! - `VLF_TEST_XR_END_AFTER` = N: the runtime ends the session itself after N frames, as a user
//!   quitting from the headset's menu would;
//! - `VLF_TEST_XR_LOSE_AFTER` = N: the session is lost after N frames (LOSS_PENDING), as when
//!   a headset is unplugged;
//! - `VLF_TEST_XR_REPORT` = file: at xrDestroySession, one `key=value` line per count of what
//!   the application did (frames, layers checked, states) for the tests to assert on.
//!
//! The first rule violation is written to the report (`violation=...`) and returned as the
//! error the specification names.

#![allow(clippy::missing_safety_doc)]

use ash::vk::{self, Handle};
use openxr_sys as xr;
use openxr_sys::pfn;
use std::collections::{HashMap, VecDeque};
use std::ffi::{c_char, CStr};
use std::sync::{LazyLock, Mutex, MutexGuard};
use std::time::{Duration, Instant};

const RUNTIME_NAME: &str = "vlf headless test runtime";
const SYSTEM_NAME: &str = "vlf simulated headset";
const SYSTEM_ID: u64 = 1;
const PERIOD_NS: i64 = 11_111_111;
const VULKAN_EXTENSION: &str = "XR_KHR_vulkan_enable2";
const PROFILE: &str = "/interaction_profiles/oculus/touch_controller";
const SWAPCHAIN_FORMATS: [vk::Format; 4] = [vk::Format::R8G8B8A8_SRGB, vk::Format::B8G8R8A8_SRGB, vk::Format::R8G8B8A8_UNORM, vk::Format::B8G8R8A8_UNORM];

struct Vulkan {
    instance: ash::Instance,
    physical_device: vk::PhysicalDevice,
    device: Option<ash::Device>,
}

struct Session {
    state: xr::SessionState,
    running: bool,
    exit_requested: bool,
    device: ash::Device,
    /// predicted display time index of the last xrWaitFrame, and whether a frame is begun
    waited: Option<i64>,
    begun: bool,
    last_display_index: i64,
    attached: bool,
}

struct Swapchain {
    session: u64,
    images: Vec<(vk::Image, vk::DeviceMemory)>,
    size: [u32; 2],
    next: usize,
    acquired: VecDeque<usize>,
    waited: bool,
    released_since_end: bool,
}

#[derive(Default)]
struct Counters {
    frames_waited: u64,
    frames_ended: u64,
    layers_checked: u64,
    images_released: u64,
    states: Vec<String>,
    violation: Option<String>,
}

struct Runtime {
    start: Instant,
    next_handle: u64,
    instance: Option<u64>,
    requirements_queried: bool,
    vulkan: Option<Vulkan>,
    sessions: HashMap<u64, Session>,
    swapchains: HashMap<u64, Swapchain>,
    spaces: HashMap<u64, xr::ReferenceSpaceType>,
    paths: Vec<String>,
    action_sets: HashMap<u64, String>,
    /// action -> (set, type, bindings in the simulated controller's profile)
    actions: HashMap<u64, (u64, xr::ActionType, Vec<String>)>,
    events: VecDeque<(u64, xr::SessionState)>,
    counters: Counters,
}

static RUNTIME: LazyLock<Mutex<Runtime>> = LazyLock::new(|| {
    Mutex::new(Runtime {
        start: Instant::now(),
        next_handle: 1,
        instance: None,
        requirements_queried: false,
        vulkan: None,
        sessions: HashMap::new(),
        swapchains: HashMap::new(),
        spaces: HashMap::new(),
        paths: vec![String::new()],
        action_sets: HashMap::new(),
        actions: HashMap::new(),
        events: VecDeque::new(),
        counters: Counters::default(),
    })
});

fn runtime() -> MutexGuard<'static, Runtime> {
    RUNTIME.lock().unwrap_or_else(|e| e.into_inner())
}

impl Runtime {
    fn handle(&mut self) -> u64 {
        self.next_handle += 1;
        self.next_handle
    }
    fn now(&self) -> i64 {
        self.start.elapsed().as_nanos() as i64 + PERIOD_NS
    }
    fn violation(&mut self, what: &str, result: xr::Result) -> xr::Result {
        if self.counters.violation.is_none() {
            self.counters.violation = Some(format!("{what} ({result:?})"));
        }
        eprintln!("[{RUNTIME_NAME}] {what}");
        result
    }
    fn set_state(&mut self, session: u64, state: xr::SessionState) {
        if let Some(s) = self.sessions.get_mut(&session) {
            s.state = state;
        }
        self.counters.states.push(format!("{state:?}").to_lowercase());
        self.events.push_back((session, state));
    }
    fn instance_ok(&self, instance: xr::Instance) -> bool {
        self.instance == Some(instance.into_raw())
    }
}

fn env_pair(name: &str, default: [f32; 2]) -> [f32; 2] {
    std::env::var(name)
        .ok()
        .and_then(|v| {
            let mut it = v.split([',', 'x']).map(|p| p.trim().parse::<f32>());
            Some([it.next()?.ok()?, it.next()?.ok()?])
        })
        .unwrap_or(default)
}

unsafe fn write_str(dst: &mut [c_char], s: &str) {
    for (d, b) in dst.iter_mut().zip(s.bytes().chain(std::iter::once(0))) {
        *d = b as c_char;
    }
    if let Some(last) = dst.last_mut() {
        *last = 0;
    }
}

unsafe fn read_str(src: &[c_char]) -> String {
    CStr::from_ptr(src.as_ptr()).to_string_lossy().into_owned()
}

/// The two-call idiom: report the count, fill when there is room.
unsafe fn two_call<T>(capacity: u32, count: *mut u32, out: *mut T, n: usize, mut fill: impl FnMut(usize, &mut T)) -> xr::Result {
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
pub unsafe extern "system" fn xrNegotiateLoaderRuntimeInterface(info: *const xr::NegotiateLoaderInfo, request: *mut xr::NegotiateRuntimeRequest) -> xr::Result {
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

unsafe extern "system" fn get_instance_proc_addr(instance: xr::Instance, name: *const c_char, function: *mut Option<pfn::VoidFunction>) -> xr::Result {
    if name.is_null() || function.is_null() {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    let name = CStr::from_ptr(name).to_str().unwrap_or("");
    let global = matches!(name, "xrEnumerateInstanceExtensionProperties" | "xrEnumerateApiLayerProperties" | "xrCreateInstance" | "xrGetInstanceProcAddr");
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
    );
    // Applications (the openxr crate among them) resolve every core function up front; the
    // ones this runtime does not implement answer XR_ERROR_FUNCTION_UNSUPPORTED when called.
    // Extension functions it does not offer are reported missing, as the loader expects.
    *function = match f {
        Some(f) => Some(f),
        None if CORE_1_0.contains(&name) => Some(std::mem::transmute::<unsafe extern "system" fn() -> xr::Result, pfn::VoidFunction>(unsupported)),
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
const CORE_1_0: [&str; 12] = [
    "xrStructureTypeToString",
    "xrGetReferenceSpaceBoundsRect",
    "xrCreateActionSpace",
    "xrLocateSpace",
    "xrGetViewConfigurationProperties",
    "xrGetActionStateFloat",
    "xrGetActionStatePose",
    "xrGetCurrentInteractionProfile",
    "xrEnumerateBoundSourcesForAction",
    "xrGetInputSourceLocalizedName",
    "xrApplyHapticFeedback",
    "xrStopHapticFeedback",
];

unsafe extern "system" fn enumerate_instance_extension_properties(layer: *const c_char, capacity: u32, count: *mut u32, out: *mut xr::ExtensionProperties) -> xr::Result {
    if !layer.is_null() {
        return xr::Result::ERROR_API_LAYER_NOT_PRESENT;
    }
    two_call(capacity, count, out, 1, |_, p| {
        write_str(&mut p.extension_name, VULKAN_EXTENSION);
        p.extension_version = 2;
    })
}

unsafe extern "system" fn enumerate_api_layer_properties(capacity: u32, count: *mut u32, out: *mut xr::ApiLayerProperties) -> xr::Result {
    two_call(capacity, count, out, 0, |_, _| {})
}

unsafe extern "system" fn create_instance(info: *const xr::InstanceCreateInfo, instance: *mut xr::Instance) -> xr::Result {
    let mut rt = runtime();
    if info.is_null() || instance.is_null() {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    if rt.instance.is_some() {
        return rt.violation("a second XrInstance while one exists", xr::Result::ERROR_LIMIT_REACHED);
    }
    let info = &*info;
    for i in 0..info.enabled_extension_count as usize {
        let name = CStr::from_ptr(*info.enabled_extension_names.add(i)).to_string_lossy();
        if name != VULKAN_EXTENSION {
            return xr::Result::ERROR_EXTENSION_NOT_PRESENT;
        }
    }
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
        rt.violation("xrDestroyInstance with a session still alive", xr::Result::ERROR_VALIDATION_FAILURE);
    }
    rt.instance = None;
    xr::Result::SUCCESS
}

unsafe extern "system" fn get_instance_properties(instance: xr::Instance, props: *mut xr::InstanceProperties) -> xr::Result {
    if !runtime().instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    (*props).runtime_version = xr::Version::new(0, 1, 0);
    write_str(&mut (*props).runtime_name, RUNTIME_NAME);
    xr::Result::SUCCESS
}

unsafe extern "system" fn result_to_string(_instance: xr::Instance, value: xr::Result, buffer: *mut c_char) -> xr::Result {
    let text = format!("{value:?}");
    write_str(std::slice::from_raw_parts_mut(buffer, xr::MAX_RESULT_STRING_SIZE), &text);
    xr::Result::SUCCESS
}

unsafe extern "system" fn get_system(instance: xr::Instance, info: *const xr::SystemGetInfo, system: *mut xr::SystemId) -> xr::Result {
    if !runtime().instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    if (*info).form_factor != xr::FormFactor::HEAD_MOUNTED_DISPLAY {
        return xr::Result::ERROR_FORM_FACTOR_UNSUPPORTED;
    }
    *system = xr::SystemId::from_raw(SYSTEM_ID);
    xr::Result::SUCCESS
}

unsafe extern "system" fn get_system_properties(_instance: xr::Instance, system: xr::SystemId, props: *mut xr::SystemProperties) -> xr::Result {
    if system.into_raw() != SYSTEM_ID {
        return xr::Result::ERROR_SYSTEM_INVALID;
    }
    let p = &mut *props;
    p.system_id = system;
    p.vendor_id = 0;
    write_str(&mut p.system_name, SYSTEM_NAME);
    p.graphics_properties = xr::SystemGraphicsProperties { max_swapchain_image_height: 4096, max_swapchain_image_width: 4096, max_layer_count: 16 };
    p.tracking_properties = xr::SystemTrackingProperties { orientation_tracking: xr::TRUE, position_tracking: xr::TRUE };
    xr::Result::SUCCESS
}

unsafe extern "system" fn enumerate_view_configurations(_i: xr::Instance, _s: xr::SystemId, capacity: u32, count: *mut u32, out: *mut xr::ViewConfigurationType) -> xr::Result {
    two_call(capacity, count, out, 1, |_, v| *v = xr::ViewConfigurationType::PRIMARY_STEREO)
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
    two_call(capacity, count, out, 1, |_, v| *v = xr::EnvironmentBlendMode::OPAQUE)
}

unsafe extern "system" fn poll_event(instance: xr::Instance, buffer: *mut xr::EventDataBuffer) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let Some((session, state)) = rt.events.pop_front() else { return xr::Result::EVENT_UNAVAILABLE };
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

// ---- Vulkan (XR_KHR_vulkan_enable2) ---------------------------------------------------------

unsafe extern "system" fn get_vulkan_graphics_requirements2(instance: xr::Instance, _s: xr::SystemId, reqs: *mut xr::GraphicsRequirementsVulkanKHR) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    rt.requirements_queried = true;
    (*reqs).min_api_version_supported = xr::Version::new(1, 0, 0);
    (*reqs).max_api_version_supported = xr::Version::new(1, 3, 0);
    xr::Result::SUCCESS
}

unsafe fn static_fn(get_instance_proc_addr: Option<xr::platform::VkGetInstanceProcAddr>) -> Option<ash::StaticFn> {
    let gipa = get_instance_proc_addr?;
    Some(ash::StaticFn { get_instance_proc_addr: std::mem::transmute::<xr::platform::VkGetInstanceProcAddr, vk::PFN_vkGetInstanceProcAddr>(gipa) })
}

unsafe extern "system" fn create_vulkan_instance(
    instance: xr::Instance,
    info: *const xr::VulkanInstanceCreateInfoKHR,
    vk_instance: *mut xr::platform::VkInstance,
    vk_result: *mut xr::platform::VkResult,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let info = &*info;
    let Some(static_fn) = static_fn(info.pfn_get_instance_proc_addr) else { return xr::Result::ERROR_VALIDATION_FAILURE };
    let entry = ash::Entry::from_static_fn(static_fn.clone());
    let create_info = &*(info.vulkan_create_info as *const vk::InstanceCreateInfo);
    match entry.create_instance(create_info, None) {
        Ok(created) => {
            *vk_instance = created.handle().as_raw() as _;
            *vk_result = 0;
            rt.vulkan = Some(Vulkan { instance: created, physical_device: vk::PhysicalDevice::null(), device: None });
            xr::Result::SUCCESS
        }
        Err(e) => {
            *vk_result = e.as_raw();
            xr::Result::SUCCESS
        }
    }
}

unsafe extern "system" fn get_vulkan_graphics_device2(instance: xr::Instance, info: *const xr::VulkanGraphicsDeviceGetInfoKHR, device: *mut xr::platform::VkPhysicalDevice) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let Some(vulkan) = rt.vulkan.as_mut() else {
        return rt.violation("xrGetVulkanGraphicsDevice2KHR before xrCreateVulkanInstanceKHR", xr::Result::ERROR_VALIDATION_FAILURE);
    };
    if (*info).vulkan_instance as u64 != vulkan.instance.handle().as_raw() {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    let Ok(devices) = vulkan.instance.enumerate_physical_devices() else { return xr::Result::ERROR_RUNTIME_FAILURE };
    // a real GPU before a software one, as a headset's runtime would pick the one the display is on
    let chosen = devices
        .iter()
        .copied()
        .find(|&d| vulkan.instance.get_physical_device_properties(d).device_type != vk::PhysicalDeviceType::CPU)
        .or(devices.first().copied());
    let Some(chosen) = chosen else { return xr::Result::ERROR_RUNTIME_FAILURE };
    vulkan.physical_device = chosen;
    *device = chosen.as_raw() as _;
    xr::Result::SUCCESS
}

unsafe extern "system" fn create_vulkan_device(
    instance: xr::Instance,
    info: *const xr::VulkanDeviceCreateInfoKHR,
    vk_device: *mut xr::platform::VkDevice,
    vk_result: *mut xr::platform::VkResult,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let info = &*info;
    let Some(vulkan) = rt.vulkan.as_mut() else {
        return rt.violation("xrCreateVulkanDeviceKHR before xrCreateVulkanInstanceKHR", xr::Result::ERROR_VALIDATION_FAILURE);
    };
    if info.vulkan_physical_device as u64 != vulkan.physical_device.as_raw() {
        return rt.violation("xrCreateVulkanDeviceKHR on a physical device other than xrGetVulkanGraphicsDevice2KHR's", xr::Result::ERROR_VALIDATION_FAILURE);
    }
    let create_info = &*(info.vulkan_create_info as *const vk::DeviceCreateInfo);
    match vulkan.instance.create_device(vulkan.physical_device, create_info, None) {
        Ok(device) => {
            *vk_device = device.handle().as_raw() as _;
            *vk_result = 0;
            vulkan.device = Some(device);
            xr::Result::SUCCESS
        }
        Err(e) => {
            *vk_result = e.as_raw();
            xr::Result::SUCCESS
        }
    }
}

// ---- session and its states ------------------------------------------------------------------

unsafe extern "system" fn create_session(instance: xr::Instance, info: *const xr::SessionCreateInfo, session: *mut xr::Session) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    if !rt.requirements_queried {
        return rt.violation("xrCreateSession before xrGetVulkanGraphicsRequirements2KHR", xr::Result::ERROR_GRAPHICS_REQUIREMENTS_CALL_MISSING);
    }
    let binding = (*info).next as *const xr::GraphicsBindingVulkanKHR;
    if binding.is_null() || (*binding).ty != xr::GraphicsBindingVulkanKHR::TYPE {
        return rt.violation("xrCreateSession without XrGraphicsBindingVulkanKHR", xr::Result::ERROR_GRAPHICS_DEVICE_INVALID);
    }
    let binding = &*binding;
    let Some(device) = rt.vulkan.as_ref().and_then(|v| v.device.clone()) else {
        return rt.violation("xrCreateSession before xrCreateVulkanDeviceKHR", xr::Result::ERROR_GRAPHICS_DEVICE_INVALID);
    };
    if binding.device as u64 != device.handle().as_raw() {
        return rt.violation("XrGraphicsBindingVulkanKHR names a device the runtime did not create", xr::Result::ERROR_GRAPHICS_DEVICE_INVALID);
    }
    let h = rt.handle();
    rt.sessions.insert(
        h,
        Session { state: xr::SessionState::IDLE, running: false, exit_requested: false, device, waited: None, begun: false, last_display_index: 0, attached: false },
    );
    rt.set_state(h, xr::SessionState::IDLE);
    rt.set_state(h, xr::SessionState::READY);
    *session = xr::Session::from_raw(h);
    xr::Result::SUCCESS
}

fn write_report(rt: &Runtime) {
    let Some(path) = std::env::var_os("VLF_TEST_XR_REPORT") else { return };
    let c = &rt.counters;
    let text = format!(
        "frames_waited={}\nframes_ended={}\nlayers_checked={}\nimages_released={}\nstates={}\nviolation={}\n",
        c.frames_waited,
        c.frames_ended,
        c.layers_checked,
        c.images_released,
        c.states.join(","),
        c.violation.clone().unwrap_or_else(|| "none".into())
    );
    let _ = std::fs::write(path, text);
}

unsafe extern "system" fn destroy_session(session: xr::Session) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    if !rt.sessions.contains_key(&h) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let chains: Vec<u64> = rt.swapchains.iter().filter(|(_, s)| s.session == h).map(|(k, _)| *k).collect();
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

unsafe extern "system" fn begin_session(session: xr::Session, info: *const xr::SessionBeginInfo) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.sessions.get_mut(&session.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if (*info).primary_view_configuration_type != xr::ViewConfigurationType::PRIMARY_STEREO {
        return xr::Result::ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
    }
    if s.running {
        return xr::Result::ERROR_SESSION_RUNNING;
    }
    if s.state != xr::SessionState::READY {
        return rt.violation("xrBeginSession before the session was READY", xr::Result::ERROR_SESSION_NOT_READY);
    }
    s.running = true;
    xr::Result::SUCCESS
}

fn stop(rt: &mut Runtime, h: u64) {
    let state = rt.sessions[&h].state;
    if state == xr::SessionState::FOCUSED {
        rt.set_state(h, xr::SessionState::VISIBLE);
    }
    if matches!(state, xr::SessionState::FOCUSED | xr::SessionState::VISIBLE) {
        rt.set_state(h, xr::SessionState::SYNCHRONIZED);
    }
    rt.set_state(h, xr::SessionState::STOPPING);
}

unsafe extern "system" fn request_exit_session(session: xr::Session) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    let Some(s) = rt.sessions.get_mut(&h) else { return xr::Result::ERROR_HANDLE_INVALID };
    if !s.running {
        return xr::Result::ERROR_SESSION_NOT_RUNNING;
    }
    if !s.exit_requested {
        s.exit_requested = true;
        stop(&mut rt, h);
    }
    xr::Result::SUCCESS
}

unsafe extern "system" fn end_session(session: xr::Session) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    let Some(s) = rt.sessions.get_mut(&h) else { return xr::Result::ERROR_HANDLE_INVALID };
    if !s.running {
        return xr::Result::ERROR_SESSION_NOT_RUNNING;
    }
    if s.state != xr::SessionState::STOPPING {
        return rt.violation("xrEndSession before the session was STOPPING", xr::Result::ERROR_SESSION_NOT_STOPPING);
    }
    s.running = false;
    rt.set_state(h, xr::SessionState::IDLE);
    rt.set_state(h, xr::SessionState::EXITING);
    xr::Result::SUCCESS
}

// ---- spaces and views -----------------------------------------------------------------------

unsafe extern "system" fn enumerate_reference_spaces(session: xr::Session, capacity: u32, count: *mut u32, out: *mut xr::ReferenceSpaceType) -> xr::Result {
    if !runtime().sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let spaces = [xr::ReferenceSpaceType::VIEW, xr::ReferenceSpaceType::LOCAL, xr::ReferenceSpaceType::STAGE];
    two_call(capacity, count, out, spaces.len(), |i, v| *v = spaces[i])
}

unsafe extern "system" fn create_reference_space(session: xr::Session, info: *const xr::ReferenceSpaceCreateInfo, space: *mut xr::Space) -> xr::Result {
    let mut rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let ty = (*info).reference_space_type;
    if ![xr::ReferenceSpaceType::VIEW, xr::ReferenceSpaceType::LOCAL, xr::ReferenceSpaceType::STAGE].contains(&ty) {
        return xr::Result::ERROR_REFERENCE_SPACE_UNSUPPORTED;
    }
    let h = rt.handle();
    rt.spaces.insert(h, ty);
    *space = xr::Space::from_raw(h);
    xr::Result::SUCCESS
}

unsafe extern "system" fn destroy_space(space: xr::Space) -> xr::Result {
    match runtime().spaces.remove(&space.into_raw()) {
        Some(_) => xr::Result::SUCCESS,
        None => xr::Result::ERROR_HANDLE_INVALID,
    }
}

/// The simulated head at display time `t` (seconds) in the stage: standing at 1.6 m, swaying
/// 5 cm and turning a few degrees, so consecutive frames differ.
fn head(t: f64) -> ([f32; 3], f32) {
    let sway = (t * 0.8).sin() as f32;
    ([0.05 * sway, 1.6, 0.0], 0.05 * sway)
}

unsafe extern "system" fn locate_views(
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
    let Some(space) = rt.spaces.get(&info.space.into_raw()).copied() else { return xr::Result::ERROR_HANDLE_INVALID };
    if info.display_time.as_nanos() <= 0 {
        return xr::Result::ERROR_TIME_INVALID;
    }
    let (mut position, yaw) = head(info.display_time.as_nanos() as f64 * 1e-9);
    match space {
        xr::ReferenceSpaceType::LOCAL => position[1] = 0.0,
        xr::ReferenceSpaceType::VIEW => position = [0.0; 3],
        _ => {}
    }
    let yaw = if space == xr::ReferenceSpaceType::VIEW { 0.0 } else { yaw };
    let orientation = xr::Quaternionf { x: 0.0, y: (yaw / 2.0).sin(), z: 0.0, w: (yaw / 2.0).cos() };
    (*state).view_state_flags = xr::ViewStateFlags::ORIENTATION_VALID
        | xr::ViewStateFlags::POSITION_VALID
        | xr::ViewStateFlags::ORIENTATION_TRACKED
        | xr::ViewStateFlags::POSITION_TRACKED;
    two_call(capacity, count, out, 2, |i, v| {
        let side = if i == 0 { -1.0f32 } else { 1.0 };
        let offset = 0.032 * side;
        v.pose = xr::Posef {
            orientation,
            position: xr::Vector3f { x: position[0] + offset * yaw.cos(), y: position[1], z: position[2] - offset * yaw.sin() },
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

// ---- swapchains -----------------------------------------------------------------------------

unsafe extern "system" fn enumerate_swapchain_formats(session: xr::Session, capacity: u32, count: *mut u32, out: *mut i64) -> xr::Result {
    if !runtime().sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    two_call(capacity, count, out, SWAPCHAIN_FORMATS.len(), |i, v| *v = SWAPCHAIN_FORMATS[i].as_raw() as i64)
}

unsafe fn free_images(device: &ash::Device, s: &Swapchain) {
    let _ = device.device_wait_idle();
    for (image, memory) in &s.images {
        device.destroy_image(*image, None);
        device.free_memory(*memory, None);
    }
}

unsafe extern "system" fn create_swapchain(session: xr::Session, info: *const xr::SwapchainCreateInfo, swapchain: *mut xr::Swapchain) -> xr::Result {
    let mut rt = runtime();
    let sh = session.into_raw();
    let Some(s) = rt.sessions.get(&sh) else { return xr::Result::ERROR_HANDLE_INVALID };
    let device = s.device.clone();
    let info = &*info;
    let format = vk::Format::from_raw(info.format as i32);
    if !SWAPCHAIN_FORMATS.contains(&format) {
        return xr::Result::ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED;
    }
    if info.width == 0 || info.height == 0 || info.width > 4096 || info.height > 4096 || info.sample_count != 1 || info.face_count != 1 || info.array_size != 1 || info.mip_count != 1 {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    let mut usage = vk::ImageUsageFlags::SAMPLED;
    let flags = info.usage_flags;
    for (x, v) in [
        (xr::SwapchainUsageFlags::COLOR_ATTACHMENT, vk::ImageUsageFlags::COLOR_ATTACHMENT),
        (xr::SwapchainUsageFlags::TRANSFER_SRC, vk::ImageUsageFlags::TRANSFER_SRC),
        (xr::SwapchainUsageFlags::TRANSFER_DST, vk::ImageUsageFlags::TRANSFER_DST),
        (xr::SwapchainUsageFlags::UNORDERED_ACCESS, vk::ImageUsageFlags::STORAGE),
    ] {
        if flags.contains(x) {
            usage |= v;
        }
    }
    let Some(vulkan) = rt.vulkan.as_ref() else { return xr::Result::ERROR_RUNTIME_FAILURE };
    let memory_properties = vulkan.instance.get_physical_device_memory_properties(vulkan.physical_device);
    let mut images = Vec::new();
    for _ in 0..3 {
        let image_info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: info.width, height: info.height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let Ok(image) = device.create_image(&image_info, None) else { return xr::Result::ERROR_RUNTIME_FAILURE };
        let requirements = device.get_image_memory_requirements(image);
        let Some(type_index) = (0..memory_properties.memory_type_count).find(|&i| {
            requirements.memory_type_bits & (1 << i) != 0 && memory_properties.memory_types[i as usize].property_flags.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
        }) else {
            return xr::Result::ERROR_RUNTIME_FAILURE;
        };
        let alloc = vk::MemoryAllocateInfo::default().allocation_size(requirements.size).memory_type_index(type_index);
        let Ok(memory) = device.allocate_memory(&alloc, None) else { return xr::Result::ERROR_RUNTIME_FAILURE };
        if device.bind_image_memory(image, memory, 0).is_err() {
            return xr::Result::ERROR_RUNTIME_FAILURE;
        }
        images.push((image, memory));
    }
    let h = rt.handle();
    rt.swapchains.insert(h, Swapchain { session: sh, images, size: [info.width, info.height], next: 0, acquired: VecDeque::new(), waited: false, released_since_end: false });
    *swapchain = xr::Swapchain::from_raw(h);
    xr::Result::SUCCESS
}

unsafe extern "system" fn destroy_swapchain(swapchain: xr::Swapchain) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.remove(&swapchain.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if let Some(session) = rt.sessions.get(&s.session) {
        free_images(&session.device.clone(), &s);
    }
    xr::Result::SUCCESS
}

unsafe extern "system" fn enumerate_swapchain_images(swapchain: xr::Swapchain, capacity: u32, count: *mut u32, out: *mut xr::SwapchainImageBaseHeader) -> xr::Result {
    let rt = runtime();
    let Some(s) = rt.swapchains.get(&swapchain.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    let out = out as *mut xr::SwapchainImageVulkanKHR;
    let images: Vec<u64> = s.images.iter().map(|(i, _)| i.as_raw()).collect();
    if capacity > 0 && (*out).ty != xr::SwapchainImageVulkanKHR::TYPE {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    two_call(capacity, count, out, images.len(), |i, v| v.image = images[i])
}

unsafe extern "system" fn acquire_swapchain_image(swapchain: xr::Swapchain, _info: *const xr::SwapchainImageAcquireInfo, index: *mut u32) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.get_mut(&swapchain.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if s.acquired.len() == s.images.len() {
        return rt.violation("xrAcquireSwapchainImage with every image already acquired", xr::Result::ERROR_CALL_ORDER_INVALID);
    }
    let i = s.next;
    s.next = (s.next + 1) % s.images.len();
    s.acquired.push_back(i);
    *index = i as u32;
    xr::Result::SUCCESS
}

unsafe extern "system" fn wait_swapchain_image(swapchain: xr::Swapchain, _info: *const xr::SwapchainImageWaitInfo) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.get_mut(&swapchain.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if s.acquired.is_empty() || s.waited {
        return rt.violation("xrWaitSwapchainImage without an acquired, unwaited image", xr::Result::ERROR_CALL_ORDER_INVALID);
    }
    s.waited = true;
    xr::Result::SUCCESS
}

unsafe extern "system" fn release_swapchain_image(swapchain: xr::Swapchain, _info: *const xr::SwapchainImageReleaseInfo) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.get_mut(&swapchain.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if !s.waited {
        return rt.violation("xrReleaseSwapchainImage before xrWaitSwapchainImage", xr::Result::ERROR_CALL_ORDER_INVALID);
    }
    s.acquired.pop_front();
    s.waited = false;
    s.released_since_end = true;
    rt.counters.images_released += 1;
    xr::Result::SUCCESS
}

// ---- the frame loop -------------------------------------------------------------------------

unsafe extern "system" fn wait_frame(session: xr::Session, _info: *const xr::FrameWaitInfo, state: *mut xr::FrameState) -> xr::Result {
    let (start, h) = {
        let rt = runtime();
        (rt.start, session.into_raw())
    };
    let index = {
        let mut rt = runtime();
        let Some(s) = rt.sessions.get_mut(&h) else { return xr::Result::ERROR_HANDLE_INVALID };
        if !s.running {
            return xr::Result::ERROR_SESSION_NOT_RUNNING;
        }
        // the next refresh after now, and never the same one twice
        let now = start.elapsed().as_nanos() as i64;
        let lockstep = std::env::var_os("VLF_TEST_XR_LOCKSTEP").is_some();
        let index = if lockstep { s.last_display_index + 1 } else { (now / PERIOD_NS + 1).max(s.last_display_index + 1) };
        s.last_display_index = index;
        s.waited = Some(index);
        index
    };
    // the frame starts one period before its display
    let begin_at = Duration::from_nanos(((index - 1) * PERIOD_NS) as u64);
    if let Some(wait) = begin_at.checked_sub(start.elapsed()) {
        std::thread::sleep(wait);
    }
    let mut rt = runtime();
    rt.counters.frames_waited += 1;
    if rt.sessions[&h].state == xr::SessionState::READY {
        rt.set_state(h, xr::SessionState::SYNCHRONIZED);
    }
    let render = matches!(rt.sessions[&h].state, xr::SessionState::VISIBLE | xr::SessionState::FOCUSED);
    (*state).predicted_display_time = xr::Time::from_nanos(index * PERIOD_NS + PERIOD_NS);
    (*state).predicted_display_period = xr::Duration::from_nanos(PERIOD_NS);
    (*state).should_render = render.into();
    xr::Result::SUCCESS
}

unsafe extern "system" fn begin_frame(session: xr::Session, _info: *const xr::FrameBeginInfo) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.sessions.get_mut(&session.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if s.waited.is_none() {
        return rt.violation("xrBeginFrame without xrWaitFrame", xr::Result::ERROR_CALL_ORDER_INVALID);
    }
    let discarded = s.begun;
    s.begun = true;
    if discarded {
        xr::Result::FRAME_DISCARDED
    } else {
        xr::Result::SUCCESS
    }
}

unsafe fn check_layer(rt: &Runtime, layer: *const xr::CompositionLayerBaseHeader) -> Result<(), String> {
    if (*layer).ty != xr::CompositionLayerProjection::TYPE {
        return Err(format!("layer of type {:?}: this runtime composes projection layers only", (*layer).ty));
    }
    let projection = &*(layer as *const xr::CompositionLayerProjection);
    if !rt.spaces.contains_key(&projection.space.into_raw()) {
        return Err("projection layer in an unknown space".into());
    }
    if projection.view_count != 2 {
        return Err(format!("projection layer with {} views, the stereo configuration has 2", projection.view_count));
    }
    for i in 0..2 {
        let view = &*projection.views.add(i);
        if view.ty != xr::CompositionLayerProjectionView::TYPE {
            return Err(format!("projection view {i}: wrong structure type"));
        }
        let Some(chain) = rt.swapchains.get(&view.sub_image.swapchain.into_raw()) else { return Err(format!("projection view {i}: unknown swapchain")) };
        if !chain.released_since_end || !chain.acquired.is_empty() {
            return Err(format!("projection view {i}: its swapchain has no released image this frame"));
        }
        let r = view.sub_image.image_rect;
        if r.offset.x < 0 || r.offset.y < 0 || r.extent.width <= 0 || r.extent.height <= 0 || (r.offset.x + r.extent.width) as u32 > chain.size[0] || (r.offset.y + r.extent.height) as u32 > chain.size[1] {
            return Err(format!("projection view {i}: image rect outside the swapchain"));
        }
        let f = view.fov;
        if !(f.angle_left < f.angle_right && f.angle_down < f.angle_up) {
            return Err(format!("projection view {i}: empty field of view"));
        }
        let q = view.pose.orientation;
        let norm = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
        if (norm - 1.0).abs() > 1e-3 {
            return Err(format!("projection view {i}: orientation not a unit quaternion"));
        }
    }
    Ok(())
}

unsafe extern "system" fn end_frame(session: xr::Session, info: *const xr::FrameEndInfo) -> xr::Result {
    let mut rt = runtime();
    let h = session.into_raw();
    let Some(s) = rt.sessions.get(&h) else { return xr::Result::ERROR_HANDLE_INVALID };
    if !s.begun {
        return rt.violation("xrEndFrame without xrBeginFrame", xr::Result::ERROR_CALL_ORDER_INVALID);
    }
    let info = &*info;
    let expected = s.waited.map(|i| i * PERIOD_NS + PERIOD_NS).unwrap_or(0);
    if info.display_time.as_nanos() != expected {
        return rt.violation("xrEndFrame with a display time other than xrWaitFrame's prediction", xr::Result::ERROR_TIME_INVALID);
    }
    if info.environment_blend_mode != xr::EnvironmentBlendMode::OPAQUE {
        return xr::Result::ERROR_ENVIRONMENT_BLEND_MODE_UNSUPPORTED;
    }
    for i in 0..info.layer_count as usize {
        if let Err(e) = check_layer(&rt, *info.layers.add(i)) {
            return rt.violation(&format!("xrEndFrame: {e}"), xr::Result::ERROR_LAYER_INVALID);
        }
        rt.counters.layers_checked += 1;
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
    let lose_after = std::env::var("VLF_TEST_XR_LOSE_AFTER").ok().and_then(|v| v.parse::<u64>().ok());
    if lose_after == Some(rt.counters.frames_ended) {
        rt.set_state(h, xr::SessionState::LOSS_PENDING);
    }
    let end_after = std::env::var("VLF_TEST_XR_END_AFTER").ok().and_then(|v| v.parse::<u64>().ok());
    if end_after.is_some_and(|n| rt.counters.frames_ended >= n) && !exit_requested {
        rt.sessions.get_mut(&h).expect("checked above").exit_requested = true;
        stop(&mut rt, h);
    }
    xr::Result::SUCCESS
}

// ---- paths and actions ----------------------------------------------------------------------

unsafe extern "system" fn string_to_path(instance: xr::Instance, string: *const c_char, path: *mut xr::Path) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let s = CStr::from_ptr(string).to_string_lossy().into_owned();
    if !s.starts_with('/') || s.ends_with('/') || s.contains("//") {
        return xr::Result::ERROR_PATH_FORMAT_INVALID;
    }
    let index = match rt.paths.iter().position(|p| *p == s) {
        Some(i) => i,
        None => {
            rt.paths.push(s);
            rt.paths.len() - 1
        }
    };
    *path = xr::Path::from_raw(index as u64);
    xr::Result::SUCCESS
}

unsafe extern "system" fn path_to_string(instance: xr::Instance, path: xr::Path, capacity: u32, count: *mut u32, buffer: *mut c_char) -> xr::Result {
    let rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let Some(s) = rt.paths.get(path.into_raw() as usize).filter(|_| path.into_raw() != 0) else { return xr::Result::ERROR_PATH_INVALID };
    let bytes: Vec<u8> = s.bytes().chain(std::iter::once(0)).collect();
    two_call(capacity, count, buffer, bytes.len(), |i, c| *c = bytes[i] as c_char)
}

unsafe extern "system" fn create_action_set(instance: xr::Instance, info: *const xr::ActionSetCreateInfo, set: *mut xr::ActionSet) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let name = read_str(&(*info).action_set_name);
    if name.is_empty() || rt.action_sets.values().any(|n| *n == name) {
        return xr::Result::ERROR_NAME_DUPLICATED;
    }
    let h = rt.handle();
    rt.action_sets.insert(h, name);
    *set = xr::ActionSet::from_raw(h);
    xr::Result::SUCCESS
}

unsafe extern "system" fn destroy_action_set(set: xr::ActionSet) -> xr::Result {
    let mut rt = runtime();
    rt.actions.retain(|_, (s, _, _)| *s != set.into_raw());
    match rt.action_sets.remove(&set.into_raw()) {
        Some(_) => xr::Result::SUCCESS,
        None => xr::Result::ERROR_HANDLE_INVALID,
    }
}

unsafe extern "system" fn create_action(set: xr::ActionSet, info: *const xr::ActionCreateInfo, action: *mut xr::Action) -> xr::Result {
    let mut rt = runtime();
    if !rt.action_sets.contains_key(&set.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    if rt.sessions.values().any(|s| s.attached) {
        return xr::Result::ERROR_ACTIONSETS_ALREADY_ATTACHED;
    }
    let h = rt.handle();
    rt.actions.insert(h, (set.into_raw(), (*info).action_type, Vec::new()));
    *action = xr::Action::from_raw(h);
    xr::Result::SUCCESS
}

unsafe extern "system" fn destroy_action(action: xr::Action) -> xr::Result {
    match runtime().actions.remove(&action.into_raw()) {
        Some(_) => xr::Result::SUCCESS,
        None => xr::Result::ERROR_HANDLE_INVALID,
    }
}

unsafe extern "system" fn suggest_interaction_profile_bindings(instance: xr::Instance, info: *const xr::InteractionProfileSuggestedBinding) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let info = &*info;
    let Some(profile) = rt.paths.get(info.interaction_profile.into_raw() as usize).cloned() else { return xr::Result::ERROR_PATH_INVALID };
    if !profile.starts_with("/interaction_profiles/") {
        return xr::Result::ERROR_PATH_UNSUPPORTED;
    }
    let mut bindings = Vec::new();
    for i in 0..info.count_suggested_bindings as usize {
        let b = &*info.suggested_bindings.add(i);
        let Some(path) = rt.paths.get(b.binding.into_raw() as usize).cloned() else { return xr::Result::ERROR_PATH_INVALID };
        if !path.starts_with("/user/hand/") {
            return xr::Result::ERROR_PATH_UNSUPPORTED;
        }
        if !rt.actions.contains_key(&b.action.into_raw()) {
            return xr::Result::ERROR_HANDLE_INVALID;
        }
        bindings.push((b.action.into_raw(), path));
    }
    // the simulated controllers are Oculus Touch: only that profile's bindings take effect
    if profile == PROFILE {
        for (action, path) in bindings {
            if let Some(a) = rt.actions.get_mut(&action) {
                a.2.push(path);
            }
        }
    }
    xr::Result::SUCCESS
}

unsafe extern "system" fn attach_session_action_sets(session: xr::Session, _info: *const xr::SessionActionSetsAttachInfo) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.sessions.get_mut(&session.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if s.attached {
        return xr::Result::ERROR_ACTIONSETS_ALREADY_ATTACHED;
    }
    s.attached = true;
    xr::Result::SUCCESS
}

unsafe extern "system" fn sync_actions(session: xr::Session, _info: *const xr::ActionsSyncInfo) -> xr::Result {
    let rt = runtime();
    let Some(s) = rt.sessions.get(&session.into_raw()) else { return xr::Result::ERROR_HANDLE_INVALID };
    if !s.attached {
        return xr::Result::ERROR_ACTIONSET_NOT_ATTACHED;
    }
    if s.state != xr::SessionState::FOCUSED {
        return xr::Result::SESSION_NOT_FOCUSED;
    }
    xr::Result::SUCCESS
}

fn bound_value(rt: &Runtime, action: xr::Action, ty: xr::ActionType) -> Result<Option<[f32; 2]>, xr::Result> {
    let Some((_, action_type, bindings)) = rt.actions.get(&action.into_raw()) else { return Err(xr::Result::ERROR_HANDLE_INVALID) };
    if *action_type != ty {
        return Err(xr::Result::ERROR_ACTION_TYPE_MISMATCH);
    }
    let focused = rt.sessions.values().any(|s| s.state == xr::SessionState::FOCUSED);
    let Some(binding) = bindings.first().filter(|_| focused) else { return Ok(None) };
    let value = if binding == "/user/hand/left/input/thumbstick" {
        env_pair("VLF_TEST_XR_LEFT_STICK", [0.0, 0.0])
    } else if binding == "/user/hand/right/input/thumbstick" {
        env_pair("VLF_TEST_XR_RIGHT_STICK", [0.0, 0.0])
    } else {
        [0.0, 0.0]
    };
    Ok(Some(value))
}

unsafe extern "system" fn get_action_state_vector2f(session: xr::Session, info: *const xr::ActionStateGetInfo, state: *mut xr::ActionStateVector2f) -> xr::Result {
    let rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    match bound_value(&rt, (*info).action, xr::ActionType::VECTOR2F_INPUT) {
        Err(e) => e,
        Ok(v) => {
            let s = &mut *state;
            s.is_active = v.is_some().into();
            let [x, y] = v.unwrap_or_default();
            s.current_state = xr::Vector2f { x, y };
            s.changed_since_last_sync = xr::FALSE;
            s.last_change_time = xr::Time::from_nanos(0);
            xr::Result::SUCCESS
        }
    }
}

unsafe extern "system" fn get_action_state_boolean(session: xr::Session, info: *const xr::ActionStateGetInfo, state: *mut xr::ActionStateBoolean) -> xr::Result {
    let rt = runtime();
    if !rt.sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    match bound_value(&rt, (*info).action, xr::ActionType::BOOLEAN_INPUT) {
        Err(e) => e,
        Ok(v) => {
            let s = &mut *state;
            s.is_active = v.is_some().into();
            s.current_state = xr::FALSE;
            s.changed_since_last_sync = xr::FALSE;
            s.last_change_time = xr::Time::from_nanos(0);
            xr::Result::SUCCESS
        }
    }
}
