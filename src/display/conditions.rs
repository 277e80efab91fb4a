//! A study's named conditions (the display TOML's `[[condition]]` tables): sets of settings an
//! experiment script switches between trials with one command (`{"cmd": "condition", "name":
//! ...}`, `crate::study`). A condition says which light field is drawn (global illumination
//! on, or direct light only; the `--scene`, another light field on its geometry, or another
//! scene, drawn by a renderer of its own: `frame/geometries.rs`), the
//! exposure of what the walls show, which moving objects are shown and whether they cast
//! shadows and show in mirrors, and where the room starts. Everything a condition needs is made
//! before the first frame (`Conditions::prepare`: every light field propagated or loaded and
//! resident on the GPU), so that a switch rebinds at a frame boundary and adds no work to any
//! frame.
//!
//! Direct light only is the scene propagated with one shooting iteration: the first iteration
//! puts on every diffuse texel the emitters' light and the sky's, in closed form with shadow
//! rays (`propagate/direct.rs`), and nothing that has bounced; the emitters keep their own
//! radiance, and mirrors are still traced at drawing time (they show the direct-lit scene).

use crate::error::{names_or_none, Result, VlfError};
use crate::lightfield::{LightField, ResidentLightField};
use crate::tracking::StartPose;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One `[[condition]]` table. A key left out takes its default: global illumination on, the
/// `--scene`'s light field, exposure 1, every object shown, shadows and reflections on; the
/// room stays where it is unless `start_pose` is given.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ConditionConfig {
    /// the name a script switches to (letters, digits, `-`, `_`, `.`)
    pub name: String,
    /// false: direct light only (the emitters and their first bounce, with shadows; no
    /// interreflection); mirrors are still traced
    #[serde(default = "yes")]
    pub global_illumination: bool,
    /// another light field to draw: a `.vlf`, or a scene propagated at start with the
    /// `--scene`'s settings; relative to the display TOML. Of the `--scene`'s geometry (other
    /// light or materials on it) it is drawn by the same renderer; of other geometry (another
    /// scene: give a `start_pose` in it) by a renderer of its own, made before the first frame
    /// like everything else
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_field: Option<PathBuf>,
    /// what the walls show is scaled by this (the PNGs a headless run and `vlf replay` write
    /// too; radiance read back and EXR stay linear)
    #[serde(default = "one")]
    pub exposure: f32,
    /// the moving objects shown (`[[object]]` names); left out: all of them
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objects_visible: Option<Vec<String>>,
    /// the moving objects' shadows on the scene
    #[serde(default = "yes")]
    pub shadows: bool,
    /// the moving objects in the scene's mirrors
    #[serde(default = "yes")]
    pub reflections: bool,
    /// where the room stands in the scene from the switch on (as `teleport`); left out: where
    /// it is
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_pose: Option<StartPose>,
}

fn yes() -> bool {
    true
}

fn one() -> f32 {
    1.0
}

/// The conditions as a study session takes them (`crate::study::Session::with_conditions`):
/// names with their start poses (the room's place and yaw), the initial one first (`default`,
/// else the list's first).
pub fn study_conditions(
    list: &[ConditionConfig],
    default: Option<&str>,
) -> Vec<(String, Option<(glam::Vec3, f32)>)> {
    let mut out: Vec<(String, Option<(glam::Vec3, f32)>)> = (list.iter())
        .map(|c| {
            let start = (c.start_pose.as_ref()).map(|p| (glam::Vec3::from(p.position), p.yaw_deg));
            (c.name.clone(), start)
        })
        .collect();
    let initial = default
        .and_then(|d| out.iter().position(|c| c.0 == d))
        .unwrap_or(0);
    if !out.is_empty() {
        let first = out.remove(initial);
        out.insert(0, first);
    }
    out
}

/// A study's conditions in a file of their own, for the display without a display config (the
/// headset: `vlf xr --conditions FILE.toml`): `default_condition` and `[[condition]]` tables as
/// a display config has them, nothing else.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ConditionsFile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub default_condition: Option<String>,
    #[serde(default, rename = "condition")]
    pub conditions: Vec<ConditionConfig>,
}

impl ConditionsFile {
    /// Read and check a file of conditions against the moving objects' names `objects`; an
    /// error names the file, the condition and the key.
    pub fn load(path: &Path, objects: &[String]) -> Result<ConditionsFile> {
        let text = std::fs::read_to_string(path).map_err(|e| VlfError::io(path, e))?;
        let err = |message: String| VlfError::Config {
            path: path.to_path_buf(),
            message,
        };
        let file: ConditionsFile = toml::from_str(&text).map_err(|e| {
            err(unknown_key(&text).unwrap_or_else(|| e.to_string().trim_end().to_string()))
        })?;
        if file.conditions.is_empty() {
            return Err(err(
                "no [[condition]] table: give at least one (name, and what it changes)".into(),
            ));
        }
        check(&file.conditions, file.default_condition.as_deref(), objects).map_err(err)?;
        Ok(file)
    }
}

/// The keys a `[[condition]]` table takes.
pub const KEYS: [&str; 8] = [
    "name",
    "global_illumination",
    "light_field",
    "exposure",
    "objects_visible",
    "shadows",
    "reflections",
    "start_pose",
];

/// Where a display TOML did not parse: an unknown key in one of its `[[condition]]` tables,
/// named with its condition (toml's own message names the key and the line only).
pub fn unknown_key(text: &str) -> Option<String> {
    let table: toml::Table = toml::from_str(text).ok()?;
    let conditions = table.get("condition")?.as_array()?;
    for (i, c) in conditions.iter().enumerate() {
        let Some(c) = c.as_table() else { continue };
        let name = c.get("name").and_then(|n| n.as_str()).unwrap_or("");
        if let Some(key) = c.keys().find(|k| !KEYS.contains(&k.as_str())) {
            return Some(format!(
                "condition[{i}] ({name:?}).{key}: unknown key; a [[condition]] takes {}",
                KEYS.join(", ")
            ));
        }
    }
    None
}

/// The conditions' checks, each naming the condition and the key; `objects`: the display's
/// `[[object]]` names; `default`: `default_condition`.
pub fn check(
    conditions: &[ConditionConfig],
    default: Option<&str>,
    objects: &[String],
) -> std::result::Result<(), String> {
    for (i, c) in conditions.iter().enumerate() {
        let at = format!("condition[{i}] ({:?})", c.name);
        let name_ok = !c.name.is_empty()
            && (c.name.chars()).all(|ch| ch.is_ascii_alphanumeric() || "-_.".contains(ch));
        if !name_ok {
            return Err(format!(
                "{at}.name: use letters, digits, '-', '_' and '.' (the name goes into the session log's CSV)"
            ));
        }
        if conditions[..i].iter().any(|p| p.name == c.name) {
            return Err(format!("{at}.name: two conditions share this name"));
        }
        if !(c.exposure.is_finite() && c.exposure > 0.0) {
            return Err(format!(
                "{at}.exposure: {} must be a positive number (1: as propagated)",
                c.exposure
            ));
        }
        for name in c.objects_visible.iter().flatten() {
            if !objects.contains(name) {
                return Err(format!(
                    "{at}.objects_visible: no [[object]] called {name:?} (there are: {})",
                    names_or_none(objects)
                ));
            }
        }
        if let Some(p) = &c.start_pose {
            if !(p.position.iter().all(|x| x.is_finite()) && p.yaw_deg.is_finite()) {
                return Err(format!("{at}.start_pose: must be finite numbers"));
            }
        }
    }
    if let Some(name) = default {
        if !conditions.iter().any(|c| c.name == name) {
            let names: Vec<&str> = conditions.iter().map(|c| c.name.as_str()).collect();
            return Err(format!(
                "default_condition: no [[condition]] called {name:?} (there are: {})",
                names_or_none(&names)
            ));
        }
    }
    Ok(())
}

/// A light field the conditions draw besides the `--scene`'s, and what it was made from.
pub struct ConditionField {
    /// the scene or .vlf (absolute where it could be resolved), and whether with global
    /// illumination
    pub source: PathBuf,
    pub global_illumination: bool,
    /// its geometry: 0 the `--scene`'s, k > 0 the k-th other (fields of one geometry share a
    /// renderer)
    pub geometry: usize,
    pub lf: LightField,
    pub resident: ResidentLightField,
}

impl ConditionField {
    /// A line for the start-up messages: what it is and its GPU memory.
    pub fn describe(&self) -> String {
        format!(
            "{}{}{}: {:.1} MiB resident",
            self.source.display(),
            if self.global_illumination {
                ""
            } else {
                " (direct light only)"
            },
            match self.geometry {
                0 => String::new(),
                g => format!(" (other geometry {g}: a renderer of its own)"),
            },
            self.resident.ledger.total() as f64 / (1024.0 * 1024.0)
        )
    }
}

/// The display's conditions with their light fields made: everything a switch needs.
pub struct Conditions {
    pub list: Vec<ConditionConfig>,
    /// the light fields besides the `--scene`'s (field 0), field k + 1 each
    pub fields: Vec<ConditionField>,
    /// each condition's light field (0: the `--scene`'s, k + 1: `fields[k]`)
    pub field_of: Vec<usize>,
    /// the condition in effect at the start (`default_condition`, else the first)
    pub initial: usize,
}

/// The light field the run draws from its `--scene`: what it is made from (a `.vlf` or a
/// scene), and the light field itself (its settings propagate the conditions' scenes).
#[derive(Clone, Copy)]
pub struct MainField<'a> {
    pub source: &'a Path,
    pub lf: &'a LightField,
    pub resident: &'a ResidentLightField,
}

impl Conditions {
    /// Make every light field the display's conditions draw (None: the display has none),
    /// reporting each (and its resident memory) to `progress`. Scenes are propagated with the main
    /// light field's settings (`LightFieldMeta::params`); direct light only with one shooting
    /// iteration and no geometric tail. Propagation repeats bit for bit, so `vlf replay` makes
    /// the same ones.
    pub fn prepare(
        config: &super::DisplayConfig,
        config_path: &Path,
        main: MainField<'_>,
        progress: &dyn crate::progress::Progress,
    ) -> Result<Option<Conditions>> {
        let list = (&config.conditions[..], config.default_condition.as_deref());
        Conditions::prepare_list(list, config_path, main, progress)
    }

    /// `prepare` for the conditions `list` and the initial one's name, from a file at
    /// `config_path` (a display config, or `vlf xr --conditions`' `ConditionsFile`).
    pub fn prepare_list(
        (list, default): (&[ConditionConfig], Option<&str>),
        config_path: &Path,
        main: MainField<'_>,
        progress: &dyn crate::progress::Progress,
    ) -> Result<Option<Conditions>> {
        if list.is_empty() {
            return Ok(None);
        }
        let base = config_path.parent().unwrap_or(Path::new("."));
        let absolute = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
        let main_source = absolute(main.source);
        let mut fields: Vec<ConditionField> = Vec::new();
        let mut field_of = Vec::new();
        for c in list {
            let source = match &c.light_field {
                Some(p) => absolute(&base.join(p)),
                None => main_source.clone(),
            };
            if source == main_source && c.global_illumination {
                field_of.push(0);
                continue;
            }
            let known = (fields.iter())
                .position(|f| f.source == source && f.global_illumination == c.global_illumination);
            let k = match known {
                Some(k) => k,
                None => {
                    let mut field = make_field(&source, c, main, progress)?;
                    field.geometry = geometry_of(&field.lf, main.lf, &fields);
                    fields.push(field);
                    fields.len() - 1
                }
            };
            field_of.push(k + 1);
        }
        let mib = |r: &ResidentLightField| r.ledger.total() as f64 / (1024.0 * 1024.0);
        progress.note(&format!(
            "conditions: {} ({}); light fields on the GPU: {}: {:.1} MiB resident",
            list.len(),
            (list.iter())
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            main_source.display(),
            mib(main.resident)
        ));
        for f in &fields {
            progress.note(&format!("conditions: light field {}", f.describe()));
        }
        let initial = default
            .and_then(|d| list.iter().position(|c| c.name == d))
            .unwrap_or(0);
        Ok(Some(Conditions {
            list: list.to_vec(),
            fields,
            field_of,
            initial,
        }))
    }

    /// The index of the condition called `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.list.iter().position(|c| c.name == name)
    }

    /// Every light field's resident bytes, the `--scene`'s first (`main`).
    pub fn resident_bytes(&self, main: &ResidentLightField) -> Vec<u64> {
        std::iter::once(main.ledger.total())
            .chain(self.fields.iter().map(|f| f.resident.ledger.total()))
            .collect()
    }
}

/// Load or propagate one condition's light field from `source`.
fn make_field(
    source: &Path,
    c: &ConditionConfig,
    main: MainField<'_>,
    progress: &dyn crate::progress::Progress,
) -> Result<ConditionField> {
    let ctx = main.resident.ctx.clone();
    let gi = c.global_illumination;
    let lf = if crate::lightfield::file::is_vlf_path(source) {
        if !gi {
            return Err(VlfError::Display(format!(
                "condition {:?}: global_illumination = false propagates a scene with one iteration, and {} is a .vlf: give the scene (scene.toml or glTF) as --scene or as the condition's light_field",
                c.name,
                source.display()
            )));
        }
        progress.note(&format!(
            "conditions: loading {} for {:?}",
            source.display(),
            c.name
        ));
        crate::lightfield::file::load(source)?
    } else {
        let scene = crate::scene::Scene::load(source)?;
        let mut params = main.lf.meta.params.clone();
        if !gi {
            params.max_iterations = 1;
            params.accelerate = false;
        }
        progress.note(&format!(
            "conditions: propagating {}{} for {:?}",
            source.display(),
            if gi {
                ""
            } else {
                " with one iteration (direct light only)"
            },
            c.name
        ));
        crate::propagate::propagate(ctx.clone(), &scene, &params, progress)?.0
    };
    let resident = lf.upload(ctx)?;
    Ok(ConditionField {
        source: source.to_path_buf(),
        global_illumination: gi,
        geometry: 0,
        lf,
        resident,
    })
}

/// Which geometry `lf` has: 0 `main`'s, else that of the first of `fields` with the same, else
/// a new one.
fn geometry_of(lf: &LightField, main: &LightField, fields: &[ConditionField]) -> usize {
    if same_geometry(main, lf) {
        return 0;
    }
    let known = (fields.iter()).find(|f| f.geometry > 0 && same_geometry(&f.lf, lf));
    match known {
        Some(f) => f.geometry,
        None => 1 + fields.iter().map(|f| f.geometry).max().unwrap_or(0),
    }
}

/// Whether two light fields draw through the same renderer: the same triangles, mirror tiles
/// and texture detail (their light and materials may differ).
fn same_geometry(a: &LightField, b: &LightField) -> bool {
    bytemuck::cast_slice::<_, u8>(&a.render_vertices)
        == bytemuck::cast_slice::<_, u8>(&b.render_vertices)
        && a.tiles.is_some() == b.tiles.is_some()
        && a.mirror_chains().tiles_needed == b.mirror_chains().tiles_needed
        && a.detail.is_some() == b.detail.is_some()
        && a.meta.normalisation == b.meta.normalisation
}
