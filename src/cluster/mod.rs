//! One CAVE driven by a cluster of processes (`mpirun -np N vlf cave ...`): which rank draws
//! which views (`ClusterConfig::assign`, `local_config`), what a run was asked for
//! (`CaveRun`), and the cluster report rank 0 prints. The display TOML's `[cluster]` table is
//! read and checked with the rest of the display configuration
//! (`crate::display::cluster_config`); the state rank 0 broadcasts every frame and the frame
//! lock the drawing loops call are `crate::framelock`; the MPI side is `with_mpi.rs`, behind the
//! cargo feature `mpi` (`run_cluster` starts it; without the feature a cluster launch is
//! refused with how to build one).

#[cfg(feature = "mpi")]
mod with_mpi;

use crate::display::cluster_config::parse_view;
pub use crate::display::cluster_config::{
    ClusterConfig, GpuPerRank, LightFieldShare, Node, ViewRef,
};
use crate::display::headless::ViewTiming;
use crate::display::DisplayConfig;
pub use crate::display::MakeLightField;
use crate::error::Result;
use crate::gpu::AdapterChoice;
use crate::stats::Distribution;
use crate::tracking::TrackingConfig;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Run this process as one rank of a CAVE cluster (under mpirun): rank 0 prints the cluster
/// report (and writes it as JSON); a lost rank ends every process with a message.
#[cfg(feature = "mpi")]
pub fn run_cluster(run: &CaveRun, make: &mut MakeLightField) -> Result<()> {
    with_mpi::run(run, make)
}

/// Without the `mpi` feature a cluster run is refused, saying how to build with it.
#[cfg(not(feature = "mpi"))]
pub fn run_cluster(_run: &CaveRun, _make: &mut MakeLightField) -> Result<()> {
    Err(crate::VlfError::Cluster(NO_MPI.into()))
}

impl ClusterConfig {
    /// Each rank's views, for `size` ranks on `hosts` (processor name per rank).
    pub fn assign(
        &self,
        config: &DisplayConfig,
        hosts: &[String],
    ) -> std::result::Result<Vec<Vec<ViewRef>>, String> {
        let size = hosts.len();
        let mut plan: Vec<Vec<ViewRef>> = vec![Vec::new(); size];
        if self.nodes.is_empty() {
            let n = config.walls.len();
            for wall in 0..n {
                plan[wall * size / n].push((wall, None));
            }
        }
        for (node, rank) in self.nodes.iter().zip(self.node_ranks(hosts)?) {
            for name in &node.walls {
                plan[rank].push(parse_view(config, name)?);
            }
        }
        if let Some(r) = plan.iter().position(Vec::is_empty) {
            return Err(format!("rank {r} has no wall to draw ({} walls over {size} ranks): launch fewer ranks or give it a [[cluster.node]]", config.walls.len()));
        }
        Ok(plan)
    }

    /// The rank each `[[cluster.node]]` runs on, for `hosts` (processor name per rank).
    fn node_ranks(&self, hosts: &[String]) -> std::result::Result<Vec<usize>, String> {
        let size = hosts.len();
        let mut taken = vec![false; size];
        let mut ranks = Vec::with_capacity(self.nodes.len());
        for (i, node) in self.nodes.iter().enumerate() {
            let rank = match (&node.rank, &node.host) {
                (Some(r), _) if (*r as usize) < size => *r as usize,
                (Some(r), _) => return Err(format!("cluster.node[{i}].rank: {r} is not a rank of this run (mpirun -np {size}: ranks 0 to {})", size - 1)),
                (None, Some(h)) => (0..size).find(|&r| &hosts[r] == h && !taken[r]).ok_or_else(|| {
                    format!("cluster.node[{i}].host: no rank left on host {h:?} (the ranks run on: {})", hosts.join(", "))
                })?,
                (None, None) => unreachable!("validated"),
            };
            if taken[rank] {
                return Err(format!("cluster.node[{i}]: rank {rank} already has a node"));
            }
            taken[rank] = true;
            ranks.push(rank);
        }
        Ok(ranks)
    }

    /// The GPU each rank opens: a node's own `gpu = N`, else by `[cluster] gpu`: "local-rank"
    /// gives the n-th rank on a host the n-th GPU there (wrapping round when the host has
    /// fewer GPUs than ranks), "default" the best adapter (or `VLF_GPU`'s) to every rank.
    pub fn gpus(&self, hosts: &[String]) -> std::result::Result<Vec<AdapterChoice>, String> {
        let mut gpus: Vec<AdapterChoice> = (0..hosts.len())
            .map(|r| match self.gpu {
                GpuPerRank::Default => AdapterChoice::Default,
                GpuPerRank::LocalRank => AdapterChoice::Gpu {
                    index: hosts[..r].iter().filter(|h| **h == hosts[r]).count(),
                    wrap: true,
                },
            })
            .collect();
        for (node, rank) in self.nodes.iter().zip(self.node_ranks(hosts)?) {
            if let Some(index) = node.gpu {
                gpus[rank] = AdapterChoice::Gpu { index, wrap: false };
            }
        }
        Ok(gpus)
    }
}

/// The display as one rank draws it: only its views; on ranks other than 0 a live tracker is
/// replaced by a static head (poses come from rank 0) that may carry a wand like the source, and
/// the source's targets by name.
pub fn local_config(config: &DisplayConfig, views: &[ViewRef], leader: bool) -> DisplayConfig {
    let mut local = config.only_views(views);
    if !leader && config.tracking.live().is_some() {
        local.tracking = TrackingConfig::Static {
            head: [0.0, 1.7, 0.0],
            head_yaw_deg: None,
            head_pitch_deg: None,
            head_roll_deg: None,
            head_orientation: None,
            wand_position: Some([0.0, 1.0, 0.0]),
            wand_yaw_deg: None,
            wand_pitch_deg: None,
            wand_orientation: None,
            left_hand_position: None,
            left_hand_yaw_deg: None,
            left_hand_pitch_deg: None,
            left_hand_orientation: None,
            // the same targets in the same order (objects name them, the log has their
            // columns), never seen here: their poses come from rank 0's frame state
            targets: (config.tracking.targets().iter())
                .map(|t| crate::tracking::TargetConfig {
                    name: t.name.clone(),
                    id: None,
                    position: None,
                    yaw_deg: None,
                    pitch_deg: None,
                    orientation: None,
                })
                .collect(),
        };
    }
    local
}

/// How a `vlf cave` run was asked for (the command line).
pub struct CaveRun {
    pub config: PathBuf,
    pub scene: PathBuf,
    pub headless: bool,
    pub frames: Option<u32>,
    pub hold: std::time::Duration,
    pub exposure: f32,
    pub out: PathBuf,
    pub exr: bool,
    pub json: Option<PathBuf>,
    /// `--log DIR`: every rank logs its own views into DIR/rank<k> (rank 0's with the events)
    pub log: Option<PathBuf>,
    /// `--control ADDR`: rank 0 takes the experiment script's commands; every rank follows
    pub control: Option<String>,
    /// `--lsl`: rank 0's LSL outlets
    pub lsl: bool,
}

/// The number of ranks when launched by mpirun (Open MPI, MPICH/PMI or PMIx), else None.
pub fn launched_size() -> Option<u32> {
    [
        "OMPI_COMM_WORLD_SIZE",
        "PMI_SIZE",
        "PMIX_SIZE",
        "MPI_LOCALNRANKS",
    ]
    .iter()
    .find_map(|k| std::env::var(k).ok()?.parse().ok())
}

/// How to get a build that runs as a cluster.
pub const NO_MPI: &str = "this vlf was built without MPI, so it cannot run as a cluster under mpirun: install Open MPI (Debian/Ubuntu: sudo apt-get install libopenmpi-dev openmpi-bin libclang-dev; tools/setup.sh does it) and build with `cargo build --release --features mpi`; without mpirun, `vlf cave` draws every wall in one process";

/// p50 / p99 / max / count of a series of milliseconds.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Stats {
    pub p50: f64,
    pub p99: f64,
    pub max: f64,
    pub samples: usize,
}

impl Stats {
    pub fn of(values: &[f64]) -> Option<Stats> {
        (!values.is_empty()).then(|| {
            let d = Distribution::of(values);
            Stats {
                p50: d.median,
                p99: d.p99,
                max: d.max,
                samples: d.samples,
            }
        })
    }
}

/// One rank's part of the cluster report.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RankReport {
    pub rank: u32,
    pub host: String,
    pub pid: u32,
    /// GPU time per wall and eye (None when the rank's run did not finish)
    pub views: Vec<ViewTiming>,
    /// CPU milliseconds per frame: frame state received to frame drawn (GPU finished)
    pub cpu_frame_ms: Option<Stats>,
    /// milliseconds waiting at the swap barrier for the other ranks
    pub swap_wait_ms: Option<Stats>,
    /// milliseconds from one present to the next: the cluster's frame time
    pub frame_ms: Option<Stats>,
    /// every frame's present-to-present time (ms), in order from frame 1: where a slow frame fell
    #[serde(default)]
    pub frame_ms_series: Vec<f32>,
    /// every frame's swap-barrier wait (ms), in order from frame 1
    #[serde(default)]
    pub swap_wait_ms_series: Vec<f32>,
    /// frames presented (after the swap barrier): [frame number, pose digest] each
    pub shown: Vec<[u64; 2]>,
    /// the GPU this rank drew on
    #[serde(default)]
    pub gpu: Option<RankGpu>,
    /// the eye rays per pixel the frame pacer gave this rank's views (headless, paced runs)
    #[serde(default)]
    pub pacer: Option<crate::render::budget::PacerReport>,
    /// this rank's own failure, if it had one
    pub error: Option<String>,
}

/// Which GPU a rank drew on: its name, the index it was asked for (`[cluster] gpu`; None: the
/// default adapter) and its PCI bus address (two GPUs of one name differ there).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct RankGpu {
    pub name: String,
    pub index: Option<usize>,
    pub pci_bus_id: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LostRank {
    pub rank: u32,
    pub reason: String,
}

/// What rank 0 prints: every rank's timings and frames, and whether they agree.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ClusterReport {
    pub display: String,
    pub adapter: String,
    pub mode: String,
    pub ranks: u32,
    pub timeout_s: f64,
    /// every rank presented the same frame numbers with the same pose digests
    pub same_frames_and_poses: bool,
    pub check: String,
    pub lost: Vec<LostRank>,
    pub per_rank: Vec<RankReport>,
}

impl ClusterReport {
    /// Compare every rank's presented frames with rank 0's; fills `same_frames_and_poses`.
    pub fn check_frames(&mut self) {
        let Some(first) = self.per_rank.first() else {
            return;
        };
        let reference = first.shown.clone();
        let mut problems = Vec::new();
        for r in &self.per_rank[1..] {
            if r.shown == reference {
                continue;
            }
            let at = (r.shown.iter().zip(&reference)).position(|(a, b)| a != b);
            problems.push(match at {
                Some(i) => format!(
                    "rank {} presented frame {} (pose {:08x}) where rank {} presented frame {} (pose {:08x})",
                    r.rank, r.shown[i][0], r.shown[i][1], first.rank, reference[i][0], reference[i][1]
                ),
                None => format!("rank {} presented {} frames, rank {} {}", r.rank, r.shown.len(), first.rank, reference.len()),
            });
        }
        self.same_frames_and_poses = problems.is_empty() && self.lost.is_empty();
        self.check =
            if problems.is_empty() {
                format!(
                "all {} reporting ranks presented the same {} frames ({}) with the same poses{}",
                self.per_rank.len(),
                reference.len(),
                frame_range(&reference),
                if self.lost.is_empty() { "" } else { " (lost ranks not included)" }
            )
            } else {
                problems.join("; ")
            };
    }

    pub fn table(&self) -> String {
        let mut s = format!(
            "cluster report: display {} on {}, {} ranks ({}), lost-rank timeout {} s\n",
            self.display, self.adapter, self.ranks, self.mode, self.timeout_s
        );
        for r in &self.per_rank {
            s.push_str(&format!(
                "  rank {} ({} pid {}{}): frames {}\n",
                r.rank,
                r.host,
                r.pid,
                r.gpu.as_ref().map_or(String::new(), |g| match g.index {
                    Some(i) => format!(", GPU {i} {} at {}", g.name, g.pci_bus_id),
                    None => format!(", {}", g.name),
                }),
                frame_range(&r.shown)
            ));
            for v in &r.views {
                if let Some(d) = &v.gpu_ms {
                    s.push_str(&format!(
                        "    {:<10} {:<6} {}x{}  GPU p50 {:.3} ms  p99 {:.3}\n",
                        v.wall, v.eye, v.pixels[0], v.pixels[1], d.median, d.p99
                    ));
                }
            }
            let line = |name: &str, d: &Option<Stats>| {
                d.as_ref().map_or(String::new(), |d| {
                    format!("    {name}: p50 {:.3} ms, p99 {:.3} ms\n", d.p50, d.p99)
                })
            };
            s.push_str(&line("frame time (present to present)", &r.frame_ms));
            s.push_str(&line(
                "CPU frame time (state received to drawn)",
                &r.cpu_frame_ms,
            ));
            s.push_str(&line("waiting at the swap barrier", &r.swap_wait_ms));
            if let Some(e) = &r.error {
                s.push_str(&format!("    failed: {e}\n"));
            }
        }
        for l in &self.lost {
            s.push_str(&format!("  LOST rank {}: {}\n", l.rank, l.reason));
        }
        s.push_str(&format!(
            "  frame lock: {} ({})\n",
            if self.same_frames_and_poses {
                "ok"
            } else {
                "NOT OK"
            },
            self.check
        ));
        s
    }
}

/// "0-299 (300)" for a run of consecutive frame numbers, else first..last and the count.
fn frame_range(shown: &[[u64; 2]]) -> String {
    match (shown.first(), shown.last()) {
        (Some(a), Some(b)) => {
            let consecutive = shown.windows(2).all(|w| w[1][0] == w[0][0] + 1);
            format!(
                "{}{}{} ({} presented)",
                a[0],
                if consecutive { "-" } else { ".." },
                b[0],
                shown.len()
            )
        }
        _ => "none".into(),
    }
}
