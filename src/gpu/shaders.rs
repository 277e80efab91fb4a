//! WGSL sources, embedded in the binary, with a tiny `#include "file"` preprocessor that keeps a
//! line map so that naga's errors point at the original file and line.

use crate::error::{Result, VlfError};

/// Every shader file under `shaders/`, by its path relative to that folder.
pub const SOURCES: &[(&str, &str)] = &[
    (
        "common/types.wgsl",
        include_str!("../../shaders/common/types.wgsl"),
    ),
    (
        "common/atlas.wgsl",
        include_str!("../../shaders/common/atlas.wgsl"),
    ),
    (
        "common/directions.wgsl",
        include_str!("../../shaders/common/directions.wgsl"),
    ),
    (
        "common/bsdf.wgsl",
        include_str!("../../shaders/common/bsdf.wgsl"),
    ),
    (
        "common/light_field.wgsl",
        include_str!("../../shaders/common/light_field.wgsl"),
    ),
    (
        "common/upstream.wgsl",
        include_str!("../../shaders/common/upstream.wgsl"),
    ),
    (
        "common/ray.wgsl",
        include_str!("../../shaders/common/ray.wgsl"),
    ),
    (
        "common/bvh.wgsl",
        include_str!("../../shaders/common/bvh.wgsl"),
    ),
    (
        "visibility.wgsl",
        include_str!("../../shaders/visibility.wgsl"),
    ),
    (
        "propagate.wgsl",
        include_str!("../../shaders/propagate.wgsl"),
    ),
    ("direct.wgsl", include_str!("../../shaders/direct.wgsl")),
    ("specular.wgsl", include_str!("../../shaders/specular.wgsl")),
    (
        "accumulate.wgsl",
        include_str!("../../shaders/accumulate.wgsl"),
    ),
    (
        "normalize.wgsl",
        include_str!("../../shaders/normalize.wgsl"),
    ),
    ("texture.wgsl", include_str!("../../shaders/texture.wgsl")),
    (
        "reference.wgsl",
        include_str!("../../shaders/reference.wgsl"),
    ),
    (
        "common/textures.wgsl",
        include_str!("../../shaders/common/textures.wgsl"),
    ),
    (
        "common/coverage.wgsl",
        include_str!("../../shaders/common/coverage.wgsl"),
    ),
    (
        "common/bilinear.wgsl",
        include_str!("../../shaders/common/bilinear.wgsl"),
    ),
    (
        "common/normal_map.wgsl",
        include_str!("../../shaders/common/normal_map.wgsl"),
    ),
    (
        "common/texture_cutouts.wgsl",
        include_str!("../../shaders/common/texture_cutouts.wgsl"),
    ),
    (
        "common/packed_cutouts.wgsl",
        include_str!("../../shaders/common/packed_cutouts.wgsl"),
    ),
    (
        "common/sampling.wgsl",
        include_str!("../../shaders/common/sampling.wgsl"),
    ),
    (
        "common/scene_cast.wgsl",
        include_str!("../../shaders/common/scene_cast.wgsl"),
    ),
    (
        "common/irradiance.wgsl",
        include_str!("../../shaders/common/irradiance.wgsl"),
    ),
    (
        "common/moving_surface.wgsl",
        include_str!("../../shaders/common/moving_surface.wgsl"),
    ),
    (
        "common/moving_shadow.wgsl",
        include_str!("../../shaders/common/moving_shadow.wgsl"),
    ),
    (
        "common/arriving.wgsl",
        include_str!("../../shaders/common/arriving.wgsl"),
    ),
    ("render.wgsl", include_str!("../../shaders/render.wgsl")),
    (
        "shadow_atlas.wgsl",
        include_str!("../../shaders/shadow_atlas.wgsl"),
    ),
    (
        "visibility_raster.wgsl",
        include_str!("../../shaders/visibility_raster.wgsl"),
    ),
    ("moving.wgsl", include_str!("../../shaders/moving.wgsl")),
    (
        "moving_light.wgsl",
        include_str!("../../shaders/moving_light.wgsl"),
    ),
    ("probes.wgsl", include_str!("../../shaders/probes.wgsl")),
    ("present.wgsl", include_str!("../../shaders/present.wgsl")),
    (
        "common/fullscreen.wgsl",
        include_str!("../../shaders/common/fullscreen.wgsl"),
    ),
    (
        "common/srgb.wgsl",
        include_str!("../../shaders/common/srgb.wgsl"),
    ),
    (
        "common/eye_colour.wgsl",
        include_str!("../../shaders/common/eye_colour.wgsl"),
    ),
    (
        "common/eye_layer.wgsl",
        include_str!("../../shaders/common/eye_layer.wgsl"),
    ),
    ("xr_eye.wgsl", include_str!("../../shaders/xr_eye.wgsl")),
    (
        "xr_multiview.wgsl",
        include_str!("../../shaders/xr_multiview.wgsl"),
    ),
    (
        "xr_colour.wgsl",
        include_str!("../../shaders/xr_colour.wgsl"),
    ),
    ("warp.wgsl", include_str!("../../shaders/warp.wgsl")),
];

/// The stages compiled into pipelines (the `common/` files are only included).
pub const STAGES: &[&str] = &[
    "visibility.wgsl",
    "propagate.wgsl",
    "direct.wgsl",
    "specular.wgsl",
    "accumulate.wgsl",
    "normalize.wgsl",
    "texture.wgsl",
    "render.wgsl",
    "visibility_raster.wgsl",
    "moving.wgsl",
    "probes.wgsl",
    "shadow_atlas.wgsl",
    "moving_light.wgsl",
    "present.wgsl",
    "xr_eye.wgsl",
    "xr_multiview.wgsl",
    "xr_colour.wgsl",
    "warp.wgsl",
    "reference.wgsl",
];

/// A stage's source with its includes expanded, and for each output line its origin.
pub struct ExpandedShader {
    pub name: String,
    pub source: String,
    pub line_origin: Vec<(String, usize)>,
}

/// A shader file's text: the embedded copy, or with `VLF_SHADER_DIR` set (shader experiments on
/// a machine without a Rust toolchain: one binary, several variants) the file of that name in
/// that folder where there is one.
fn raw_source(name: &str) -> Result<std::borrow::Cow<'static, str>> {
    if let Some(dir) = std::env::var_os("VLF_SHADER_DIR") {
        let path = std::path::Path::new(&dir).join(name);
        if path.exists() {
            return std::fs::read_to_string(&path)
                .map(Into::into)
                .map_err(|e| VlfError::Gpu(format!("VLF_SHADER_DIR: {}: {e}", path.display())));
        }
    }
    SOURCES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| (*s).into())
        .ok_or_else(|| VlfError::Gpu(format!("shader {name} is not embedded")))
}

pub fn expand(name: &str) -> Result<ExpandedShader> {
    let mut out = ExpandedShader {
        name: name.to_string(),
        source: String::new(),
        line_origin: Vec::new(),
    };
    expand_into(name, &mut out, 0)?;
    Ok(out)
}

fn expand_into(name: &str, out: &mut ExpandedShader, depth: usize) -> Result<()> {
    if depth > 8 {
        return Err(VlfError::Gpu(format!(
            "shaders/{name}: #include nested too deeply"
        )));
    }
    for (index, line) in raw_source(name)?.lines().enumerate() {
        if let Some(rest) = line.trim().strip_prefix("#include") {
            let included = rest.trim().trim_matches('"');
            expand_into(included, out, depth + 1)?;
        } else {
            out.source.push_str(line);
            out.source.push('\n');
            out.line_origin.push((name.to_string(), index + 1));
        }
    }
    Ok(())
}

impl ExpandedShader {
    /// Parse and validate with naga; errors name the original file and line.
    pub fn validate(&self) -> std::result::Result<naga::Module, String> {
        self.validate_with_info().map(|(module, _)| module)
    }

    /// `validate`, with naga's analysis of the module (which globals each entry point uses).
    pub fn validate_with_info(
        &self,
    ) -> std::result::Result<(naga::Module, naga::valid::ModuleInfo), String> {
        let module = naga::front::wgsl::parse_str(&self.source).map_err(|e| {
            let location = e
                .location(&self.source)
                .map(|l| self.origin(l.line_number as usize));
            format!(
                "{}: {}",
                location.unwrap_or_else(|| format!("shaders/{}", self.name)),
                e.emit_to_string(&self.source)
            )
        })?;
        // multiview (view_index, xr_multiview.wgsl) is allowed here; a device without it
        // refuses the module, and vlf compiles that stage only where the device has it
        let mut validator = naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default() | naga::valid::Capabilities::MULTIVIEW,
        );
        let info = validator.validate(&module).map_err(|e| {
            let location = e
                .location(&self.source)
                .map(|l| self.origin(l.line_number as usize));
            format!(
                "{}: {}",
                location.unwrap_or_else(|| format!("shaders/{}", self.name)),
                e.emit_to_string(&self.source)
            )
        })?;
        Ok((module, info))
    }

    fn origin(&self, line: usize) -> String {
        match self.line_origin.get(line.saturating_sub(1)) {
            Some((file, l)) => format!("shaders/{file}:{l}"),
            None => format!("shaders/{}:{line}", self.name),
        }
    }
}

/// Compile a stage into a wgpu shader module.
pub fn module(device: &wgpu::Device, name: &str) -> Result<wgpu::ShaderModule> {
    module_with(device, name, &[])
}

/// The same, with module-scope `const NAME: u32 = ...;` declarations given other values: sizes
/// WGSL cannot take from an `override` (a function's array length) chosen per scene.
pub fn module_with(
    device: &wgpu::Device,
    name: &str,
    constants: &[(&str, u32)],
) -> Result<wgpu::ShaderModule> {
    let mut expanded = expand(name)?;
    for (constant, value) in constants {
        let declaration = format!("const {constant}: u32 = ");
        let line = expanded
            .source
            .lines()
            .find(|l| l.starts_with(&declaration))
            .ok_or_else(|| VlfError::Gpu(format!("shaders/{name} declares no {declaration}")))?
            .to_string();
        expanded.source = expanded
            .source
            .replace(&line, &format!("{declaration}{value}u;"));
    }
    Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(name),
        source: wgpu::ShaderSource::Wgsl(expanded.source.into()),
    }))
}
