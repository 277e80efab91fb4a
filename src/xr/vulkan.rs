//! wgpu on the OpenXR runtime's Vulkan device (XR_KHR_vulkan_enable2). The runtime creates the
//! Vulkan instance and device from the create-infos wgpu-hal asks for (it may add extensions of
//! its own); wgpu-hal is built on those raw handles, then wgpu on wgpu-hal. The light field is
//! then propagated into, or loaded onto, that device, and the swapchain images the runtime
//! allocates are wrapped as wgpu textures.

use crate::error::{Result, VlfError};
use crate::gpu::GpuContext;
use ash::vk::{self, Handle};
use std::ffi::{c_char, CStr};
use std::sync::Arc;
use wgpu::hal;
use wgpu::hal::api::Vulkan;

/// The Vulkan objects the OpenXR session is created with, and the wgpu context built on them.
pub struct XrVulkan {
    pub ctx: Arc<GpuContext>,
    pub session_info: openxr::vulkan::SessionCreateInfo,
}

fn vk_error(what: &str, e: impl std::fmt::Display) -> VlfError {
    VlfError::Display(format!("OpenXR/Vulkan: {what}: {e}"))
}

/// The newest Vulkan version the runtime, the system's loader and wgpu (1.3) all support: wgpu
/// enables what a device offers by its API version (timeline semaphores from 1.2), so asking
/// for less than the device has leaves it calling functions the instance never loaded.
fn api_version(requirements: &openxr::vulkan::Requirements, loader_version: u32) -> Result<u32> {
    let min = requirements.min_api_version_supported;
    let max = requirements.max_api_version_supported;
    if min > openxr::Version::new(1, 3, 0) {
        return Err(VlfError::Display(format!(
            "the OpenXR runtime needs Vulkan {min} or newer, which vlf's wgpu does not support"
        )));
    }
    let loader = openxr::Version::new(
        vk::api_version_major(loader_version) as u16,
        vk::api_version_minor(loader_version) as u16,
        0,
    );
    let chosen = [max, loader, openxr::Version::new(1, 3, 0)]
        .into_iter()
        .min()
        .expect("three versions");
    if chosen < min {
        return Err(VlfError::Display(format!("the OpenXR runtime needs Vulkan {min} or newer but the system's Vulkan loader offers {loader}; update the Vulkan loader (libvulkan1)")));
    }
    Ok(vk::make_api_version(
        0,
        chosen.major() as u32,
        chosen.minor() as u32,
        0,
    ))
}

/// The Vulkan instance the runtime created for us, and the GPU it chose.
struct RuntimeInstance {
    entry: ash::Entry,
    api_version: u32,
    extensions: Vec<&'static CStr>,
    flags: wgpu::InstanceFlags,
    ash_instance: ash::Instance,
    raw_instance: vk::Instance,
    physical_device: vk::PhysicalDevice,
    get_instance_proc_addr: openxr::sys::platform::VkGetInstanceProcAddr,
}

/// Let the runtime create the Vulkan instance (with what wgpu needs) and choose the GPU.
fn runtime_instance(
    instance: &openxr::Instance,
    system: openxr::SystemId,
) -> Result<RuntimeInstance> {
    let requirements = instance
        .graphics_requirements::<openxr::Vulkan>(system)
        .map_err(|e| vk_error("graphics requirements", e))?;
    // SAFETY: loads the system's Vulkan loader; its entry points are checked by ash.
    let entry = unsafe { ash::Entry::load() }.map_err(|e| {
        VlfError::Display(format!("no Vulkan loader ({e}); install one (Debian/Ubuntu: sudo apt-get install libvulkan1 and a driver, e.g. mesa-vulkan-drivers)"))
    })?;
    let loader_version = unsafe { entry.try_enumerate_instance_version() }
        .ok()
        .flatten()
        .unwrap_or(vk::API_VERSION_1_0);
    let api_version = api_version(&requirements, loader_version)?;
    let flags = wgpu::InstanceFlags::from_build_config().with_env();
    let extensions = <hal::vulkan::Instance>::desired_extensions(&entry, api_version, flags)
        .map_err(|e| vk_error("instance extensions", e))?;
    let extension_names: Vec<*const c_char> = extensions.iter().map(|e| e.as_ptr()).collect();
    let app_info = vk::ApplicationInfo::default()
        .application_name(c"vlf")
        .engine_name(c"vlf")
        .api_version(api_version);
    let instance_info = vk::InstanceCreateInfo::default()
        .application_info(&app_info)
        .enabled_extension_names(&extension_names);
    // SAFETY: the pointer is the loader's vkGetInstanceProcAddr, whose signature OpenXR's
    // PFN_vkGetInstanceProcAddr matches; the create-info lives across the call.
    let get_instance_proc_addr = unsafe {
        std::mem::transmute::<
            vk::PFN_vkGetInstanceProcAddr,
            openxr::sys::platform::VkGetInstanceProcAddr,
        >(entry.static_fn().get_instance_proc_addr)
    };
    let raw_instance = unsafe {
        instance.create_vulkan_instance(
            system,
            get_instance_proc_addr,
            &instance_info as *const _ as *const _,
        )
    }
    .map_err(|e| vk_error("xrCreateVulkanInstanceKHR", e))?
    .map_err(|r| vk_error("the runtime's vkCreateInstance", vk::Result::from_raw(r)))?;
    let raw_instance = vk::Instance::from_raw(raw_instance as u64);
    // SAFETY: the runtime just created this instance with the loader behind `entry`.
    let ash_instance = unsafe { ash::Instance::load(entry.static_fn(), raw_instance) };
    let physical_device =
        unsafe { instance.vulkan_graphics_device(system, raw_instance.as_raw() as _) }
            .map_err(|e| vk_error("xrGetVulkanGraphicsDevice2KHR", e))?;
    let physical_device = vk::PhysicalDevice::from_raw(physical_device as u64);

    Ok(RuntimeInstance {
        entry,
        api_version,
        extensions,
        flags,
        ash_instance,
        raw_instance,
        physical_device,
        get_instance_proc_addr,
    })
}

/// The device the runtime created on `vulkan`'s GPU (with what wgpu needs), opened by wgpu-hal;
/// and its queue family.
fn runtime_device(
    instance: &openxr::Instance,
    system: openxr::SystemId,
    vulkan: &RuntimeInstance,
    exposed: &hal::ExposedAdapter<Vulkan>,
) -> Result<(
    hal::OpenDevice<Vulkan>,
    u32,
    vk::Device,
    wgpu::Features,
    wgpu::Limits,
)> {
    let RuntimeInstance {
        ash_instance,
        physical_device,
        get_instance_proc_addr,
        ..
    } = vulkan;
    let (physical_device, get_instance_proc_addr) = (*physical_device, *get_instance_proc_addr);
    // multiview puts both eyes on an array swapchain's two layers in one pass (layers.rs)
    let features = exposed.features & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::MULTIVIEW);
    let device_extensions = exposed.adapter.required_device_extensions(features);
    let mut device_features = exposed
        .adapter
        .physical_device_features(&device_extensions, features);
    let family_index =
        unsafe { ash_instance.get_physical_device_queue_family_properties(physical_device) }
            .iter()
            .position(|f| {
                f.queue_flags
                    .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
            })
            .ok_or_else(|| {
                VlfError::Display(
                    "the GPU the OpenXR runtime chose has no graphics+compute queue".into(),
                )
            })? as u32;
    let priorities = [1.0f32];
    let queue_info = vk::DeviceQueueCreateInfo::default()
        .queue_family_index(family_index)
        .queue_priorities(&priorities);
    let device_extension_names: Vec<*const c_char> = device_extensions
        .iter()
        .map(|e: &&CStr| e.as_ptr())
        .collect();
    let device_info = vk::DeviceCreateInfo::default()
        .queue_create_infos(std::slice::from_ref(&queue_info))
        .enabled_extension_names(&device_extension_names);
    let device_info = device_features.add_to_device_create(device_info);
    let raw_device = unsafe {
        instance.create_vulkan_device(
            system,
            get_instance_proc_addr,
            physical_device.as_raw() as _,
            &device_info as *const _ as *const _,
        )
    }
    .map_err(|e| vk_error("xrCreateVulkanDeviceKHR", e))?
    .map_err(|r| vk_error("the runtime's vkCreateDevice", vk::Result::from_raw(r)))?;
    let raw_device = vk::Device::from_raw(raw_device as u64);
    // SAFETY: created on `ash_instance` from `physical_device`.
    let ash_device = unsafe { ash::Device::load(ash_instance.fp_v1_0(), raw_device) };
    let limits = exposed.capabilities.limits.clone();
    let open = unsafe {
        exposed.adapter.device_from_raw(
            ash_device,
            None,
            &device_extensions,
            features,
            &limits,
            &wgpu::MemoryHints::Performance,
            family_index,
            0,
        )
    }
    .map_err(|e| vk_error("wgpu on the runtime's Vulkan device", e))?;
    Ok((open, family_index, raw_device, features, limits))
}

/// Let the runtime create the Vulkan instance and device; build wgpu on them.
pub fn create(instance: &openxr::Instance, system: openxr::SystemId) -> Result<XrVulkan> {
    let vulkan = runtime_instance(instance, system)?;
    let (raw_instance, physical_device) = (vulkan.raw_instance, vulkan.physical_device);
    // SAFETY: the instance was created with `extensions` at `api_version`; wgpu-hal owns it from
    // here and destroys it last (OpenXR leaves instance and device to the application).
    let hal_instance = unsafe {
        hal::vulkan::Instance::from_raw(
            vulkan.entry.clone(),
            vulkan.ash_instance.clone(),
            vulkan.api_version,
            0,
            None,
            vulkan.extensions.clone(),
            vulkan.flags,
            wgpu::MemoryBudgetThresholds::default(),
            false,
            None,
        )
    }
    .map_err(|e| vk_error("wgpu on the runtime's Vulkan instance", e))?;
    let exposed = hal_instance
        .expose_adapter(physical_device)
        .ok_or_else(|| VlfError::Display("the GPU the OpenXR runtime chose cannot run wgpu (its Vulkan device lacks what wgpu needs)".into()))?;
    let (open, family_index, raw_device, features, limits) =
        runtime_device(instance, system, &vulkan, &exposed)?;
    // SAFETY: every handle above came from this instance; wgpu takes ownership of all of them.
    let wgpu_instance = unsafe { wgpu::Instance::from_hal::<Vulkan>(hal_instance) };
    let adapter = unsafe { wgpu_instance.create_adapter_from_hal(exposed) };
    let (device, queue) = unsafe {
        adapter.create_device_from_hal(
            open,
            &wgpu::DeviceDescriptor {
                label: Some("vlf (OpenXR)"),
                required_features: features,
                required_limits: limits,
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            },
        )
    }
    .map_err(|e| vk_error("wgpu device", e))?;
    let session_info = openxr::vulkan::SessionCreateInfo {
        instance: raw_instance.as_raw() as _,
        physical_device: physical_device.as_raw() as _,
        device: raw_device.as_raw() as _,
        queue_family_index: family_index,
        queue_index: 0,
    };
    Ok(XrVulkan {
        ctx: GpuContext::from_device(wgpu_instance, adapter, device, queue),
        session_info,
    })
}

/// The swapchain formats vlf can draw into, best first (sRGB so the runtime gets linear-light
/// blending right), as (Vulkan format, wgpu format).
pub const SWAPCHAIN_FORMATS: [(vk::Format, wgpu::TextureFormat); 4] = [
    (
        vk::Format::R8G8B8A8_SRGB,
        wgpu::TextureFormat::Rgba8UnormSrgb,
    ),
    (
        vk::Format::B8G8R8A8_SRGB,
        wgpu::TextureFormat::Bgra8UnormSrgb,
    ),
    (vk::Format::R8G8B8A8_UNORM, wgpu::TextureFormat::Rgba8Unorm),
    (vk::Format::B8G8R8A8_UNORM, wgpu::TextureFormat::Bgra8Unorm),
];

/// The depth swapchain formats vlf can write, best first, as (Vulkan format, wgpu format).
pub const DEPTH_FORMATS: [(vk::Format, wgpu::TextureFormat); 2] = [
    (vk::Format::D32_SFLOAT, wgpu::TextureFormat::Depth32Float),
    (vk::Format::D16_UNORM, wgpu::TextureFormat::Depth16Unorm),
];

/// Wrap one of the runtime's swapchain images (`layers` array layers) as a wgpu texture: a
/// colour image as render target and copy source (and copy destination where `copy_dst`: made
/// with transfer-destination usage), a depth image as depth attachment. The runtime owns the
/// image: wgpu must not destroy it.
pub fn wrap_swapchain_image(
    ctx: &GpuContext,
    image: u64,
    format: wgpu::TextureFormat,
    ([width, height], layers): ([u32; 2], u32),
    (label, copy_dst): (&str, bool),
) -> Result<wgpu::Texture> {
    let size = wgpu::Extent3d {
        width,
        height,
        depth_or_array_layers: layers,
    };
    let depth = format.is_depth_stencil_format();
    let (hal_usage, usage) = if depth {
        (
            wgpu::TextureUses::DEPTH_STENCIL_WRITE,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        )
    } else if copy_dst {
        (
            wgpu::TextureUses::COLOR_TARGET
                | wgpu::TextureUses::COPY_SRC
                | wgpu::TextureUses::COPY_DST,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
        )
    } else {
        (
            wgpu::TextureUses::COLOR_TARGET | wgpu::TextureUses::COPY_SRC,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        )
    };
    let hal_desc = hal::TextureDescriptor {
        label: Some(label),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: hal_usage,
        memory_flags: hal::MemoryFlags::empty(),
        view_formats: vec![],
    };
    // SAFETY: the image is the runtime's, created on this device with colour-attachment and
    // transfer-source usage (and transfer-destination where `copy_dst`; depth: depth-attachment)
    // and this size, layer count and format; it outlives the texture (the swapchain is destroyed
    // after the textures). The drop callback stops wgpu-hal destroying it.
    let hal_device = unsafe { ctx.device.as_hal::<Vulkan>() }
        .ok_or_else(|| VlfError::Display("the OpenXR device is not a Vulkan device".into()))?;
    let hal_texture = unsafe {
        hal_device.texture_from_raw(
            vk::Image::from_raw(image),
            &hal_desc,
            Some(Box::new(|| {})),
            hal::vulkan::TextureMemory::External,
        )
    };
    drop(hal_device);
    let desc = wgpu::TextureDescriptor {
        label: Some(label),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    };
    Ok(unsafe {
        ctx.device.create_texture_from_hal::<Vulkan>(
            hal_texture,
            &desc,
            wgpu::TextureUses::UNINITIALIZED,
        )
    })
}
