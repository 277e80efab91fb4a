//! Bind group layouts reflected from each stage's WGSL (as vello does): the shader is the one
//! declaration of its bindings, and the Rust side asks naga what group N holds instead of
//! repeating it as a positional list. A binding the shader changes (a buffer made read-write, a
//! binding added) changes the layout with it; a Rust bind group that no longer matches fails at
//! creation with wgpu's message naming the binding.

use super::shaders;
use crate::error::{Result, VlfError};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// The parsed stages and naga's analysis of them, each parsed once per process.
fn parsed_with_info(stage: &str) -> Result<&'static (naga::Module, naga::valid::ModuleInfo)> {
    type Parsed = &'static (naga::Module, naga::valid::ModuleInfo);
    static CACHE: OnceLock<Mutex<HashMap<String, Parsed>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    if let Some(m) = cache.lock().unwrap().get(stage) {
        return Ok(m);
    }
    let parsed = shaders::expand(stage)?
        .validate_with_info()
        .map_err(VlfError::Gpu)?;
    let leaked: Parsed = Box::leak(Box::new(parsed));
    cache.lock().unwrap().insert(stage.to_string(), leaked);
    Ok(leaked)
}

fn parsed(stage: &str) -> Result<&'static naga::Module> {
    parsed_with_info(stage).map(|(module, _)| module)
}

/// The stages that can see a binding: those of the module's entry points.
fn stages_of(module: &naga::Module) -> wgpu::ShaderStages {
    module
        .entry_points
        .iter()
        .fold(wgpu::ShaderStages::NONE, |s, e| {
            s | match e.stage {
                naga::ShaderStage::Vertex => wgpu::ShaderStages::VERTEX,
                naga::ShaderStage::Fragment => wgpu::ShaderStages::FRAGMENT,
                _ => wgpu::ShaderStages::COMPUTE,
            }
        })
}

fn storage_format(format: naga::StorageFormat) -> Option<wgpu::TextureFormat> {
    use naga::StorageFormat as S;
    use wgpu::TextureFormat as T;
    Some(match format {
        S::Rgba32Float => T::Rgba32Float,
        S::Rgba16Float => T::Rgba16Float,
        S::Rgba8Unorm => T::Rgba8Unorm,
        S::R32Float => T::R32Float,
        S::R32Uint => T::R32Uint,
        S::Rgba32Uint => T::Rgba32Uint,
        _ => return None,
    })
}

fn dimension(dim: naga::ImageDimension, arrayed: bool) -> wgpu::TextureViewDimension {
    use wgpu::TextureViewDimension as V;
    match (dim, arrayed) {
        (naga::ImageDimension::D1, _) => V::D1,
        (naga::ImageDimension::D2, false) => V::D2,
        (naga::ImageDimension::D2, true) => V::D2Array,
        (naga::ImageDimension::D3, _) => V::D3,
        (naga::ImageDimension::Cube, false) => V::Cube,
        (naga::ImageDimension::Cube, true) => V::CubeArray,
    }
}

/// The wgpu binding type of one WGSL global, or why it has none.
fn binding_type(
    module: &naga::Module,
    var: &naga::GlobalVariable,
) -> std::result::Result<wgpu::BindingType, String> {
    let buffer = |ty| {
        Ok(wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        })
    };
    match var.space {
        naga::AddressSpace::Uniform => buffer(wgpu::BufferBindingType::Uniform),
        naga::AddressSpace::Storage { access } => buffer(wgpu::BufferBindingType::Storage {
            read_only: !access.contains(naga::StorageAccess::STORE),
        }),
        naga::AddressSpace::Handle => match &module.types[var.ty].inner {
            naga::TypeInner::Image {
                dim,
                arrayed,
                class,
            } => image_type(*dim, *arrayed, class),
            naga::TypeInner::Sampler { comparison } => {
                Ok(wgpu::BindingType::Sampler(if *comparison {
                    wgpu::SamplerBindingType::Comparison
                } else {
                    wgpu::SamplerBindingType::Filtering
                }))
            }
            other => Err(format!("handle of type {other:?}")),
        },
        other => Err(format!("address space {other:?}")),
    }
}

fn image_type(
    dim: naga::ImageDimension,
    arrayed: bool,
    class: &naga::ImageClass,
) -> std::result::Result<wgpu::BindingType, String> {
    let view_dimension = dimension(dim, arrayed);
    match class {
        naga::ImageClass::Sampled { kind, multi } => Ok(wgpu::BindingType::Texture {
            sample_type: match kind {
                // read with textureLoad (no sampler in vlf's shaders): any float format binds
                naga::ScalarKind::Float => wgpu::TextureSampleType::Float { filterable: false },
                naga::ScalarKind::Uint => wgpu::TextureSampleType::Uint,
                naga::ScalarKind::Sint => wgpu::TextureSampleType::Sint,
                other => return Err(format!("texture of {other:?}")),
            },
            view_dimension,
            multisampled: *multi,
        }),
        naga::ImageClass::Storage { format, access } => Ok(wgpu::BindingType::StorageTexture {
            access: match (
                access.contains(naga::StorageAccess::LOAD),
                access.contains(naga::StorageAccess::STORE),
            ) {
                (true, true) => wgpu::StorageTextureAccess::ReadWrite,
                (true, false) => wgpu::StorageTextureAccess::ReadOnly,
                _ => wgpu::StorageTextureAccess::WriteOnly,
            },
            format: storage_format(*format)
                .ok_or_else(|| format!("storage texture format {format:?}"))?,
            view_dimension,
        }),
        other => Err(format!("image class {other:?}")),
    }
}

/// The entries of bind group `group` as `stage` (a file under shaders/) declares them, in
/// binding order.
pub fn layout_entries(stage: &str, group: u32) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    entries_where(stage, group, |_| true)
}

/// The entries of bind group `group` that some entry point of `stage` reads or writes: for a
/// group declared by a shared module (`common/light_field.wgsl`), of which a stage may use a
/// part (a binding in the layout counts against the device's limits whether read or not).
pub fn used_layout_entries(stage: &str, group: u32) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    let (module, info) = parsed_with_info(stage)?;
    let used = |handle: naga::Handle<naga::GlobalVariable>| {
        (0..module.entry_points.len()).any(|e| !info.get_entry_point(e)[handle].is_empty())
    };
    entries_where(stage, group, used)
}

fn entries_where(
    stage: &str,
    group: u32,
    keep: impl Fn(naga::Handle<naga::GlobalVariable>) -> bool,
) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    let module = parsed(stage)?;
    let visibility = stages_of(module);
    let mut entries = Vec::new();
    for (handle, var) in module.global_variables.iter() {
        let Some(rb) = &var.binding else { continue };
        if rb.group != group || !keep(handle) {
            continue;
        }
        let ty = binding_type(module, var).map_err(|what| {
            VlfError::Gpu(format!(
                "shaders/{stage}: @group({group}) @binding({}) {}: {what} is not supported by \
                 the layout reflection (src/gpu/reflect.rs)",
                rb.binding,
                var.name.as_deref().unwrap_or("?")
            ))
        })?;
        entries.push(wgpu::BindGroupLayoutEntry {
            binding: rb.binding,
            visibility,
            ty,
            count: None,
        });
    }
    if entries.is_empty() {
        return Err(VlfError::Gpu(format!(
            "shaders/{stage} declares nothing in @group({group})"
        )));
    }
    entries.sort_by_key(|e| e.binding);
    Ok(entries)
}

/// Bind group layout `group` of `stage`, reflected from its WGSL.
pub fn layout(device: &wgpu::Device, stage: &str, group: u32) -> Result<wgpu::BindGroupLayout> {
    let entries = layout_entries(stage, group)?;
    Ok(layout_of(device, stage, group, &entries))
}

/// A bind group layout of `entries` (from `layout_entries` or `used_layout_entries`).
pub fn layout_of(
    device: &wgpu::Device,
    stage: &str,
    group: u32,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&format!("{stage} group {group}")),
        entries,
    })
}

/// The bind group of `stage`'s global `name`: a stage that includes a shared module of bindings
/// (`common/light_field.wgsl`) chooses the group, and the driver asks the shader where it is.
pub fn group_of(stage: &str, name: &str) -> Result<u32> {
    let module = parsed(stage)?;
    (module.global_variables.iter())
        .find(|(_, var)| var.name.as_deref() == Some(name))
        .and_then(|(_, var)| var.binding.as_ref().map(|b| b.group))
        .ok_or_else(|| VlfError::Gpu(format!("shaders/{stage} binds no global named `{name}`")))
}
