//! `vlf xr`: an OpenXR headset drawn from the one resident light field. This module loads the
//! system's OpenXR loader (the `openxr` crate, at run time), finds a runtime with
//! XR_KHR_vulkan_enable2 and a head-mounted system (or says what is missing and how to install
//! and select a runtime), and draws with the view math of `display::headset_view` (OpenXR's asymmetric field of view to
//! a projection, OpenXR poses to the renderer's views). `vulkan` builds wgpu on the Vulkan
//! instance and device the runtime creates; `session` runs the frame loop; `body` is the moving
//! objects' file and what they follow (the head and the controllers' grips).

pub mod body;
mod colour_pass;
mod controls;
mod eye_pass;
mod eyes;
mod layers;
mod multiview_check;
pub mod report;
pub mod session;
pub mod study;
pub mod vulkan;

pub use colour_pass::LayerColour;
pub use layers::Swapchains;
pub use report::XrReport;
pub use study::XrStudy;

pub use crate::display::headset_view::{
    eye_view, pose_from_view, projection_from_fov, view_from_pose, Fov, XrPose, FAR_OVER_NEAR,
};
pub use crate::display::MakeLightField;

use crate::error::{Result, VlfError};
use std::path::Path;

/// The eyes' view configuration: one stereo pair.
const VIEW_TYPE: openxr::ViewConfigurationType = openxr::ViewConfigurationType::PRIMARY_STEREO;

/// What `vlf xr` is asked for.
pub struct XrOptions {
    /// request the end of the session after this many rendered frames (None: until the
    /// runtime ends it)
    pub frames: Option<u32>,
    /// write the left eye's swapchain image of frame `screenshot_frame` (1-based) as PNG
    pub screenshot: Option<std::path::PathBuf>,
    pub screenshot_frame: u32,
    pub exposure: f32,
    /// the scene camera the viewer starts at (None: the first)
    pub camera: Option<String>,
    /// per-eye resolution relative to the runtime's recommendation (1.0: as recommended;
    /// above 1 supersamples), clamped to the runtime's maximum
    pub resolution_scale: f32,
    /// antialiasing: eye rays per pixel (1 = off)
    pub antialiasing: u32,
    /// probe the eyes in the first frame and pace them after (render/budget.rs)
    pub fit_frame_time: bool,
    /// how eye rays find their first hits (`render::raster`)
    pub first_hits: crate::render::raster::FirstHits,
    /// edge antialiasing (None: `antialiasing` eye rays on every pixel)
    pub edge_antialiasing: Option<crate::render::edges::EdgeAntialiasing>,
    /// one array swapchain for both eyes, or one per eye
    pub swapchains: Swapchains,
    /// how the eyes' colour reaches the swapchains (`colour_pass.rs`)
    pub layer_colour: LayerColour,
    /// a file of moving objects (`body::ObjectsFile`): the participant's body, props in the hands
    pub objects: Option<std::path::PathBuf>,
    /// an experiment script's commands, the session log, LSL (`study.rs`)
    pub study: XrStudy,
}

fn xr_error(what: &str) -> impl Fn(openxr::sys::Result) -> VlfError + '_ {
    move |e| VlfError::Display(format!("OpenXR {what}: {e}"))
}

const INSTALL: &str = "install an OpenXR runtime: Monado (https://monado.freedesktop.org, e.g. the monado-service package) or SteamVR; select it with XR_RUNTIME_JSON=/path/to/its runtime.json (Monado: openxr_monado.json) or make it the active runtime (~/.config/openxr/1/active_runtime.json)";

/// The system's OpenXR loader (`VLF_OPENXR_LOADER` names another file).
pub fn load_loader() -> Result<openxr::Entry> {
    let candidates: Vec<std::ffi::OsString> = match std::env::var_os("VLF_OPENXR_LOADER") {
        Some(path) => vec![path],
        None => vec!["libopenxr_loader.so.1".into(), "libopenxr_loader.so".into()],
    };
    let mut tried = Vec::new();
    for path in &candidates {
        // SAFETY: the file is the OpenXR loader the system or the user named; the crate checks
        // that its entry points exist.
        match unsafe { openxr::Entry::load_from(Path::new(path)) } {
            Ok(entry) => return Ok(entry),
            Err(e) => tried.push(format!("{}: {e}", Path::new(path).display())),
        }
    }
    Err(VlfError::Display(format!(
        "no OpenXR loader found ({}). Install the loader (Debian/Ubuntu: sudo apt-get install libopenxr-loader1) and {INSTALL}",
        tried.join("; ")
    )))
}

/// What the runtime offers: its name and the headset system.
#[derive(Debug)]
pub struct XrRuntime {
    pub runtime: String,
    pub system: String,
    /// the runtime converts the system clock to XrTime (XR_KHR_convert_timespec_time), so
    /// frames submitted after their display time can be counted
    pub clock: bool,
    /// the runtime takes depth layers (XR_KHR_composition_layer_depth), enabled
    pub depth: bool,
}

/// Find a runtime with Vulkan (XR_KHR_vulkan_enable2) and a head-mounted display.
pub fn find_runtime(
    entry: &openxr::Entry,
) -> Result<(openxr::Instance, openxr::SystemId, XrRuntime)> {
    let selected = match std::env::var_os("XR_RUNTIME_JSON") {
        Some(v) => format!("XR_RUNTIME_JSON={}", Path::new(&v).display()),
        None => "XR_RUNTIME_JSON is not set and no active runtime was found".into(),
    };
    let no_runtime = |what: String| {
        VlfError::Display(format!("the OpenXR loader found no usable runtime ({selected}): {what}. To run `vlf xr`, {INSTALL}"))
    };
    let available = entry
        .enumerate_extensions()
        .map_err(|e| no_runtime(e.to_string()))?;
    if !available.khr_vulkan_enable2 {
        return Err(no_runtime(
            "it does not offer XR_KHR_vulkan_enable2 (Vulkan), which vlf renders with".into(),
        ));
    }
    let mut extensions = openxr::ExtensionSet::default();
    extensions.khr_vulkan_enable2 = true;
    extensions.khr_convert_timespec_time = available.khr_convert_timespec_time;
    // depth layers let the runtime reproject with the rendered depth (layers.rs)
    extensions.khr_composition_layer_depth = available.khr_composition_layer_depth;
    let app = openxr::ApplicationInfo {
        application_name: "vlf",
        application_version: 1,
        engine_name: "vlf",
        engine_version: 1,
        api_version: openxr::Version::new(1, 0, 0),
    };
    let instance = entry
        .create_instance(&app, &extensions, &[])
        .map_err(|e| no_runtime(e.to_string()))?;
    let props = instance
        .properties()
        .map_err(|e| no_runtime(e.to_string()))?;
    let system = instance
        .system(openxr::FormFactor::HEAD_MOUNTED_DISPLAY)
        .map_err(|e| VlfError::Display(format!("the OpenXR runtime {} has no headset ({e}): connect one, or start the runtime's simulated headset", props.runtime_name)))?;
    let system_props = instance
        .system_properties(system)
        .map_err(|e| no_runtime(e.to_string()))?;
    let runtime = XrRuntime {
        runtime: format!("{} {}", props.runtime_name, props.runtime_version),
        system: system_props.system_name,
        clock: available.khr_convert_timespec_time,
        depth: available.khr_composition_layer_depth,
    };
    Ok((instance, system, runtime))
}

/// `vlf xr`: the objects (`--objects`), the loader and the runtime are checked before the light
/// field is made (so a machine without a headset learns it at once), then the light field is
/// made on the runtime's device by `make_light_field` and the session runs until the runtime
/// ends it.
pub fn run_headset(
    make_light_field: &mut MakeLightField<'_>,
    options: &XrOptions,
) -> Result<XrReport> {
    // the objects' file and meshes first: a mistake in them is found before any runtime starts
    let objects = match &options.objects {
        Some(path) => {
            let file = body::ObjectsFile::load(path)?;
            let objects = crate::dynamic::Objects::load(&file.objects, path)?;
            Some((objects, file.object_lighting.unwrap_or_default()))
        }
        None => None,
    };
    let conditions = match &options.study.conditions {
        Some((path, _)) => {
            let names: Vec<String> = (objects.iter())
                .flat_map(|(o, _)| o.configs().iter().map(|c| c.name.clone()))
                .collect();
            Some(crate::display::conditions::ConditionsFile::load(
                path, &names,
            )?)
        }
        None => None,
    };
    let entry = load_loader()?;
    let (instance, system, runtime) = find_runtime(&entry)?;
    session::run(
        (instance, system, runtime),
        make_light_field,
        (objects, conditions),
        options,
    )
}
