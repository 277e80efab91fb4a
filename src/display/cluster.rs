//! One CAVE driven by a cluster of processes (`mpirun -np N vlf cave ...`): the display TOML's
//! `[cluster]` table (walls or eyes per rank or host name, the lost-rank timeout), what a run
//! was asked for, and the cluster report rank 0 prints. The state rank 0 broadcasts every frame
//! and the frame lock the drawing loops call are in `framelock.rs`; the MPI side is
//! `cluster_mpi.rs`, behind the cargo feature `mpi` (`super::run_cluster` starts it; without
//! the feature a cluster launch is refused with how to build one).

use super::headless::ViewTiming;
use super::{DisplayConfig, Stereo};
use crate::stats::Distribution;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// `[cluster]`: which rank draws which walls, and how long a silent rank may take.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ClusterConfig {
    /// seconds without a frame-lock message after which a rank counts as lost
    #[serde(default = "default_timeout")]
    pub timeout_s: f64,
    /// seconds the ranks wait for each other while starting (loading, propagating on rank 0)
    #[serde(default = "default_startup_timeout")]
    pub startup_timeout_s: f64,
    /// how the light field reaches the ranks: "auto" (each rank that can read the .vlf loads
    /// it, the others get rank 0's over MPI), "shared" (every rank must read it) or "broadcast"
    #[serde(default)]
    pub light_field: LightFieldShare,
    /// walls per rank (or host); none: the walls split in order into equal runs over the ranks
    #[serde(default, rename = "node")]
    pub nodes: Vec<Node>,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum LightFieldShare {
    #[default]
    Auto,
    Shared,
    Broadcast,
}

/// `[[cluster.node]]`: a rank (by number, or the next rank on a host) and what it draws.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Node {
    pub rank: Option<u32>,
    pub host: Option<String>,
    /// wall names; "wall:left" / "wall:right" for one eye of a wall with `stereo = "separate"`
    pub walls: Vec<String>,
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            timeout_s: default_timeout(),
            startup_timeout_s: default_startup_timeout(),
            light_field: LightFieldShare::Auto,
            nodes: Vec::new(),
        }
    }
}

fn default_timeout() -> f64 {
    10.0
}

fn default_startup_timeout() -> f64 {
    600.0
}

/// One view a rank draws: a wall and, when split, one of its eyes.
pub type ViewRef = (usize, Option<&'static str>);

impl ClusterConfig {
    /// Checks naming the key (`cluster.…`), against the display's walls.
    pub fn validate(&self, config: &DisplayConfig) -> std::result::Result<(), String> {
        for (key, s) in [
            ("timeout_s", self.timeout_s),
            ("startup_timeout_s", self.startup_timeout_s),
        ] {
            if !(s.is_finite() && s > 0.0 && s <= 86400.0) {
                return Err(format!("cluster.{key}: {s} must be seconds above 0"));
            }
        }
        let mut seen = std::collections::HashSet::new();
        for (i, n) in self.nodes.iter().enumerate() {
            let at = format!("cluster.node[{i}]");
            if n.rank.is_some() == n.host.is_some() {
                return Err(format!("{at}: give either rank = N or host = \"name\""));
            }
            if n.walls.is_empty() {
                return Err(format!("{at}.walls: name at least one wall"));
            }
            for name in &n.walls {
                let (wall, eye) =
                    parse_view(config, name).map_err(|e| format!("{at}.walls: {e}"))?;
                let eyes: Vec<&str> = match eye {
                    Some(e) => vec![e],
                    None => config.walls[wall].eyes().iter().map(|e| e.0).collect(),
                };
                for e in eyes {
                    if !seen.insert((wall, e)) {
                        return Err(format!("{at}.walls: {name:?} is already drawn by another node (each wall and eye on one rank)"));
                    }
                }
            }
        }
        if !self.nodes.is_empty() {
            for (i, w) in config.walls.iter().enumerate() {
                for (eye, _) in w.eyes() {
                    if !seen.contains(&(i, eye)) {
                        return Err(format!("cluster.node: wall {:?} ({eye} eye) is drawn by no node: add it to a node's walls", w.name));
                    }
                }
            }
        }
        Ok(())
    }

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
        let mut taken = vec![false; size];
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
            for name in &node.walls {
                plan[rank].push(parse_view(config, name)?);
            }
        }
        if let Some(r) = plan.iter().position(Vec::is_empty) {
            return Err(format!("rank {r} has no wall to draw ({} walls over {size} ranks): launch fewer ranks or give it a [[cluster.node]]", config.walls.len()));
        }
        Ok(plan)
    }
}

/// "front" or "front:left" -> (wall index, eye).
fn parse_view(config: &DisplayConfig, name: &str) -> std::result::Result<ViewRef, String> {
    let (wall, eye) = match name.split_once(':') {
        Some((w, e)) => (w, Some(e)),
        None => (name, None),
    };
    let index = (config.walls.iter().position(|w| w.name == wall)).ok_or_else(|| {
        let names: Vec<&str> = config.walls.iter().map(|w| w.name.as_str()).collect();
        format!("no wall named {wall:?} (walls: {})", names.join(", "))
    })?;
    let eye = match eye {
        None => None,
        Some(_) if config.walls[index].stereo != Stereo::Separate => {
            return Err(format!("{name:?}: only a wall with stereo = \"separate\" has its eyes on different outputs; give the whole wall"))
        }
        Some("left") => Some("left"),
        Some("right") => Some("right"),
        Some(e) => return Err(format!("{name:?}: eye {e:?} is left or right")),
    };
    Ok((index, eye))
}

/// The display as one rank draws it: only its views; on ranks other than 0 a live tracker is
/// replaced by a static head (poses come from rank 0) that may carry a wand like the source.
pub fn local_config(config: &DisplayConfig, views: &[ViewRef], leader: bool) -> DisplayConfig {
    let mut local = config.clone();
    local.walls = views
        .iter()
        .map(|&(wall, eye)| {
            let mut w = config.walls[wall].clone();
            w.only_eye = eye;
            w
        })
        .collect();
    if !leader && config.tracking.live().is_some() {
        local.tracking = super::TrackingConfig::Static {
            head: [0.0, 1.7, 0.0],
            head_yaw_deg: None,
            head_pitch_deg: None,
            head_roll_deg: None,
            head_orientation: None,
            wand_position: Some([0.0, 1.0, 0.0]),
            wand_yaw_deg: None,
            wand_pitch_deg: None,
            wand_orientation: None,
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
}

pub use super::MakeLightField;

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
    /// frames presented (after the swap barrier): [frame number, pose digest] each
    pub shown: Vec<[u64; 2]>,
    /// this rank's own failure, if it had one
    pub error: Option<String>,
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
                "  rank {} ({} pid {}): frames {}\n",
                r.rank,
                r.host,
                r.pid,
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
