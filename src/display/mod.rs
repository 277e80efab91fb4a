//! Displays: CAVE walls, power walls and desktop windows, configured in TOML under
//! `config/displays/` (this module), with off-axis projection per wall and eye
//! (`projection.rs`), projector warp and blend (`warp.rs`) applied with the wand ray by one GPU
//! pass per output (`post.rs`), one frame of views as every display draws it (`frame/`), an eye
//! image onto a window (`present.rs`), and the drivers of that frame: offscreen (`headless.rs`)
//! and in windows (`window/`). The display TOML's `[cluster]` table and its checks against the
//! walls are `cluster_config.rs`. Poses come from `crate::tracking`; a cluster of processes
//! drives these loops through `crate::framelock` (`crate::cluster`); the headset is `crate::xr`.
//! Every wall and eye is drawn from one device and one light field.

pub mod cluster_config;
pub mod conditions;
pub mod frame;
pub mod headless;
pub mod headset_view;
pub mod post;
pub mod present;
pub mod projection;
pub mod replay;
pub mod warp;
pub mod window;

use crate::error::{Result, VlfError};
use crate::tracking::source::PoseSource;
use crate::tracking::{vrpn, Navigation, Pose, StartPose, TrackingConfig};
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DisplayConfig {
    pub name: String,
    /// interpupillary distance, metres
    #[serde(default = "default_ipd")]
    pub eye_separation: f32,
    /// from the tracked point of the head to the point between the eyes, metres in the head's
    /// frame (x right, y up, -z ahead): e.g. [0, -0.05, -0.08] for a target on top of the glasses
    #[serde(default)]
    pub eye_offset: [f32; 3],
    #[serde(default)]
    pub start_pose: StartPose,
    #[serde(default)]
    pub tracking: TrackingConfig,
    #[serde(default)]
    pub navigation: Navigation,
    /// antialiasing: eye rays per pixel of every wall (1 = off)
    #[serde(default = "default_antialiasing")]
    pub antialiasing: u32,
    /// the projectors' refresh rate, Hz: every frame must be drawn within one period (the
    /// reports check it; left out, no frame budget is checked)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refresh_hz: Option<f32>,
    /// fit every frame into the refresh period (needs `refresh_hz`): before the first frame the
    /// views are probed from `antialiasing` down (fewer eye rays per pixel, then fewer mirror
    /// reflections before the tiles) until their GPU time leaves a quarter of the period free,
    /// and the run keeps those settings (`render/budget.rs`); the report says what was chosen
    #[serde(default)]
    pub fit_frame_time: bool,
    /// how eye rays find their first hits: "rays" (cast through the BVH) or "raster" (a
    /// visibility buffer drawn by the rasteriser with `antialiasing` MSAA samples per pixel, one
    /// per eye ray: `render/raster.rs`); reflections are traced either way
    #[serde(
        default,
        skip_serializing_if = "crate::render::raster::FirstHits::is_rays"
    )]
    pub first_hits: crate::render::raster::FirstHits,
    /// edge antialiasing (`render/edges.rs`): pixels that differ from a neighbour (another face,
    /// a step in luminance over `contrast`) take `samples` eye rays, the others `antialiasing`;
    /// e.g. `edge_antialiasing = { samples = 8 }` with `antialiasing = 1`
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub edge_antialiasing: Option<crate::render::edges::EdgeAntialiasing>,
    /// the tracked wand's ray, drawn on every wall (`post.rs`)
    #[serde(default)]
    pub wand_ray: post::WandRay,
    #[serde(rename = "wall")]
    pub walls: Vec<Wall>,
    /// moving things drawn into the light field: props on the head or wand, keyframed objects,
    /// the participant's avatar (`crate::dynamic`)
    #[serde(default, rename = "object", skip_serializing_if = "Vec::is_empty")]
    pub objects: Vec<crate::dynamic::ObjectConfig>,
    /// how the moving objects are lit and shadow the scene (`render::probes`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_lighting: Option<crate::render::probes::ObjectLighting>,
    /// a study's named conditions (`conditions.rs`), switched by the experiment script
    #[serde(default, rename = "condition", skip_serializing_if = "Vec::is_empty")]
    pub conditions: Vec<conditions::ConditionConfig>,
    /// the condition in effect at the start (left out: the first `[[condition]]`)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub default_condition: Option<String>,
    /// several processes, one CAVE (`mpirun`; `cluster_config.rs`, `crate::cluster`): walls per rank, lost-rank timeout
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cluster: Option<cluster_config::ClusterConfig>,
}

fn default_ipd() -> f32 {
    0.064
}

fn default_antialiasing() -> u32 {
    crate::render::REALTIME_SAMPLES
}

#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Stereo {
    Mono,
    /// left and right eye on separate outputs
    Separate,
    SideBySide,
    TopBottom,
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// monitor by index or by name
    pub monitor: Option<MonitorRef>,
    #[serde(default)]
    pub fullscreen: bool,
    /// window position in pixels (windowed)
    pub window: Option<[i32; 2]>,
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum MonitorRef {
    Index(u32),
    Name(String),
}

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    pub name: String,
    /// corners in room metres (y up)
    pub lower_left: [f32; 3],
    pub lower_right: [f32; 3],
    pub upper_left: [f32; 3],
    /// pixels (per eye for side-by-side / top-bottom halves: the whole output)
    pub pixels: [u32; 2],
    #[serde(default = "mono")]
    pub stereo: Stereo,
    pub output: Output,
    /// projectors that share this wall's image, each with a warp and a blend mask (`warp.rs`);
    /// none: the wall image goes to the output as it is
    #[serde(default, rename = "projector", skip_serializing_if = "Vec::is_empty")]
    pub projectors: Vec<warp::Projector>,
    /// a cluster rank drawing only one eye of this wall (`crate::cluster::local_config`)
    #[serde(skip)]
    pub only_eye: Option<&'static str>,
}

fn mono() -> Stereo {
    Stereo::Mono
}

impl Wall {
    pub fn corners(&self) -> [Vec3; 3] {
        [
            Vec3::from(self.lower_left),
            Vec3::from(self.lower_right),
            Vec3::from(self.upper_left),
        ]
    }
    /// The eyes drawn on this wall: ("mono", 0) or ("left", -1) and ("right", +1).
    pub fn eyes(&self) -> Vec<(&'static str, f32)> {
        let all = match self.stereo {
            Stereo::Mono => vec![("mono", 0.0)],
            _ => vec![("left", -1.0), ("right", 1.0)],
        };
        (all.into_iter())
            .filter(|e| self.only_eye.is_none_or(|only| only == e.0))
            .collect()
    }
    /// Pixel size of one eye's image.
    pub fn eye_pixels(&self) -> [u32; 2] {
        match self.stereo {
            Stereo::SideBySide => [self.pixels[0] / 2, self.pixels[1]],
            Stereo::TopBottom => [self.pixels[0], self.pixels[1] / 2],
            _ => self.pixels,
        }
    }
}

impl DisplayConfig {
    /// The pose source this display's loops draw from (`config_path` resolves a scripted path
    /// relative to the configuration file).
    pub fn pose_source(&self, config_path: &Path) -> Result<PoseSource> {
        PoseSource::from_config(&self.tracking, &self.start_pose, config_path)
    }

    /// The conditions' names (a study switches between them), in the config's order.
    pub fn condition_names(&self) -> Vec<String> {
        self.conditions.iter().map(|c| c.name.clone()).collect()
    }

    /// The conditions as a study session takes them (`crate::study::Session::with_conditions`):
    /// names with their start poses (the room's place and yaw), the initial one first
    /// (`default_condition`, else the config's first).
    pub fn study_conditions(&self) -> Vec<(String, Option<(Vec3, f32)>)> {
        conditions::study_conditions(&self.conditions, self.default_condition.as_deref())
    }

    /// The moving objects' names (a study shows and hides them by name).
    pub fn object_names(&self) -> Vec<String> {
        self.objects.iter().map(|o| o.name.clone()).collect()
    }

    /// One refresh period in milliseconds, where `refresh_hz` is given.
    pub fn frame_budget_ms(&self) -> Option<f64> {
        self.refresh_hz.map(|hz| 1000.0 / hz as f64)
    }

    /// Read and check a configuration, and the warp and blend files it names.
    pub fn load(path: &Path) -> Result<DisplayConfig> {
        let text = std::fs::read_to_string(path).map_err(|e| VlfError::io(path, e))?;
        let config = Self::parse(&text, path)?;
        warp::load_outputs(&config, path)?;
        Ok(config)
    }

    pub fn parse(text: &str, path: &Path) -> Result<DisplayConfig> {
        let err = |message: String| VlfError::Config {
            path: path.to_path_buf(),
            message,
        };
        let config: DisplayConfig = toml::from_str(text).map_err(|e| {
            // an unknown key of a [[condition]] named with its condition
            let message = conditions::unknown_key(text);
            err(message.unwrap_or_else(|| e.to_string().trim_end().to_string()))
        })?;
        config.validate().map_err(err)?;
        Ok(config)
    }

    /// Checks that name the offending key.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.walls.is_empty() {
            return Err("[[wall]]: at least one wall is needed".into());
        }
        crate::dynamic::check_objects(&self.objects)?;
        self.tracking.check_targets()?;
        crate::dynamic::target_indices(&self.objects, &self.tracking.target_names())?;
        let objects = self.object_names();
        conditions::check(
            &self.conditions,
            self.default_condition.as_deref(),
            &objects,
        )?;
        if let Some(l) = &self.object_lighting {
            l.check()?;
        }
        if !(1..=crate::render::MAX_SAMPLES).contains(&self.antialiasing) {
            return Err(format!(
                "antialiasing: {} eye rays per pixel: use 1 (off) to {}",
                self.antialiasing,
                crate::render::MAX_SAMPLES
            ));
        }
        if let Some(hz) = self.refresh_hz.filter(|hz| !(hz.is_finite() && *hz >= 1.0)) {
            return Err(format!(
                "refresh_hz: {hz} is not a refresh rate: give the projectors' rate in Hz (e.g. 120)"
            ));
        }
        if self.fit_frame_time && self.refresh_hz.is_none() {
            return Err(
                "fit_frame_time: a frame can only be fitted into a refresh period: give refresh_hz"
                    .into(),
            );
        }
        if !(self.eye_separation.is_finite() && (0.0..0.2).contains(&self.eye_separation)) {
            return Err(format!(
                "eye_separation: {} m is not a plausible interpupillary distance (0 to 0.2)",
                self.eye_separation
            ));
        }
        let mut names = std::collections::HashSet::new();
        for (i, w) in self.walls.iter().enumerate() {
            let at = format!("wall[{i}] ({:?})", w.name);
            if !names.insert(w.name.as_str()) {
                return Err(format!("{at}.name: duplicate wall name"));
            }
            let [ll, lr, ul] = w.corners();
            if [ll, lr, ul].iter().any(|c| !c.is_finite()) {
                return Err(format!("{at}: corners must be finite numbers"));
            }
            let (right, up) = (lr - ll, ul - ll);
            if right.length() < 1e-4 || up.length() < 1e-4 {
                return Err(format!(
                    "{at}.lower_right/upper_left: the wall has zero size"
                ));
            }
            let cos = right.normalize().dot(up.normalize());
            if cos.abs() > 1e-3 {
                return Err(format!(
                    "{at}.upper_left: lower_left->lower_right and lower_left->upper_left must meet at a right angle (they are {:.2} degrees apart)",
                    cos.clamp(-1.0, 1.0).acos().to_degrees()
                ));
            }
            if w.pixels[0] == 0 || w.pixels[1] == 0 || w.pixels[0] > 16384 || w.pixels[1] > 16384 {
                return Err(format!(
                    "{at}.pixels: {:?} must be 1..16384 each way",
                    w.pixels
                ));
            }
            if w.output.monitor.is_none() && w.output.window.is_none() {
                return Err(format!(
                    "{at}.output: name a monitor (index or name) or a window position"
                ));
            }
        }
        if !(self.eye_offset.iter().all(|x| x.is_finite())
            && Vec3::from(self.eye_offset).length() <= 0.5)
        {
            return Err(format!("eye_offset: {:?} must be finite and at most 0.5 m long (it is the offset from the tracked point to the eyes' centre)", self.eye_offset));
        }
        if let TrackingConfig::Static { head, .. } = &self.tracking {
            if head.iter().any(|x| !x.is_finite()) {
                return Err("tracking.head: must be finite".into());
            }
        }
        self.tracking.static_head_rotation()?;
        self.tracking.static_wand()?;
        self.tracking.static_left_hand()?;
        self.tracking.static_targets()?;
        self.wand_ray.validate()?;
        for (i, w) in self.walls.iter().enumerate() {
            warp::validate_projectors(w).map_err(|e| format!("wall[{i}] ({:?}).{e}", w.name))?;
        }
        if let Some(source) = self.tracking.live() {
            source.calibration?;
        }
        if let TrackingConfig::Vrpn { server, device, .. } = &self.tracking {
            vrpn::server_address(server).map_err(|e| format!("tracking.server: {e}"))?;
            if device.is_empty() {
                return Err("tracking.device: name the VRPN device (as in Tracker0@host)".into());
            }
        }
        if let Some(c) = &self.cluster {
            c.validate(self)?;
        }
        if self.navigation.wand_reset_button >= 64 {
            return Err(format!(
                "navigation.wand_reset_button: {} is not a button (0 to 63)",
                self.navigation.wand_reset_button
            ));
        }
        Ok(())
    }

    /// Check outputs against the monitors that exist (names as the windowing system gives them).
    pub fn check_outputs(&self, monitors: &[String]) -> std::result::Result<(), String> {
        for (i, w) in self.walls.iter().enumerate() {
            match &w.output.monitor {
                Some(MonitorRef::Index(n)) if *n as usize >= monitors.len() => {
                    return Err(format!("wall[{i}] ({:?}).output.monitor: {n} is not a monitor here; there are {} ({})", w.name, monitors.len(), monitors.join(", ")));
                }
                Some(MonitorRef::Name(name)) if !monitors.iter().any(|m| m == name) => {
                    return Err(format!(
                        "wall[{i}] ({:?}).output.monitor: no monitor named {name:?}; there are: {}",
                        w.name,
                        monitors.join(", ")
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }
}

/// Makes the light field on a GPU context chosen elsewhere (the headset runtime's device, each
/// cluster rank's): loads a `.vlf` onto it or propagates a scene into it (the command line's
/// `src/cli/light_field.rs`).
pub type MakeLightField<'a> = dyn FnMut(
        &std::sync::Arc<crate::gpu::GpuContext>,
    ) -> Result<(
        crate::lightfield::LightField,
        crate::lightfield::ResidentLightField,
    )> + 'a;

/// One wall seen by one eye (`side` -1 left, +1 right, 0 mono): the off-axis view-projection
/// and the eye, in the light field's normalised space. The eyes sit at +-IPD/2 along the
/// tracked head's right axis, `eye_offset` (head frame) from the tracked point.
pub fn wall_view(
    config: &DisplayConfig,
    wall: &Wall,
    side: f32,
    pose: &Pose,
    norm: &crate::prepare::Normalisation,
) -> (Mat4, Vec3) {
    let to_unit = |p: Vec3| norm.to_unit(p.into()).as_vec3();
    let eye = to_unit(pose.room_to_world(pose.eye(
        Vec3::from(config.eye_offset),
        config.eye_separation,
        side,
    )));
    let [ll, lr, ul] = wall.corners().map(|c| to_unit(pose.room_to_world(c)));
    let plane_distance = (ll - eye).dot((lr - ll).cross(ul - ll).normalize()).abs();
    let near = (plane_distance * 0.5).clamp(1e-4, 0.01);
    (
        projection::off_axis(ll, lr, ul, eye, near, eye.length() + 4.0).view_proj,
        eye,
    )
}

/// A new session log in `dir` for a CAVE run of the display `config` (loaded from
/// `config_path`) drawing `lf` (made from `scene`) on `adapter` (`crate::study`): its views
/// are `display`'s, which in a cluster are one rank's.
pub fn session_log(
    dir: &Path,
    (config_path, scene): (&Path, &Path),
    lf: &crate::lightfield::LightField,
    display: &DisplayConfig,
    adapter: &str,
) -> Result<crate::study::SessionLog> {
    let views = (frame::wall_views(display).iter())
        .map(|v| v.name(display))
        .collect();
    let meta = crate::study::SessionMeta {
        display_config: std::fs::canonicalize(config_path)
            .unwrap_or_else(|_| config_path.to_path_buf()),
        targets: display.tracking.target_names(),
        ..crate::study::SessionMeta::starting(scene, lf, adapter, views)
    };
    crate::study::SessionLog::create(dir, meta)
}
