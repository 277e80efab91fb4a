//! `[cluster]`: the display TOML's table for a CAVE driven by several processes (which rank or
//! host draws which walls or eyes, the lost-rank timeouts, how the light field reaches the
//! ranks) and its checks against the walls. It is part of the display configuration, so it
//! lives here; the cluster itself (the ranks' plan, the MPI frame lock, the report) is
//! `crate::cluster`.

use super::{DisplayConfig, Stereo};
use serde::{Deserialize, Serialize};

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
    /// which GPU each rank opens: "local-rank" (the n-th rank on a host takes the host's n-th
    /// GPU in PCI bus order, nvidia-smi's; ranks share when there are fewer GPUs) or "default"
    /// (every rank the best adapter, or `VLF_GPU`'s); a node's own `gpu = N` comes first
    #[serde(default)]
    pub gpu: GpuPerRank,
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

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum GpuPerRank {
    #[default]
    LocalRank,
    Default,
}

/// `[[cluster.node]]`: a rank (by number, or the next rank on a host) and what it draws.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Node {
    pub rank: Option<u32>,
    pub host: Option<String>,
    /// the GPU this node's rank opens (index in PCI bus order, as nvidia-smi lists them)
    pub gpu: Option<usize>,
    /// wall names; "wall:left" / "wall:right" for one eye of a wall with `stereo = "separate"`
    pub walls: Vec<String>,
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            timeout_s: default_timeout(),
            startup_timeout_s: default_startup_timeout(),
            light_field: LightFieldShare::Auto,
            gpu: GpuPerRank::LocalRank,
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

impl DisplayConfig {
    /// The display as one rank draws it: only `views`' walls (each with its one eye where the
    /// view names one), in `views`' order.
    pub fn only_views(&self, views: &[ViewRef]) -> DisplayConfig {
        let mut local = self.clone();
        local.walls = (views.iter())
            .map(|&(wall, eye)| {
                let mut w = self.walls[wall].clone();
                w.only_eye = eye;
                w
            })
            .collect();
        local
    }

    /// The views named `names` (`<wall>-<eye>`, as `wall_views` names them), as `only_views`
    /// takes them: a wall whose every eye is named is drawn whole. None where a name is not
    /// one of this display's views.
    pub fn views_named(&self, names: &[String]) -> Option<Vec<ViewRef>> {
        let all = crate::display::frame::wall_views(self);
        if !(names.iter()).all(|n| all.iter().any(|v| &v.name(self) == n)) {
            return None;
        }
        let mut views: Vec<ViewRef> = Vec::new();
        for (wall, w) in self.walls.iter().enumerate() {
            let eyes = w.eyes();
            let named: Vec<&'static str> = (eyes.iter())
                .map(|(eye, _)| *eye)
                .filter(|eye| names.contains(&format!("{}-{eye}", w.name)))
                .collect();
            match named.len() {
                0 => {}
                n if n == eyes.len() => views.push((wall, None)),
                _ => views.extend(named.into_iter().map(|eye| (wall, Some(eye)))),
            }
        }
        Some(views)
    }
}

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
}

/// "front" or "front:left" -> (wall index, eye).
pub fn parse_view(config: &DisplayConfig, name: &str) -> std::result::Result<ViewRef, String> {
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
