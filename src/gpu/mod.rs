//! The GPU device and the small helpers every stage uses: buffers with a memory ledger,
//! bind group layouts, compute pipelines, read-back and timestamp queries.

pub mod reflect;
pub mod shaders;
pub mod types;

use crate::error::{Result, VlfError};
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;

/// What the report says about the adapter.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub driver: String,
    pub driver_info: String,
    pub device_type: String,
    pub software: bool,
    /// PCI bus address where the driver gives one (tells two GPUs of one name apart)
    #[serde(default)]
    pub pci_bus_id: String,
    /// which GPU was asked for (`VLF_GPU`, or a cluster rank's `[cluster] gpu`), if one was
    #[serde(default)]
    pub gpu_index: Option<usize>,
}

/// Which adapter to open.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum AdapterChoice {
    /// `VLF_GPU=N` if set, else `WGPU_ADAPTER_NAME`/`WGPU_BACKEND`, else the best adapter
    Default,
    /// the n-th hardware GPU in PCI bus order (nvidia-smi's order); `wrap`: n modulo the
    /// number of GPUs (a cluster rank on a host with fewer GPUs than ranks shares one)
    Gpu { index: usize, wrap: bool },
}

pub struct GpuContext {
    /// kept for windows' surfaces
    pub instance: wgpu::Instance,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: wgpu::Adapter,
    pub summary: AdapterSummary,
    pub timestamps: bool,
    pub timestamp_period_ns: f32,
    /// errors wgpu reported outside any call's return value (validation, out of memory)
    errors: Arc<Mutex<Vec<String>>>,
}

/// The hardware GPUs in PCI bus order (nvidia-smi's), each once: a GPU that both Vulkan and
/// GL offer is taken through Vulkan. Software adapters are not GPUs here.
async fn hardware_gpus(instance: &wgpu::Instance, backends: wgpu::Backends) -> Vec<wgpu::Adapter> {
    let mut gpus: Vec<wgpu::Adapter> = (instance.enumerate_adapters(backends).await)
        .into_iter()
        .filter(|a| {
            let info = a.get_info();
            let name = info.name.to_lowercase();
            info.device_type != wgpu::DeviceType::Cpu
                && !name.contains("llvmpipe")
                && !name.contains("lavapipe")
        })
        .collect();
    if gpus
        .iter()
        .any(|a| a.get_info().backend == wgpu::Backend::Vulkan)
    {
        gpus.retain(|a| a.get_info().backend == wgpu::Backend::Vulkan);
    }
    gpus.sort_by_key(|a| {
        let info = a.get_info();
        (info.device_pci_bus_id, info.name, info.device)
    });
    gpus
}

/// The `index`-th hardware GPU (modulo their number when `wrap`) and the index taken; None
/// when `wrap` and there is no hardware GPU (a cluster on the software adapter).
async fn nth_gpu(
    instance: &wgpu::Instance,
    backends: wgpu::Backends,
    index: usize,
    wrap: bool,
) -> Result<Option<(wgpu::Adapter, usize)>> {
    let mut gpus = hardware_gpus(instance, backends).await;
    let count = gpus.len();
    if wrap && count == 0 {
        return Ok(None);
    }
    let names: Vec<String> = (gpus.iter().enumerate())
        .map(|(i, a)| {
            format!(
                "{i}: {} ({})",
                a.get_info().name,
                a.get_info().device_pci_bus_id
            )
        })
        .collect();
    let taken = if wrap { index % count } else { index };
    if taken >= count {
        return Err(VlfError::GpuChoice(if count == 0 {
            format!("GPU {index} was asked for (VLF_GPU or [cluster] gpu), but wgpu sees no hardware GPU here; unset VLF_GPU (or set [cluster] gpu = \"default\") to use the best adapter there is")
        } else {
            format!("GPU {index} was asked for (VLF_GPU or [cluster] gpu), but this machine has {count}: {}", names.join(", "))
        }));
    }
    Ok(Some((gpus.swap_remove(taken), taken)))
}

/// An error and every cause under it, on one line each.
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        s.push_str(&format!("\n  caused by: {cause}"));
        source = cause.source();
    }
    s
}

impl GpuContext {
    /// Open the best adapter (a real GPU before a software one). `VLF_GPU=N` (the n-th GPU
    /// in PCI bus order), `WGPU_BACKEND` and `WGPU_ADAPTER_NAME` choose otherwise.
    pub fn new() -> Result<Arc<GpuContext>> {
        Self::open(AdapterChoice::Default)
    }

    /// Open the adapter `choice` names.
    pub fn open(choice: AdapterChoice) -> Result<Arc<GpuContext>> {
        let choice = match (choice, std::env::var("VLF_GPU")) {
            (AdapterChoice::Default, Ok(v)) if !v.trim().is_empty() => AdapterChoice::Gpu {
                index: v.trim().parse().map_err(|_| {
                    VlfError::GpuChoice(format!("VLF_GPU={v:?}: give a GPU's index (0, 1, ...; nvidia-smi's order) or leave it unset"))
                })?,
                wrap: false,
            },
            (choice, _) => choice,
        };
        pollster::block_on(Self::new_async(choice))
    }

    async fn new_async(choice: AdapterChoice) -> Result<Arc<GpuContext>> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::GL;
        }
        let backends = desc.backends;
        let instance = wgpu::Instance::new(desc);
        let mut gpu_index = None;
        let chosen = match choice {
            AdapterChoice::Gpu { index, wrap } => nth_gpu(&instance, backends, index, wrap).await?,
            AdapterChoice::Default => None,
        };
        let adapter = match chosen {
            Some((adapter, index)) => {
                gpu_index = Some(index);
                adapter
            }
            None => Self::default_adapter(&instance).await?,
        };
        let (device, queue) = Self::request_device(&adapter).await?;
        Ok(Self::wrap(instance, adapter, device, queue, gpu_index))
    }

    /// `WGPU_ADAPTER_NAME` / `WGPU_BACKEND`'s adapter, else the best one.
    async fn default_adapter(instance: &wgpu::Instance) -> Result<wgpu::Adapter> {
        Ok(
            match wgpu::util::initialize_adapter_from_env(instance, None).await {
                Ok(adapter) => adapter,
                Err(_) => instance
                    .request_adapter(&wgpu::RequestAdapterOptions {
                        power_preference: wgpu::PowerPreference::HighPerformance,
                        force_fallback_adapter: false,
                        compatible_surface: None,
                        ..Default::default()
                    })
                    .await
                    .map_err(|e| VlfError::NoAdapter {
                        detail: e.to_string(),
                    })?,
            },
        )
    }

    /// A device with every feature and limit vlf uses that the adapter offers.
    async fn request_device(adapter: &wgpu::Adapter) -> Result<(wgpu::Device, wgpu::Queue)> {
        let supported = adapter.features();
        let timestamps = supported.contains(wgpu::Features::TIMESTAMP_QUERY);
        let mut required_features = wgpu::Features::empty();
        if timestamps {
            required_features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        // MSAA counts past the guaranteed 4x for raster first hits (render::raster)
        required_features |= supported & wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
        // Ask for everything the adapter offers: big scenes need big storage bindings.
        let required_limits = adapter.limits();
        adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("vlf"),
                required_features,
                required_limits,
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| VlfError::Device(e.to_string()))
    }

    /// Wrap a device opened elsewhere (an OpenXR runtime's Vulkan device, see
    /// `xr::vulkan`): the same error sink and adapter summary as `new`.
    pub fn from_device(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
    ) -> Arc<GpuContext> {
        Self::wrap(instance, adapter, device, queue, None)
    }

    fn wrap(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        gpu_index: Option<usize>,
    ) -> Arc<GpuContext> {
        let info = adapter.get_info();
        let software = info.device_type == wgpu::DeviceType::Cpu
            || info.name.to_lowercase().contains("llvmpipe")
            || info.name.to_lowercase().contains("lavapipe");
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let timestamp_period_ns = queue.get_timestamp_period();
        let errors: Arc<Mutex<Vec<String>>> = Default::default();
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let text = match &e {
                wgpu::Error::Validation { description, .. } => description.clone(),
                wgpu::Error::OutOfMemory { .. } => "the GPU ran out of memory".into(),
                other => error_chain(other),
            };
            sink.lock().unwrap().push(text);
        }));
        let summary = AdapterSummary {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
            device_type: format!("{:?}", info.device_type),
            software,
            pci_bus_id: info.device_pci_bus_id.clone(),
            gpu_index,
        };
        Arc::new(GpuContext {
            instance,
            device,
            queue,
            adapter,
            summary,
            timestamps,
            timestamp_period_ns,
            errors,
        })
    }

    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// Refuse a buffer that would not fit one binding, before allocating anything.
    pub fn check_binding(&self, what: &str, bytes: u64, advice: &str) -> Result<()> {
        let limits = self.limits();
        let max = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        if bytes > max {
            return Err(VlfError::GpuBudget(format!(
                "{what} needs {} but this adapter binds at most {}; {advice}",
                human_bytes(bytes),
                human_bytes(max)
            )));
        }
        Ok(())
    }

    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| VlfError::Gpu(e.to_string()))?;
        self.check_errors()
    }

    /// Wait for the GPU by polling, without sleeping: for the frame loops of displays that must
    /// not miss a refresh. A thread that sleeps until the GPU is done is woken by the OS when it
    /// gets to it: on the H100 machine 1 to 4 ms late in one frame of twenty (the CAVE's CPU+GPU
    /// frame p99 8.2 ms against a GPU time held at 6.25).
    /// On a software adapter (lavapipe) it waits as `wait` does: there the GPU is the CPU, and a
    /// spinning thread would take a core from it.
    pub fn wait_spinning(&self) -> Result<()> {
        if self.summary.software {
            return self.wait();
        }
        loop {
            let status = (self.device.poll(wgpu::PollType::Poll))
                .map_err(|e| VlfError::Gpu(e.to_string()))?;
            if status.is_queue_empty() {
                break;
            }
            std::hint::spin_loop();
        }
        self.check_errors()
    }

    /// Turn errors wgpu reported asynchronously into an error of ours.
    pub fn check_errors(&self) -> Result<()> {
        let mut errors = self.errors.lock().unwrap();
        if errors.is_empty() {
            return Ok(());
        }
        let all = errors.drain(..).collect::<Vec<_>>().join("\n");
        Err(VlfError::Gpu(all))
    }

    /// Copy a buffer back to the CPU.
    pub fn read_buffer<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        bytes: u64,
    ) -> Result<Vec<T>> {
        if bytes == 0 {
            return Ok(Vec::new());
        }
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, bytes);
        self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|e| VlfError::Gpu(e.to_string()))?
            .map_err(|e| VlfError::Gpu(format!("read-back failed: {e}")))?;
        let data = {
            let view = staging
                .get_mapped_range(..)
                .map_err(|e| VlfError::Gpu(e.to_string()))?;
            bytemuck::cast_slice::<u8, T>(&view).to_vec()
        };
        staging.unmap();
        Ok(data)
    }

    pub fn compute_pipeline(
        &self,
        module: &wgpu::ShaderModule,
        entry: &str,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> wgpu::ComputePipeline {
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> =
            layouts.iter().map(|l| Some(*l)).collect();
        let layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &layouts,
                immediate_size: 0,
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    pub fn bind_group(
        &self,
        layout: &wgpu::BindGroupLayout,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout,
            entries: &entries,
        })
    }
}

/// Named GPU allocations, so that reports can say what memory each stage used.
#[derive(Clone, Default)]
pub struct MemoryLedger {
    inner: Arc<Mutex<Vec<(String, u64)>>>,
}

impl MemoryLedger {
    pub fn record(&self, name: &str, bytes: u64) {
        self.inner.lock().unwrap().push((name.to_string(), bytes));
    }
    /// A buffer that took the place of an earlier one of the same name (which is freed).
    pub fn replace(&self, name: &str, bytes: u64) {
        let mut entries = self.inner.lock().unwrap();
        match entries.iter_mut().find(|(n, _)| n == name) {
            Some(entry) => entry.1 = bytes,
            None => entries.push((name.to_string(), bytes)),
        }
    }

    pub fn total(&self) -> u64 {
        self.inner.lock().unwrap().iter().map(|(_, b)| b).sum()
    }
    pub fn entries(&self) -> Vec<(String, u64)> {
        self.inner.lock().unwrap().clone()
    }
}

pub const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

impl GpuContext {
    /// A storage buffer holding `data`, recorded in `ledger`. Empty data still gets 16 bytes,
    /// since bindings cannot be empty.
    pub fn buffer_init(
        &self,
        ledger: &MemoryLedger,
        name: &str,
        data: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        let padded;
        let contents = if data.len() < 16 {
            padded = {
                let mut v = data.to_vec();
                v.resize(16, 0);
                v
            };
            &padded[..]
        } else {
            data
        };
        ledger.record(name, contents.len() as u64);
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(name),
                contents,
                usage,
            })
    }

    /// A zeroed buffer of `bytes`, recorded in `ledger`.
    pub fn buffer_zeroed(
        &self,
        ledger: &MemoryLedger,
        name: &str,
        bytes: u64,
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        let size = bytes.max(16).next_multiple_of(4);
        ledger.record(name, size);
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(name),
            size,
            usage,
            mapped_at_creation: false,
        })
    }
}

/// One timestamp pair spanning several passes: its beginning written by the first, its end by the
/// last, nothing by those between.
#[derive(Clone, Copy)]
pub struct PairSpan<'q> {
    pub query_set: &'q wgpu::QuerySet,
    pub begin: u32,
    pub end: u32,
}

impl<'q> PairSpan<'q> {
    /// Pass `k` of the span (`last`: the index of its last pass): the indices it writes, or None
    /// for a pass between the first and the last.
    fn writes(&self, k: usize, last: usize) -> Option<(Option<u32>, Option<u32>)> {
        let (first, ending) = (k == 0, k == last);
        (first || ending).then_some((first.then_some(self.begin), ending.then_some(self.end)))
    }

    /// Compute pass `k`'s timestamp writes (see `writes`).
    pub fn compute(&self, k: usize, last: usize) -> Option<wgpu::ComputePassTimestampWrites<'q>> {
        let (begin, end) = self.writes(k, last)?;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: self.query_set,
            beginning_of_pass_write_index: begin,
            end_of_pass_write_index: end,
        })
    }

    /// Render pass `k`'s timestamp writes (see `writes`).
    pub fn render(&self, k: usize, last: usize) -> Option<wgpu::RenderPassTimestampWrites<'q>> {
        let (begin, end) = self.writes(k, last)?;
        Some(wgpu::RenderPassTimestampWrites {
            query_set: self.query_set,
            beginning_of_pass_write_index: begin,
            end_of_pass_write_index: end,
        })
    }
}

/// Pairs of GPU timestamps around passes, resolved to milliseconds.
pub struct Timestamps {
    pub query_set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    capacity: u32,
    used: u32,
}

impl Timestamps {
    pub fn new(ctx: &GpuContext, pairs: u32) -> Option<Timestamps> {
        if !ctx.timestamps {
            return None;
        }
        let capacity = pairs * 2;
        let query_set = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let resolve = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamp resolve"),
            size: capacity as u64 * 8,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(Timestamps {
            query_set,
            resolve,
            capacity,
            used: 0,
        })
    }

    /// The next pair as a span over several passes (`PairSpan`), or None when full.
    pub fn next_span(&mut self) -> Option<PairSpan<'_>> {
        let (begin, end) = self.next_pair()?;
        Some(PairSpan {
            query_set: &self.query_set,
            begin,
            end,
        })
    }

    /// The next pair of query indices, or None when full.
    pub fn next_pair(&mut self) -> Option<(u32, u32)> {
        if self.used + 2 > self.capacity {
            return None;
        }
        let pair = (self.used, self.used + 1);
        self.used += 2;
        Some(pair)
    }

    pub fn compute_writes(&mut self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let (a, b) = self.next_pair()?;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(a),
            end_of_pass_write_index: Some(b),
        })
    }

    pub fn render_writes(&mut self) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let (a, b) = self.next_pair()?;
        Some(wgpu::RenderPassTimestampWrites {
            query_set: &self.query_set,
            beginning_of_pass_write_index: Some(a),
            end_of_pass_write_index: Some(b),
        })
    }

    /// Resolve every pair written so far into `readback` (a buffer of at least 16 bytes a
    /// pair) from within `encoder`, and start over: the number of pairs it will hold.
    pub fn resolve_into(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        readback: &wgpu::Buffer,
    ) -> u32 {
        let used = self.used;
        if used > 0 {
            encoder.resolve_query_set(&self.query_set, 0..used, &self.resolve, 0);
            encoder.copy_buffer_to_buffer(&self.resolve, 0, readback, 0, used as u64 * 8);
        }
        self.used = 0;
        used / 2
    }

    /// Resolve every pair written so far into milliseconds and start over.
    pub fn read_ms(&mut self, ctx: &GpuContext) -> Result<Vec<f64>> {
        let ticks = self.read_ticks(ctx)?;
        Ok(pairs_ms(&ticks, ctx.timestamp_period_ns))
    }

    /// Resolve every pair written so far and start over: the GPU clock's raw counts, two a pair
    /// (a frame's span runs from its first pass's start to its last pass's end).
    pub fn read_ticks(&mut self, ctx: &GpuContext) -> Result<Vec<u64>> {
        if self.used == 0 {
            return Ok(Vec::new());
        }
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.resolve_query_set(&self.query_set, 0..self.used, &self.resolve, 0);
        ctx.queue.submit([encoder.finish()]);
        let ticks: Vec<u64> = ctx.read_buffer(&self.resolve, self.used as u64 * 8)?;
        self.used = 0;
        Ok(ticks)
    }
}

/// Timestamp pairs' raw counts (two a pair) as each pair's milliseconds, at `period_ns` a count.
pub fn pairs_ms(ticks: &[u64], period_ns: f32) -> Vec<f64> {
    (ticks.chunks(2))
        .map(|p| p[1].wrapping_sub(p[0]) as f64 * period_ns as f64 * 1e-6)
        .collect()
}

/// Record a copy of a whole 2D texture into `buffer`, rows `padded_row` bytes apart (a multiple
/// of wgpu::COPY_BYTES_PER_ROW_ALIGNMENT).
pub fn copy_texture_to_buffer(
    encoder: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    buffer: &wgpu::Buffer,
    padded_row: u32,
    [width, height]: [u32; 2],
) {
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer,
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
}

pub fn human_bytes(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.2} GiB", b / (1024.0 * 1024.0 * 1024.0))
    } else if b >= 1024.0 * 1024.0 {
        format!("{:.1} MiB", b / (1024.0 * 1024.0))
    } else if b >= 1024.0 {
        format!("{:.1} KiB", b / 1024.0)
    } else {
        format!("{bytes} B")
    }
}
