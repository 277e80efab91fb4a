//! XR_KHR_vulkan_enable2: the runtime creates the application's Vulkan instance and device,
//! and allocates swapchain images on that device.

use crate::*;
use ash::vk::{self, Handle};
use openxr_sys as xr;

// ---- Vulkan (XR_KHR_vulkan_enable2) ---------------------------------------------------------

pub(crate) unsafe extern "system" fn get_vulkan_graphics_requirements2(
    instance: xr::Instance,
    _s: xr::SystemId,
    reqs: *mut xr::GraphicsRequirementsVulkanKHR,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    rt.requirements_queried = true;
    (*reqs).min_api_version_supported = xr::Version::new(1, 0, 0);
    (*reqs).max_api_version_supported = xr::Version::new(1, 3, 0);
    xr::Result::SUCCESS
}

pub(crate) unsafe fn static_fn(
    get_instance_proc_addr: Option<xr::platform::VkGetInstanceProcAddr>,
) -> Option<ash::StaticFn> {
    let gipa = get_instance_proc_addr?;
    Some(ash::StaticFn {
        get_instance_proc_addr: std::mem::transmute::<
            xr::platform::VkGetInstanceProcAddr,
            vk::PFN_vkGetInstanceProcAddr,
        >(gipa),
    })
}

pub(crate) unsafe extern "system" fn create_vulkan_instance(
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
    let Some(static_fn) = static_fn(info.pfn_get_instance_proc_addr) else {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    };
    let entry = ash::Entry::from_static_fn(static_fn.clone());
    let create_info = &*(info.vulkan_create_info as *const vk::InstanceCreateInfo);
    match entry.create_instance(create_info, None) {
        Ok(created) => {
            *vk_instance = created.handle().as_raw() as _;
            *vk_result = 0;
            rt.vulkan = Some(Vulkan {
                instance: created,
                physical_device: vk::PhysicalDevice::null(),
                device: None,
            });
            xr::Result::SUCCESS
        }
        Err(e) => {
            *vk_result = e.as_raw();
            xr::Result::SUCCESS
        }
    }
}

pub(crate) unsafe extern "system" fn get_vulkan_graphics_device2(
    instance: xr::Instance,
    info: *const xr::VulkanGraphicsDeviceGetInfoKHR,
    device: *mut xr::platform::VkPhysicalDevice,
) -> xr::Result {
    let mut rt = runtime();
    if !rt.instance_ok(instance) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    let Some(vulkan) = rt.vulkan.as_mut() else {
        return rt.violation(
            "xrGetVulkanGraphicsDevice2KHR before xrCreateVulkanInstanceKHR",
            xr::Result::ERROR_VALIDATION_FAILURE,
        );
    };
    if (*info).vulkan_instance as u64 != vulkan.instance.handle().as_raw() {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    let Ok(devices) = vulkan.instance.enumerate_physical_devices() else {
        return xr::Result::ERROR_RUNTIME_FAILURE;
    };
    // a real GPU before a software one, as a headset's runtime would pick the one the display is on
    let chosen = devices
        .iter()
        .copied()
        .find(|&d| {
            vulkan
                .instance
                .get_physical_device_properties(d)
                .device_type
                != vk::PhysicalDeviceType::CPU
        })
        .or(devices.first().copied());
    let Some(chosen) = chosen else {
        return xr::Result::ERROR_RUNTIME_FAILURE;
    };
    vulkan.physical_device = chosen;
    *device = chosen.as_raw() as _;
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn create_vulkan_device(
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
        return rt.violation(
            "xrCreateVulkanDeviceKHR before xrCreateVulkanInstanceKHR",
            xr::Result::ERROR_VALIDATION_FAILURE,
        );
    };
    if info.vulkan_physical_device as u64 != vulkan.physical_device.as_raw() {
        return rt.violation("xrCreateVulkanDeviceKHR on a physical device other than xrGetVulkanGraphicsDevice2KHR's", xr::Result::ERROR_VALIDATION_FAILURE);
    }
    let create_info = &*(info.vulkan_create_info as *const vk::DeviceCreateInfo);
    match vulkan
        .instance
        .create_device(vulkan.physical_device, create_info, None)
    {
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

// ---- swapchains -----------------------------------------------------------------------------

pub(crate) unsafe extern "system" fn enumerate_swapchain_formats(
    session: xr::Session,
    capacity: u32,
    count: *mut u32,
    out: *mut i64,
) -> xr::Result {
    if !runtime().sessions.contains_key(&session.into_raw()) {
        return xr::Result::ERROR_HANDLE_INVALID;
    }
    two_call(capacity, count, out, SWAPCHAIN_FORMATS.len(), |i, v| {
        *v = SWAPCHAIN_FORMATS[i].as_raw() as i64
    })
}

pub(crate) unsafe fn free_images(device: &ash::Device, s: &Swapchain) {
    let _ = device.device_wait_idle();
    for (image, memory) in &s.images {
        device.destroy_image(*image, None);
        device.free_memory(*memory, None);
    }
}

pub(crate) unsafe extern "system" fn create_swapchain(
    session: xr::Session,
    info: *const xr::SwapchainCreateInfo,
    swapchain: *mut xr::Swapchain,
) -> xr::Result {
    let mut rt = runtime();
    let sh = session.into_raw();
    let Some(s) = rt.sessions.get(&sh) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    let device = s.device.clone();
    let info = &*info;
    let format = vk::Format::from_raw(info.format as i32);
    if !SWAPCHAIN_FORMATS.contains(&format) {
        return xr::Result::ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED;
    }
    if info.width == 0
        || info.height == 0
        || info.width > 4096
        || info.height > 4096
        || info.sample_count != 1
        || info.face_count != 1
        || info.array_size != 1
        || info.mip_count != 1
    {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    let mut usage = vk::ImageUsageFlags::SAMPLED;
    let flags = info.usage_flags;
    for (x, v) in [
        (
            xr::SwapchainUsageFlags::COLOR_ATTACHMENT,
            vk::ImageUsageFlags::COLOR_ATTACHMENT,
        ),
        (
            xr::SwapchainUsageFlags::TRANSFER_SRC,
            vk::ImageUsageFlags::TRANSFER_SRC,
        ),
        (
            xr::SwapchainUsageFlags::TRANSFER_DST,
            vk::ImageUsageFlags::TRANSFER_DST,
        ),
        (
            xr::SwapchainUsageFlags::UNORDERED_ACCESS,
            vk::ImageUsageFlags::STORAGE,
        ),
    ] {
        if flags.contains(x) {
            usage |= v;
        }
    }
    let Some(vulkan) = rt.vulkan.as_ref() else {
        return xr::Result::ERROR_RUNTIME_FAILURE;
    };
    let memory_properties = vulkan
        .instance
        .get_physical_device_memory_properties(vulkan.physical_device);
    let mut images = Vec::new();
    for _ in 0..3 {
        let image_info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: info.width,
                height: info.height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let Ok(image) = device.create_image(&image_info, None) else {
            return xr::Result::ERROR_RUNTIME_FAILURE;
        };
        let requirements = device.get_image_memory_requirements(image);
        let Some(type_index) = (0..memory_properties.memory_type_count).find(|&i| {
            requirements.memory_type_bits & (1 << i) != 0
                && memory_properties.memory_types[i as usize]
                    .property_flags
                    .contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
        }) else {
            return xr::Result::ERROR_RUNTIME_FAILURE;
        };
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(requirements.size)
            .memory_type_index(type_index);
        let Ok(memory) = device.allocate_memory(&alloc, None) else {
            return xr::Result::ERROR_RUNTIME_FAILURE;
        };
        if device.bind_image_memory(image, memory, 0).is_err() {
            return xr::Result::ERROR_RUNTIME_FAILURE;
        }
        images.push((image, memory));
    }
    let h = rt.handle();
    rt.swapchains.insert(
        h,
        Swapchain {
            session: sh,
            images,
            size: [info.width, info.height],
            next: 0,
            acquired: VecDeque::new(),
            waited: false,
            released_since_end: false,
        },
    );
    *swapchain = xr::Swapchain::from_raw(h);
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn destroy_swapchain(swapchain: xr::Swapchain) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.remove(&swapchain.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if let Some(session) = rt.sessions.get(&s.session) {
        free_images(&session.device.clone(), &s);
    }
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn enumerate_swapchain_images(
    swapchain: xr::Swapchain,
    capacity: u32,
    count: *mut u32,
    out: *mut xr::SwapchainImageBaseHeader,
) -> xr::Result {
    let rt = runtime();
    let Some(s) = rt.swapchains.get(&swapchain.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    let out = out as *mut xr::SwapchainImageVulkanKHR;
    let images: Vec<u64> = s.images.iter().map(|(i, _)| i.as_raw()).collect();
    if capacity > 0 && (*out).ty != xr::SwapchainImageVulkanKHR::TYPE {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    two_call(capacity, count, out, images.len(), |i, v| {
        v.image = images[i]
    })
}

pub(crate) unsafe extern "system" fn acquire_swapchain_image(
    swapchain: xr::Swapchain,
    _info: *const xr::SwapchainImageAcquireInfo,
    index: *mut u32,
) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.get_mut(&swapchain.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if s.acquired.len() == s.images.len() {
        return rt.violation(
            "xrAcquireSwapchainImage with every image already acquired",
            xr::Result::ERROR_CALL_ORDER_INVALID,
        );
    }
    let i = s.next;
    s.next = (s.next + 1) % s.images.len();
    s.acquired.push_back(i);
    *index = i as u32;
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn wait_swapchain_image(
    swapchain: xr::Swapchain,
    _info: *const xr::SwapchainImageWaitInfo,
) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.get_mut(&swapchain.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if s.acquired.is_empty() || s.waited {
        return rt.violation(
            "xrWaitSwapchainImage without an acquired, unwaited image",
            xr::Result::ERROR_CALL_ORDER_INVALID,
        );
    }
    s.waited = true;
    xr::Result::SUCCESS
}

pub(crate) unsafe extern "system" fn release_swapchain_image(
    swapchain: xr::Swapchain,
    _info: *const xr::SwapchainImageReleaseInfo,
) -> xr::Result {
    let mut rt = runtime();
    let Some(s) = rt.swapchains.get_mut(&swapchain.into_raw()) else {
        return xr::Result::ERROR_HANDLE_INVALID;
    };
    if !s.waited {
        return rt.violation(
            "xrReleaseSwapchainImage before xrWaitSwapchainImage",
            xr::Result::ERROR_CALL_ORDER_INVALID,
        );
    }
    s.acquired.pop_front();
    s.waited = false;
    s.released_since_end = true;
    rt.counters.images_released += 1;
    xr::Result::SUCCESS
}
