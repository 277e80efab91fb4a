//! Irradiance probes baked from the converged light field (`shaders/probes.wgsl`): a grid over
//! the scene's box, each probe the radiance arriving at its point in nine spherical-harmonic
//! coefficients per colour. Moving objects, which the light field does not hold, are lit from
//! them (`common/moving_surface.wgsl`). Baked once per light field, only where a display has
//! moving objects.

use crate::error::{Result, VlfError};
use crate::gpu::types::{GpuProbeGrid, GpuView};
use crate::gpu::{reflect, shaders, GpuContext, MemoryLedger, STORAGE};
use glam::Vec3;

/// How moving objects are lit and shadow the scene: the probes that light them (how many along
/// the scene's longest side, rays each), the shadow rays of their own direct light (and of their
/// shadows on the scene per pixel), and how their shadows on the scene are drawn
/// (`render::shadow_atlas`); the display TOML's `[object_lighting]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectLighting {
    #[serde(default = "default_resolution")]
    pub probe_resolution: u32,
    /// a multiple of 64
    #[serde(default = "default_rays")]
    pub probe_rays: u32,
    /// how a moving surface takes its own direct light: once per frame at its vertices (the
    /// default), or by shadow rays per eye ray that meets it
    #[serde(default)]
    pub direct_light: DirectLightMethod,
    /// shadow rays per vertex (`direct_light = "per_vertex"`) to the emitters and to the sky
    #[serde(default = "default_vertex_shadow_samples")]
    pub vertex_shadow_samples: u32,
    #[serde(default = "default_vertex_sky_shadow_samples")]
    pub vertex_sky_shadow_samples: u32,
    /// the most shadow rays the vertices take in all per frame: more vertices take fewer each
    #[serde(default = "default_vertex_light_rays")]
    pub vertex_light_rays: u32,
    /// rays per vertex (`direct_light = "per_vertex"`) against the moving objects themselves,
    /// for what they hide of the probes' light and send instead (`render::moving_light`; 0:
    /// the probes' light as it is)
    #[serde(default = "default_occlusion_rays")]
    pub occlusion_rays: u32,
    /// shadow rays per eye ray to the emitters, each to a triangle picked by power (0: the
    /// objects cast no shadow from emitters)
    #[serde(default = "default_shadow_samples")]
    pub shadow_samples: u32,
    /// shadow rays per eye ray toward the sky, where the scene has one
    #[serde(default = "default_sky_shadow_samples")]
    pub sky_shadow_samples: u32,
    /// how the shadows on the static scene are drawn: once per frame into the shadow atlas
    /// (the default), or per pixel of every view
    #[serde(default)]
    pub shadows: ShadowMethod,
    /// the shadow atlas: shadow rays per texel to the emitters and to the sky
    #[serde(default = "default_atlas_shadow_samples")]
    pub atlas_shadow_samples: u32,
    #[serde(default = "default_atlas_sky_shadow_samples")]
    pub atlas_sky_shadow_samples: u32,
    /// the shadow atlas: the sky's shadow (contact darkening) within this many metres of the
    /// objects' boxes, fading out over its outer half
    #[serde(default = "default_sky_shadow_reach")]
    pub sky_shadow_reach: f32,
    /// the shadow atlas: rays per texel against the moving objects for the indirect light they
    /// block (the light field's radiance from the directions they cover, less what they send
    /// back; 0: none, the objects take only direct light from the scene)
    #[serde(default = "default_atlas_indirect_rays")]
    pub atlas_indirect_rays: u32,
    /// the shadow atlas: the indirect light's shadow within this many metres of the objects'
    /// boxes, fading out over its outer half
    #[serde(default = "default_indirect_shadow_reach")]
    pub indirect_shadow_reach: f32,
    /// the shadow atlas: its texels along each side of a light-field texel (1 to 4)
    #[serde(default = "default_shadow_atlas_subdivision")]
    pub shadow_atlas_subdivision: u32,
    /// the shadow atlas: texels evaluated per frame at most (faces past it take no shadow)
    #[serde(default = "default_shadow_atlas_texels")]
    pub shadow_atlas_texels: u32,
}

/// How the moving objects' shadows on the static scene are drawn: `"atlas"`, once per frame
/// into texels laid out as the light field's atlas and read by every view (its cost does not
/// grow with views or pixels), or `"per_pixel"`, shadow rays from every pair of eye rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShadowMethod {
    #[default]
    Atlas,
    PerPixel,
}

/// How a moving surface takes its own direct light (emitters and sky, shadowed by the scene
/// and the moving objects): `"per_vertex"`, once per frame at each vertex of the objects for
/// every view (`render::moving_light`), interpolated over the triangle where a ray meets it (its
/// cost follows the objects' vertices, not the views' pixels); or `"per_pixel"`, shadow rays
/// from every eye ray that meets it (sharper shadows across a large triangle).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DirectLightMethod {
    #[default]
    PerVertex,
    PerPixel,
}

fn default_vertex_shadow_samples() -> u32 {
    32
}

fn default_vertex_sky_shadow_samples() -> u32 {
    16
}

fn default_occlusion_rays() -> u32 {
    16
}

fn default_vertex_light_rays() -> u32 {
    1 << 20
}

fn default_resolution() -> u32 {
    24
}

fn default_rays() -> u32 {
    1024
}

fn default_shadow_samples() -> u32 {
    8
}

fn default_sky_shadow_samples() -> u32 {
    4
}

fn default_atlas_shadow_samples() -> u32 {
    32
}

fn default_atlas_sky_shadow_samples() -> u32 {
    16
}

fn default_sky_shadow_reach() -> f32 {
    1.0
}

fn default_atlas_indirect_rays() -> u32 {
    16
}

fn default_indirect_shadow_reach() -> f32 {
    1.0
}

fn default_shadow_atlas_subdivision() -> u32 {
    2
}

fn default_shadow_atlas_texels() -> u32 {
    1 << 22
}

impl Default for ObjectLighting {
    fn default() -> Self {
        ObjectLighting {
            probe_resolution: default_resolution(),
            probe_rays: default_rays(),
            direct_light: DirectLightMethod::default(),
            vertex_shadow_samples: default_vertex_shadow_samples(),
            vertex_sky_shadow_samples: default_vertex_sky_shadow_samples(),
            vertex_light_rays: default_vertex_light_rays(),
            occlusion_rays: default_occlusion_rays(),
            shadow_samples: default_shadow_samples(),
            sky_shadow_samples: default_sky_shadow_samples(),
            shadows: ShadowMethod::default(),
            atlas_shadow_samples: default_atlas_shadow_samples(),
            atlas_sky_shadow_samples: default_atlas_sky_shadow_samples(),
            sky_shadow_reach: default_sky_shadow_reach(),
            atlas_indirect_rays: default_atlas_indirect_rays(),
            indirect_shadow_reach: default_indirect_shadow_reach(),
            shadow_atlas_subdivision: default_shadow_atlas_subdivision(),
            shadow_atlas_texels: default_shadow_atlas_texels(),
        }
    }
}

impl ObjectLighting {
    /// The shadow rays a moving surface's own direct light takes: to the emitters and to the
    /// sky, per vertex or per eye ray as `direct_light` says.
    pub fn direct_samples(&self) -> [u32; 2] {
        match self.direct_light {
            DirectLightMethod::PerVertex => {
                [self.vertex_shadow_samples, self.vertex_sky_shadow_samples]
            }
            DirectLightMethod::PerPixel => [self.shadow_samples, self.sky_shadow_samples],
        }
    }

    /// Whether points sample direct light with shadow rays of their own in the views: a moving
    /// surface's (`direct_light = "per_pixel"`) or a shadow's (`shadows = "per_pixel"`); else
    /// the vertices and the shadow atlas carry it (`SAMPLED_DIRECT` in render.wgsl).
    pub fn samples_direct(&self) -> bool {
        self.direct_light == DirectLightMethod::PerPixel || self.shadows == ShadowMethod::PerPixel
    }

    /// What of their direct light the moving surfaces sample themselves (the probes leave it
    /// out): `gpu::types::DIRECT_EMITTERS` | `DIRECT_SKY`.
    pub(super) fn direct_sampled(&self) -> u32 {
        use crate::gpu::types::{DIRECT_EMITTERS, DIRECT_SKY};
        let [emitters, sky] = self.direct_samples();
        (if emitters > 0 { DIRECT_EMITTERS } else { 0 }) | if sky > 0 { DIRECT_SKY } else { 0 }
    }

    pub fn check(&self) -> std::result::Result<(), String> {
        let at = "[object_lighting]";
        if !(2..=128).contains(&self.probe_resolution) {
            return Err(format!(
                "{at} probe_resolution = {}: use 2 to 128",
                self.probe_resolution
            ));
        }
        let rays = self.probe_rays;
        if rays == 0 || !rays.is_multiple_of(64) || rays > 65536 {
            return Err(format!(
                "{at} probe_rays = {rays}: use a multiple of 64 up to 65536"
            ));
        }
        for (key, n) in [
            ("shadow_samples", self.shadow_samples),
            ("vertex_shadow_samples", self.vertex_shadow_samples),
            ("vertex_sky_shadow_samples", self.vertex_sky_shadow_samples),
            ("occlusion_rays", self.occlusion_rays),
            ("sky_shadow_samples", self.sky_shadow_samples),
            ("atlas_shadow_samples", self.atlas_shadow_samples),
            ("atlas_sky_shadow_samples", self.atlas_sky_shadow_samples),
            ("atlas_indirect_rays", self.atlas_indirect_rays),
        ] {
            if n > 256 {
                return Err(format!("{at} {key} = {n}: use 0 (none) to 256"));
            }
        }
        for (key, reach, what) in [
            ("sky_shadow_reach", self.sky_shadow_reach, "sky"),
            (
                "indirect_shadow_reach",
                self.indirect_shadow_reach,
                "indirect",
            ),
        ] {
            if !(reach.is_finite() && reach >= 0.0) {
                return Err(format!(
                    "{at} {key} = {reach}: use metres, 0 (no {what} shadow in the atlas) or more"
                ));
            }
        }
        let subdivision = self.shadow_atlas_subdivision;
        if !(1..=4).contains(&subdivision) {
            return Err(format!(
                "{at} shadow_atlas_subdivision = {subdivision}: use 1 (the light field's texels) to 4"
            ));
        }
        let rays = self.vertex_light_rays;
        if !(1024..=1 << 26).contains(&rays) {
            return Err(format!(
                "{at} vertex_light_rays = {rays}: use 1024 to {}",
                1 << 26
            ));
        }
        let texels = self.shadow_atlas_texels;
        if !(1024..=1 << 26).contains(&texels) {
            return Err(format!(
                "{at} shadow_atlas_texels = {texels}: use 1024 to {}",
                1 << 26
            ));
        }
        Ok(())
    }
}

/// The grid over the box `lo`..`hi` (normalised space): cells as cubic as the box allows, probes
/// at the cells' centres.
pub fn probe_grid(lo: Vec3, hi: Vec3, settings: &ObjectLighting) -> GpuProbeGrid {
    let extent = (hi - lo).max(Vec3::splat(1e-6));
    let cell = extent.max_element() / settings.probe_resolution as f32;
    let counts = (extent / cell).ceil().as_uvec3().max(glam::UVec3::splat(2));
    let spacing = extent / counts.as_vec3();
    GpuProbeGrid {
        origin: (lo + spacing * 0.5).into(),
        rays: settings.probe_rays,
        spacing: spacing.into(),
        counts: counts.into(),
        shadow_samples: settings.shadow_samples,
        sky_shadow_samples: settings.sky_shadow_samples,
        shadow_subdivision: settings.shadow_atlas_subdivision,
        vertex_light: u32::from(settings.direct_light == DirectLightMethod::PerVertex),
        direct_sampled: settings.direct_sampled(),
        ..Default::default()
    }
}

/// The baked probes: the grid (a uniform) and the coefficients, 9 vec4 per probe.
pub struct Probes {
    pub grid: GpuProbeGrid,
    pub grid_buffer: wgpu::Buffer,
    pub coefficients: wgpu::Buffer,
    /// the emitting triangles the shadows sample (`emitters`) and their alias table
    pub emitters: wgpu::Buffer,
    pub emitter_alias: wgpu::Buffer,
}

impl Probes {
    /// The moving objects' shading group (`common/moving_surface.wgsl`, group 2) for the passes
    /// that sample the objects' direct light once per frame (`render::shadow_atlas`,
    /// `render::moving_light`): `objects`' records with these probes and emitters, and the
    /// vertices' light where given (the shadow atlas reads what the objects send back from it;
    /// the vertices' own pass binds a placeholder here and writes the light in its own group).
    pub fn moving_group(
        &self,
        ctx: &GpuContext,
        layout: &wgpu::BindGroupLayout,
        objects: &super::moving::MovingObjects,
        vertex_light: Option<&wgpu::Buffer>,
    ) -> wgpu::BindGroup {
        // a placeholder, never read, where the objects carry no vertices' light
        let unread;
        let lit = match vertex_light {
            Some(buffer) => buffer,
            None => {
                unread = ctx.buffer_init(
                    &MemoryLedger::default(),
                    "moving objects: no vertices' light",
                    &[0u8; 16],
                    STORAGE,
                );
                &unread
            }
        };
        ctx.bind_group(
            layout,
            &[
                &objects.shading,
                &objects.materials,
                &self.grid_buffer,
                &self.coefficients,
                &self.emitters,
                &self.emitter_alias,
                lit,
                &objects.corners,
            ],
        )
    }
}

/// What the bake reads: the renderer's scene buffers (group 0 of probes.wgsl, as render.wgsl
/// binds them) and the light field's bind group.
pub struct BakeInputs<'a> {
    pub view: &'a GpuView,
    pub faces: &'a wgpu::Buffer,
    pub triangles: &'a wgpu::Buffer,
    pub pairs: &'a wgpu::Buffer,
    pub ray_triangles: &'a wgpu::Buffer,
    pub materials: &'a wgpu::Buffer,
    /// the light field and its layout uniform (`lightfield::bindings`)
    pub resident: &'a crate::lightfield::ResidentLightField,
    pub field: &'a wgpu::Buffer,
    pub stack: u32,
    /// some face cuts holes: the probes' rays pass through them (`ALPHA_MASKS`)
    pub cutouts: bool,
    pub emitters: &'a [crate::gpu::types::GpuEmitter],
}

/// Bake `grid`'s probes from the light field and wait for them.
pub fn bake(
    ctx: &GpuContext,
    ledger: &MemoryLedger,
    grid: GpuProbeGrid,
    inputs: &BakeInputs,
) -> Result<Probes> {
    let device = &ctx.device;
    let module = shaders::module_with(
        device,
        "probes.wgsl",
        &[
            ("PROBE_RAYS", grid.rays),
            ("PAIR_STACK", inputs.stack),
            ("ALPHA_MASKS", u32::from(inputs.cutouts)),
        ],
    )?;
    let layout = reflect::layout(device, "probes.wgsl", 0)?;
    let field_layout = crate::lightfield::bindings::layout(device, "probes.wgsl")?;
    let field = inputs.resident.bind_group(&field_layout, inputs.field);
    let pipeline = ctx.compute_pipeline(&module, "bake", &[&layout, &field_layout.layout]);
    let count = grid.counts.iter().product::<u32>();
    let uniform = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
    let view = GpuView {
        moving_root: u32::MAX,
        ..*inputs.view
    };
    let view_buffer = ctx.buffer_init(ledger, "probes: view", bytemuck::bytes_of(&view), uniform);
    let grid_buffer = ctx.buffer_init(ledger, "probes: grid", bytemuck::bytes_of(&grid), uniform);
    let coefficients = ctx.buffer_init(
        ledger,
        "probes: coefficients",
        &vec![0u8; count as usize * 9 * 16],
        STORAGE,
    );
    let group = ctx.bind_group(
        &layout,
        &[
            &view_buffer,
            inputs.faces,
            inputs.triangles,
            inputs.pairs,
            &grid_buffer,
            inputs.ray_triangles,
            &coefficients,
            inputs.materials,
        ],
    );
    // a row of at most 65535 workgroups (the limit of one dimension), one per probe
    let (x, y) = (count.min(65535), count.div_ceil(65535));
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.set_bind_group(1, &field, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    ctx.wait()
        .map_err(|e| VlfError::Gpu(format!("baking {count} irradiance probes: {e}")))?;
    // a scene without emitters (sky only) binds one that is never read (emitter_count 0): a
    // binding holds at least one record
    let none = [crate::gpu::types::GpuEmitter::default()];
    let list = match inputs.emitters.is_empty() {
        true => &none[..],
        false => inputs.emitters,
    };
    let emitters = ctx.buffer_init(
        ledger,
        "moving: emitters",
        bytemuck::cast_slice(list),
        STORAGE,
    );
    let chances: Vec<f32> = inputs.emitters.iter().map(|e| e.chance).collect();
    let emitter_alias = ctx.buffer_init(
        ledger,
        "moving: emitter alias table",
        bytemuck::cast_slice(&alias_table(&chances)),
        STORAGE,
    );
    Ok(Probes {
        grid,
        grid_buffer,
        coefficients,
        emitters,
        emitter_alias,
    })
}

/// The scene's emitting triangles as the moving objects' shadows sample them (normalised space,
/// each with its face's material emission; a map_Ke texture is not read: its face's factor is),
/// each with its share of the emitted power (radiance x area): a shadow ray picks its triangle
/// by power (`alias_table`), so a scene of many lights costs what one of few does.
pub fn emitters(lf: &crate::lightfield::LightField) -> Vec<crate::gpu::types::GpuEmitter> {
    let mut out: Vec<crate::gpu::types::GpuEmitter> = (lf.render_vertices.chunks_exact(3))
        .filter_map(|t| {
            let face = lf.faces.get(t[0].face as usize)?;
            let e = lf.materials.get(face.material as usize)?.emission;
            if e.iter().all(|c| *c <= 0.0) {
                return None;
            }
            let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(t[k].position));
            Some(crate::gpu::types::GpuEmitter {
                v0: a.into(),
                face: t[0].face,
                e1: (b - a).into(),
                e2: (c - a).into(),
                radiance: [e[0], e[1], e[2], e[0] + e[1] + e[2]],
                ..Default::default()
            })
        })
        .collect();
    let power = |e: &crate::gpu::types::GpuEmitter| {
        let area = 0.5 * Vec3::from(e.e1).cross(Vec3::from(e.e2)).length() as f64;
        area * e.radiance[3] as f64
    };
    let total: f64 = out.iter().map(power).sum();
    for e in &mut out {
        e.chance = if total > 0.0 {
            (power(e) / total) as f32
        } else {
            0.0
        };
    }
    // triangles of no area carry no power and are never picked
    out
}

/// Walker's alias table (Vose's construction) for picking emitter i with chance `chances[i]` in
/// one step: entry i is [threshold, alias as f32 bits, 0, 0]; a uniform u in [0, n) picks
/// floor(u) if its fraction is below the threshold, else the alias.
pub fn alias_table(chances: &[f32]) -> Vec<[f32; 4]> {
    let n = chances.len();
    let total: f64 = chances.iter().map(|&c| c as f64).sum();
    let mut scaled: Vec<f64> = (chances.iter())
        .map(|&c| {
            if total > 0.0 {
                c as f64 * n as f64 / total
            } else {
                1.0
            }
        })
        .collect();
    let mut table = vec![[1.0f32, 0.0, 0.0, 0.0]; n];
    for (i, t) in table.iter_mut().enumerate() {
        t[1] = f32::from_bits(i as u32);
    }
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
        table[s] = [scaled[s] as f32, f32::from_bits(l as u32), 0.0, 0.0];
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    table
}

#[cfg(test)]
mod tests {
    use super::{alias_table, ObjectLighting, ShadowMethod};

    /// The shadows' method and the atlas's settings come from `[object_lighting]`: the atlas by
    /// default, "per_pixel" on request, an unknown method refused with its name, and settings out
    /// of range named by their key.
    #[test]
    fn object_lighting_reads_the_shadow_method_and_refuses_bad_atlas_settings() {
        let read = |text: &str| toml::from_str::<ObjectLighting>(text);
        assert_eq!(read("").unwrap().shadows, ShadowMethod::Atlas);
        let per_pixel = read("shadows = \"per_pixel\"").unwrap();
        assert_eq!(per_pixel.shadows, ShadowMethod::PerPixel);
        let e = read("shadows = \"soft\"").unwrap_err().to_string();
        assert!(e.contains("soft") && e.contains("per_pixel"), "{e}");
        for (text, key) in [
            ("shadow_atlas_subdivision = 5", "shadow_atlas_subdivision"),
            ("shadow_atlas_texels = 10", "shadow_atlas_texels"),
            ("sky_shadow_reach = -1.0", "sky_shadow_reach"),
            ("atlas_shadow_samples = 1000", "atlas_shadow_samples"),
            ("indirect_shadow_reach = -2.0", "indirect_shadow_reach"),
            ("atlas_indirect_rays = 300", "atlas_indirect_rays"),
        ] {
            let e = read(text).unwrap().check().unwrap_err();
            assert!(e.contains(key), "{text}: {e}");
        }
        assert_eq!(read("").unwrap().check(), Ok(()));
    }

    /// Each entry's chance, read back from the table as the shader picks: entry i keeps its
    /// threshold of the 1/n that lands on it and hands the rest to its alias.
    #[test]
    fn the_alias_table_picks_each_emitter_with_its_chance() {
        let chances = [0.1f32, 0.6, 0.05, 0.25];
        let table = alias_table(&chances);
        let n = chances.len() as f64;
        let mut picked = [0.0f64; 4];
        for (i, t) in table.iter().enumerate() {
            picked[i] += t[0] as f64 / n;
            picked[t[1].to_bits() as usize] += (1.0 - t[0] as f64) / n;
        }
        for (p, c) in picked.iter().zip(chances) {
            assert!(
                (p - c as f64).abs() < 1e-6,
                "{picked:?} against {chances:?}"
            );
        }
    }
}
