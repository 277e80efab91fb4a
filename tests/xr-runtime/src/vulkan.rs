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
    let formats: Vec<vk::Format> = SWAPCHAIN_FORMATS
        .iter()
        .copied()
        .chain([DEPTH_FORMAT])
        .collect();
    two_call(capacity, count, out, formats.len(), |i, v| {
        *v = formats[i].as_raw() as i64
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
    let depth = format == DEPTH_FORMAT;
    if !SWAPCHAIN_FORMATS.contains(&format) && !depth {
        return xr::Result::ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED;
    }
    if info.width == 0
        || info.height == 0
        || info.width > 4096
        || info.height > 4096
        || info.sample_count != 1
        || info.face_count != 1
        || !(1..=16).contains(&info.array_size)
        || info.mip_count != 1
    {
        return xr::Result::ERROR_VALIDATION_FAILURE;
    }
    if info.array_size > 1 && std::env::var_os("VLF_TEST_XR_NO_ARRAY").is_some() {
        rt.counters.arrays_refused += 1;
        return xr::Result::ERROR_FEATURE_UNSUPPORTED;
    }
    let flags = info.usage_flags;
    // a runtime whose images take no copies (the application's compute colour path falls back)
    if flags.contains(xr::SwapchainUsageFlags::TRANSFER_DST)
        && std::env::var_os("VLF_TEST_XR_NO_COPY_DST").is_some()
    {
        return xr::Result::ERROR_FEATURE_UNSUPPORTED;
    }
    let (attachment, other) = if depth {
        (
            xr::SwapchainUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            xr::SwapchainUsageFlags::COLOR_ATTACHMENT,
        )
    } else {
        (
            xr::SwapchainUsageFlags::COLOR_ATTACHMENT,
            xr::SwapchainUsageFlags::DEPTH_STENCIL_ATTACHMENT,
        )
    };
    if !flags.contains(attachment) || flags.contains(other) {
        return rt.violation(
            &format!("xrCreateSwapchain: {format:?} with usage {flags:?}"),
            xr::Result::ERROR_VALIDATION_FAILURE,
        );
    }
    // depth images are read back by the runtime (the depth check): transfer source
    let mut usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_SRC;
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
        (
            xr::SwapchainUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
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
            .array_layers(info.array_size)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let Ok(image) = device.create_image(&image_info, None) else {
            return xr::Result::ERROR_RUNTIME_FAILURE;
        };
        let requirements = device.get_image_memory_requirements(image);
        let local = vk::MemoryPropertyFlags::DEVICE_LOCAL;
        let Some(type_index) = memory_type(&memory_properties, &requirements, local) else {
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
    if depth {
        rt.counters.depth_swapchains.push(info.array_size);
    } else {
        rt.counters.colour_swapchains.push(info.array_size);
    }
    rt.swapchains.insert(
        h,
        Swapchain {
            session: sh,
            images,
            size: [info.width, info.height],
            layers: info.array_size,
            depth,
            last_released: None,
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
    let handle = swapchain.into_raw();
    let shows_depth = rt
        .last_depth
        .iter()
        .flatten()
        .any(|&(chain, _)| chain == handle);
    if shows_depth && rt.counters.depth_left.is_none() {
        crate::session::check_eye_depths(&mut rt);
    }
    let Some(s) = rt.swapchains.remove(&handle) else {
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
    s.last_released = s.acquired.pop_front();
    s.waited = false;
    s.released_since_end = true;
    rt.counters.images_released += 1;
    xr::Result::SUCCESS
}

/// The first memory type `requirements` allow that has all of `flags`.
fn memory_type(
    props: &vk::PhysicalDeviceMemoryProperties,
    requirements: &vk::MemoryRequirements,
    flags: vk::MemoryPropertyFlags,
) -> Option<u32> {
    (0..props.memory_type_count).find(|&i| {
        requirements.memory_type_bits & (1 << i) != 0
            && props.memory_types[i as usize]
                .property_flags
                .contains(flags)
    })
}

// ---- depth read-back ------------------------------------------------------------------------

/// The depth values (DEPTH_FORMAT, f32) of layer `layer` of swapchain `chain`'s last released
/// image, copied on the application's queue after the work it submitted. The image is in
/// DEPTH_STENCIL_ATTACHMENT_OPTIMAL, as the application must release a depth image, and is left so.
pub(crate) unsafe fn read_depth(rt: &Runtime, chain: u64, layer: u32) -> Result<Vec<f32>, String> {
    let s = rt.swapchains.get(&chain).ok_or("unknown swapchain")?;
    let session = rt.sessions.get(&s.session).ok_or("unknown session")?;
    let vulkan = rt.vulkan.as_ref().ok_or("no Vulkan instance")?;
    let image = s.images[s.last_released.ok_or("no image released")?].0;
    let device = &session.device;
    let [w, h] = s.size;
    let bytes = w as u64 * h as u64 * 4;
    let e = |what: &str| {
        let what = what.to_string();
        move |r: vk::Result| format!("{what}: {r}")
    };
    let buffer_info = vk::BufferCreateInfo::default()
        .size(bytes)
        .usage(vk::BufferUsageFlags::TRANSFER_DST);
    let buffer = device
        .create_buffer(&buffer_info, None)
        .map_err(e("buffer"))?;
    let requirements = device.get_buffer_memory_requirements(buffer);
    let props = vulkan
        .instance
        .get_physical_device_memory_properties(vulkan.physical_device);
    let host = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
    let type_index = memory_type(&props, &requirements, host).ok_or("no host-visible memory")?;
    let alloc = vk::MemoryAllocateInfo::default()
        .allocation_size(requirements.size)
        .memory_type_index(type_index);
    let memory = device.allocate_memory(&alloc, None).map_err(e("memory"))?;
    device
        .bind_buffer_memory(buffer, memory, 0)
        .map_err(e("bind"))?;
    let pool_info = vk::CommandPoolCreateInfo::default().queue_family_index(session.queue.0);
    let pool = device
        .create_command_pool(&pool_info, None)
        .map_err(e("command pool"))?;
    let result = copy_depth(device, session.queue, pool, (image, layer, [w, h]), buffer);
    let values = result.and_then(|()| {
        let mapped = device
            .map_memory(memory, 0, bytes, vk::MemoryMapFlags::empty())
            .map_err(e("map"))?;
        let values = std::slice::from_raw_parts(mapped as *const f32, (w * h) as usize).to_vec();
        device.unmap_memory(memory);
        Ok(values)
    });
    device.destroy_command_pool(pool, None);
    device.destroy_buffer(buffer, None);
    device.free_memory(memory, None);
    values
}

unsafe fn copy_depth(
    device: &ash::Device,
    (family, index): (u32, u32),
    pool: vk::CommandPool,
    (image, layer, [w, h]): (vk::Image, u32, [u32; 2]),
    buffer: vk::Buffer,
) -> Result<(), String> {
    let e = |what: &'static str| move |r: vk::Result| format!("{what}: {r}");
    let alloc = vk::CommandBufferAllocateInfo::default()
        .command_pool(pool)
        .level(vk::CommandBufferLevel::PRIMARY)
        .command_buffer_count(1);
    let cmd = device
        .allocate_command_buffers(&alloc)
        .map_err(e("command buffer"))?[0];
    let begin =
        vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
    device
        .begin_command_buffer(cmd, &begin)
        .map_err(e("begin"))?;
    let range = vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::DEPTH,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: layer,
        layer_count: 1,
    };
    let barrier = |old, new, src, dst| {
        vk::ImageMemoryBarrier::default()
            .old_layout(old)
            .new_layout(new)
            .src_access_mask(src)
            .dst_access_mask(dst)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range)
    };
    let attachment = vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    let to_copy = barrier(
        attachment,
        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        vk::AccessFlags::MEMORY_WRITE,
        vk::AccessFlags::TRANSFER_READ,
    );
    let all = vk::PipelineStageFlags::ALL_COMMANDS;
    let transfer = vk::PipelineStageFlags::TRANSFER;
    let none = vk::DependencyFlags::empty();
    device.cmd_pipeline_barrier(cmd, all, transfer, none, &[], &[], &[to_copy]);
    let region = vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::DEPTH,
            mip_level: 0,
            base_array_layer: layer,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width: w,
            height: h,
            depth: 1,
        });
    let src = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
    device.cmd_copy_image_to_buffer(cmd, image, src, buffer, &[region]);
    let back = barrier(
        src,
        attachment,
        vk::AccessFlags::TRANSFER_READ,
        vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE,
    );
    device.cmd_pipeline_barrier(cmd, transfer, all, none, &[], &[], &[back]);
    device.end_command_buffer(cmd).map_err(e("end"))?;
    let queue = device.get_device_queue(family, index);
    let fence = device
        .create_fence(&vk::FenceCreateInfo::default(), None)
        .map_err(e("fence"))?;
    let cmds = [cmd];
    let submit = vk::SubmitInfo::default().command_buffers(&cmds);
    let done = device
        .queue_submit(queue, &[submit], fence)
        .and_then(|()| device.wait_for_fences(&[fence], true, u64::MAX))
        .map_err(e("submit"));
    device.destroy_fence(fence, None);
    done
}
