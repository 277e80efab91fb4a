//! The propagation summary, after the paper's Table 1: what was propagated, what it cost in
//! time and GPU memory, and where the light went (the power balance). Printed as a table and
//! written as JSON.

use super::transport::{IterationStats, PowerAccount};
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
    /// faces with a specular part too small for tiles
    /// (`prepare::packing::SPECULAR_TILES_MIN_AREA`), whose specular light propagation sends
    /// on as diffuse light
    pub specular_faces_without_tiles: u64,
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
    /// the setup's steps and their seconds: preparing the faces, the BVH and the atlas
    /// (`PreparedScene::laps`), then the propagator's buffers, pipelines, direct light, texel
    /// areas, ... (`Propagator::setup_laps`), and the rest as "other" (the visibility lists are
    /// `visibility_seconds`)
    pub setup_phases: Vec<(String, f64)>,
    pub visibility_seconds: f64,
    pub visibility_gpu_ms: Option<f64>,
    pub propagation_seconds: f64,
    /// after the iterations: reading the light field back, the power balance (with its probes
    /// of the materials where a loss concentrates), the surface detail and tiles, the render
    /// buffers (`finish_phases` names them)
    pub finish_seconds: f64,
    pub finish_phases: Vec<(String, f64)>,
    /// what `vlf propagate` spends around the propagation: reading the scene, writing the
    /// light field file (empty where the light field is not read or written by a command)
    pub command_phases: Vec<(String, f64)>,
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
    /// emitted + sky = absorbed + escaped + unshot (+ residue), measured term by term; None for
    /// a run resumed from a checkpoint (the iterations before it were not measured)
    pub power_balance: Option<PowerBalance>,
    pub warnings: Vec<String>,
}

impl PropagationReport {
    pub fn table(&self) -> String {
        let mut rows = self.size_rows();
        rows.extend(self.cost_rows());
        rows.extend(self.light_rows());
        match &self.power_balance {
            Some(b) => rows.extend(b.rows(&self.per_iteration)),
            None => rows.push((
                "power balance".into(),
                "not measured (resumed from a checkpoint)".into(),
            )),
        }
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
                    "{} ({} of tiles){}",
                    self.non_diffuse_elements,
                    human_bytes(self.tile_bytes),
                    match self.specular_faces_without_tiles {
                        0 => String::new(),
                        n => format!(
                            "; {n} small specular face(s) without tiles: their specular light sent on as diffuse light"
                        ),
                    }
                ),
            ),
            ("textures".into(), self.textures_text()),
            ("visibility layers".into(), self.layers_text()),
        ]
    }

    /// A stage's seconds and its steps, e.g. `9.579 s (faces 2.1, BVH 1.3, ...)`.
    fn steps_text(seconds: f64, phases: &[(String, f64)]) -> String {
        let steps: Vec<String> = (phases.iter())
            .map(|(phase, s)| format!("{phase} {s:.2}"))
            .collect();
        match steps.is_empty() {
            true => format!("{seconds:.3} s"),
            false => format!("{seconds:.3} s ({})", steps.join(", ")),
        }
    }

    /// What it cost: time per stage, iterations, residual, GPU memory.
    fn cost_rows(&self) -> Vec<(String, String)> {
        vec![
            (
                "setup".into(),
                Self::steps_text(self.setup_seconds, &self.setup_phases),
            ),
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
                "finishing".into(),
                Self::steps_text(self.finish_seconds, &self.finish_phases),
            ),
            (
                "scene and file".into(),
                match self.command_phases.is_empty() {
                    true => "not read or written here".into(),
                    false => Self::steps_text(
                        self.command_phases.iter().map(|p| p.1).sum(),
                        &self.command_phases,
                    ),
                },
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

/// A run whose power balance is off by more than this share of the injected power says so.
pub const BALANCE_TOLERANCE: f64 = 0.005;

/// The power balance of a run: emitted + sky = absorbed (fronts and one-sided backs) + escaped +
/// unshot + residue. See `transport::Propagator` for how each term is measured and which are
/// exact.
#[derive(Clone, Debug, Serialize)]
pub struct PowerBalance {
    pub emitted: f64,
    pub sky: f64,
    pub absorbed: f64,
    pub absorbed_by_backs: f64,
    pub escaped: f64,
    /// left unshot when the iterations stopped (a geometric tail, where one was added, spreads
    /// it over the totals in the proportions of the last iteration)
    pub unshot: f64,
    pub residue: f64,
    /// residue / (emitted + sky): > 0 light lost in transport, < 0 light made
    pub residue_fraction: f64,
    /// |residue_fraction| > 0.5%
    pub off: bool,
    /// where the balance is off: what each material's light loses when gathered once more
    pub losses: Vec<MaterialLoss>,
    /// the balance in words
    pub verdict: String,
}

/// How much of one material's light the transport loses (`transport::Propagator::probe`).
#[derive(Clone, Debug, Serialize)]
pub struct MaterialLoss {
    pub material: String,
    /// what its texels sent over the run (pi x total radiance x area, r+g+b)
    pub sent: f64,
    /// of that, sent once more: what reached no face's front, not the sky and no one-sided back
    pub lost: f64,
    /// lost / sent
    pub lost_fraction: f64,
    /// lost / (emitted + sky)
    pub share_of_injected: f64,
}

impl PowerBalance {
    /// The whole run's balance from its account (losses per material to be filled in where it is
    /// off).
    pub fn of(account: &PowerAccount) -> PowerBalance {
        let injected = account.injected().max(1e-300);
        let residue = account.residue();
        PowerBalance {
            emitted: account.emitted,
            sky: account.sky,
            absorbed: account.absorbed,
            absorbed_by_backs: account.absorbed_by_backs,
            escaped: account.escaped,
            unshot: account.unshot(),
            residue,
            residue_fraction: residue / injected,
            off: (residue / injected).abs() > BALANCE_TOLERANCE,
            losses: Vec::new(),
            verdict: String::new(),
        }
    }

    /// Set the verdict in words from the terms and `losses` (largest loss first).
    pub fn set_verdict(&mut self) {
        let pct = |x: f64| 100.0 * x / (self.emitted + self.sky).max(1e-300);
        let terms = format!(
            "emitted + sky ({:.4} + {:.4}) = absorbed {:.2}% + absorbed by one-sided backs {:.2}% + escaped {:.2}% + unshot {:.2}% + residue {:+.3}%",
            self.emitted,
            self.sky,
            pct(self.absorbed),
            pct(self.absorbed_by_backs),
            pct(self.escaped),
            pct(self.unshot),
            pct(self.residue)
        );
        if !self.off {
            self.verdict = format!("power balance closes within 0.5%: {terms}");
            return;
        }
        let what = if self.residue > 0.0 { "lost" } else { "made" };
        let mut text = format!(
            "power balance off by {:+.2}% (more than 0.5%): {:.2}% of the injected power was {what} in transport, neither absorbed, nor escaped to the sky, nor still unshot ({terms})",
            pct(self.residue),
            pct(self.residue.abs())
        );
        let named: Vec<String> = (self.losses.iter())
            .filter(|l| {
                l.lost * self.residue > 0.0
                    && l.share_of_injected.abs() >= 0.1 * self.residue_fraction.abs()
            })
            .take(3)
            .map(|l| {
                format!(
                    "'{}' ({:.1}% of the light it sends goes nowhere: {:.2}% of the injected power)",
                    l.material,
                    100.0 * l.lost_fraction,
                    100.0 * l.share_of_injected
                )
            })
            .collect();
        if !named.is_empty() {
            text.push_str(&format!(
                "; the loss concentrates on the light of {}",
                named.join(", ")
            ));
        }
        self.verdict = text;
    }

    /// Rows of the summary table: the balance, then per iteration.
    fn rows(&self, per_iteration: &[IterationStats]) -> Vec<(String, String)> {
        let injected = (self.emitted + self.sky).max(1e-300);
        let pct = |x: f64| 100.0 * x / injected;
        let mut rows = vec![("power balance".to_string(), self.verdict.clone())];
        for s in per_iteration {
            let Some(p) = &s.power else { continue };
            rows.push((
                format!("  iteration {}", s.iteration),
                format!(
                    "shot {:.2}% -> received {:.2}% (absorbed {:.2}%, reflected {:.2}%, mirrored {:.2}%), one-sided backs {:.2}%, escaped {:.2}%; unshot {:.2}%; residue so far {:+.3}%",
                    pct(p.shot),
                    pct(p.received),
                    pct(p.absorbed),
                    pct(p.reflected),
                    pct(p.mirrored),
                    pct(p.absorbed_by_backs),
                    pct(p.escaped),
                    pct(p.unshot),
                    100.0 * p.residue
                ),
            ));
        }
        rows
    }
}
