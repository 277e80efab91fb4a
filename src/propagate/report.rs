//! The propagation summary, after the paper's Table 1: what was propagated, what it cost in
//! time and GPU memory. Printed as a table and written as JSON.

use super::transport::IterationStats;
use crate::gpu::{human_bytes, AdapterSummary};
use crate::params::PropagationParams;
use serde::Serialize;

#[derive(Clone, Debug, Serialize)]
pub struct MemoryItem {
    pub name: String,
    pub bytes: u64,
}

#[derive(Clone, Debug, Serialize)]
pub struct PropagationReport {
    pub scene: String,
    pub adapter: AdapterSummary,
    pub params: PropagationParams,
    pub directions: u32,
    pub faces: u32,
    pub triangles: u32,
    /// texels of all charts, padding included
    pub diffuse_elements: u64,
    /// tile cells of non-diffuse faces (none in a diffuse-only scene)
    pub non_diffuse_elements: u64,
    pub tile_bytes: u64,
    /// per-texel texture factors on the GPU (none in an untextured scene)
    pub texture_bytes: u64,
    /// the scene's textures on the host: kept (resolved to texel density) and at full size
    pub host_textures: crate::scene::texels::TextureMemory,
    pub layers: u64,
    pub visibility_kept_resident: bool,
    /// directions are gathered in this many batches (1: all lists resident)
    pub direction_batches: u32,
    pub directions_per_batch: u32,
    pub setup_seconds: f64,
    pub visibility_seconds: f64,
    pub visibility_gpu_ms: Option<f64>,
    pub propagation_seconds: f64,
    pub iterations: u32,
    pub final_residual: f64,
    pub converged: bool,
    /// with acceleration: the tail that was added, and what plain shooting would have needed
    pub tail: Option<super::Tail>,
    pub plain_iterations_estimate: Option<u32>,
    pub per_iteration: Vec<IterationStats>,
    pub propagation_memory_bytes: u64,
    pub propagation_memory: Vec<MemoryItem>,
    pub render_memory_bytes: u64,
    pub render_memory: Vec<MemoryItem>,
    /// how rendering shows mirrors: reflections traced per eye ray, and whether the mirror tiles
    /// stay resident to end longer chains
    pub mirror_rendering: Option<crate::lightfield::MirrorChains>,
    /// emitter triangles whose light reaches the texels directly (0: through the directions)
    pub direct_emitters: u32,
    /// mirror triangles whose virtual emitters reach the texels in closed form (0: no mirror,
    /// or mirror_direct off: then through the mirror tiles)
    pub direct_mirrors: u32,
    pub sky: bool,
    pub warnings: Vec<String>,
}

impl PropagationReport {
    pub fn table(&self) -> String {
        let mut rows = self.size_rows();
        rows.extend(self.cost_rows());
        rows.extend(self.light_rows());
        let width = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
        rows.iter()
            .map(|(k, v)| format!("  {k:<width$}  {v}\n"))
            .collect()
    }

    /// What was propagated: scene, adapter, directions, grid, elements, textures, layers.
    fn size_rows(&self) -> Vec<(String, String)> {
        vec![
            ("scene".into(), self.scene.clone()),
            (
                "adapter".into(),
                format!(
                    "{} ({}, {})",
                    self.adapter.name, self.adapter.backend, self.adapter.driver_info
                ),
            ),
            ("directions".into(), self.directions_text()),
            (
                "grid / tile".into(),
                format!(
                    "{0}x{0} cells, {1}x{1}-cell tiles",
                    self.params.grid_resolution, self.params.tile_size
                ),
            ),
            (
                "faces (triangles)".into(),
                format!("{} ({})", self.faces, self.triangles),
            ),
            (
                "diffuse elements".into(),
                format!(
                    "{} texels at {} / unit",
                    self.diffuse_elements, self.params.texel_density
                ),
            ),
            (
                "non-diffuse elements".into(),
                format!(
                    "{} ({} of tiles)",
                    self.non_diffuse_elements,
                    human_bytes(self.tile_bytes)
                ),
            ),
            ("textures".into(), self.textures_text()),
            ("visibility layers".into(), self.layers_text()),
        ]
    }

    /// What it cost: time per stage, iterations, residual, GPU memory.
    fn cost_rows(&self) -> Vec<(String, String)> {
        vec![
            ("setup".into(), format!("{:.3} s", self.setup_seconds)),
            (
                "visibility".into(),
                match self.visibility_gpu_ms {
                    Some(g) => format!("{:.3} s ({:.2} ms GPU)", self.visibility_seconds, g),
                    None => format!("{:.3} s", self.visibility_seconds),
                },
            ),
            (
                "propagation".into(),
                format!("{:.3} s", self.propagation_seconds),
            ),
            (
                "iterations".into(),
                match &self.tail {
                    Some(t) => format!(
                        "{} + geometric tail (ratio {:.4}; plain shooting would need about {})",
                        self.iterations, t.ratio, t.plain_iterations_estimate
                    ),
                    None => format!("{}", self.iterations),
                },
            ),
            (
                "final residual".into(),
                format!(
                    "{:.3e} ({})",
                    self.final_residual,
                    if self.converged {
                        format!("converged below {:.0e}", self.params.tolerance)
                    } else {
                        "iteration cap reached".into()
                    }
                ),
            ),
            (
                "GPU memory, propagating".into(),
                human_bytes(self.propagation_memory_bytes),
            ),
            (
                "GPU memory, rendering".into(),
                human_bytes(self.render_memory_bytes),
            ),
        ]
    }

    /// How light reaches the texels and the eye: direct light, mirrors when rendering, sky
    /// (the last two only when there is something to say).
    fn light_rows(&self) -> Vec<(String, String)> {
        let mut rows = vec![("direct light".into(), self.direct_light_text())];
        if let Some(m) = self.mirror_rendering.filter(|m| m.bounces > 0) {
            let tiles = if m.tiles_needed {
                "mirror tiles kept: mirrors face each other"
            } else {
                "mirror tiles freed: not needed to render"
            };
            rows.push((
                "mirrors, rendering".into(),
                format!("{} reflection(s) traced per eye ray; {tiles}", m.bounces),
            ));
        }
        if !self.sky {
            rows.push(("sky".into(), "none (black): nothing allocated".into()));
        }
        rows
    }

    fn directions_text(&self) -> String {
        if self.params.perturb > 1 {
            format!(
                "{} (geodesic n={}), {} perturbed sets in transport",
                self.directions, self.params.geodesic_frequency, self.params.perturb
            )
        } else {
            format!(
                "{} (geodesic n={})",
                self.directions, self.params.geodesic_frequency
            )
        }
    }

    fn textures_text(&self) -> String {
        if self.texture_bytes == 0 {
            return "none: nothing allocated".into();
        }
        let h = &self.host_textures;
        format!(
            "{} on the GPU; {} image(s), {} on the host ({} at full size, {} reduced to texel density)",
            human_bytes(self.texture_bytes),
            h.textures,
            human_bytes(h.kept_bytes),
            human_bytes(h.full_bytes),
            h.reduced
        )
    }

    fn layers_text(&self) -> String {
        if self.visibility_kept_resident {
            format!("{} (kept resident for all iterations)", self.layers)
        } else {
            format!(
                "{} in the largest batch: {} batches of {} directions, rebuilt every iteration",
                self.layers, self.direction_batches, self.directions_per_batch
            )
        }
    }

    fn direct_light_text(&self) -> String {
        if self.params.direct_samples == 0 {
            return "through the fixed directions (--direct-samples 0)".into();
        }
        let mirrors = if self.direct_mirrors > 0 {
            format!(
                "; mirrors' virtual emitters included ({} mirror triangle(s))",
                self.direct_mirrors
            )
        } else if self.non_diffuse_elements > 0 {
            "; mirrors' virtual emitters not included (through the mirror tiles)".into()
        } else {
            String::new()
        };
        format!(
            "{} emitter triangle(s), {} shadow rays per texel (closed form x visibility){mirrors}",
            self.direct_emitters, self.params.direct_samples
        )
    }
}

pub fn memory_items(entries: Vec<(String, u64)>) -> Vec<MemoryItem> {
    entries
        .into_iter()
        .map(|(name, bytes)| MemoryItem { name, bytes })
        .collect()
}
