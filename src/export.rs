//! `vlf export mitsuba`: a vlf scene as a standalone Mitsuba 3 scene, for ground truth that
//! shares none of vlf's code.
//!
//! The exporter is `tools/mitsuba/reference.py`, compiled into the binary and run with the
//! system's Python: it parses scene.toml, OBJ and MTL itself, so an error in vlf's own scene
//! import cannot cancel out when a researcher compares vlf with the Mitsuba rendering. Writing
//! the exporter in Rust on top of [`crate::scene`] would have made the reference depend on the
//! very code it is meant to check.

use crate::error::{Result, VlfError};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The exporter's source (Python 3.11+, numpy, mitsuba).
pub const MITSUBA_EXPORTER: &str = include_str!("../tools/mitsuba/reference.py");

/// What `vlf export mitsuba` wrote.
#[derive(Debug)]
pub struct MitsubaExport {
    /// One XML per `[[camera]]` (each includes `geometry.xml`), in the order the exporter named them.
    pub cameras: Vec<PathBuf>,
    /// The exporter's notes and warnings (approximations it made), one per line.
    pub notes: Vec<String>,
}

/// Writes `out_dir/<camera>.xml`, `geometry.xml`, `meshes/*.ply` and `textures/*.exr` for the
/// scene at `scene_toml`, with `python` (e.g. "python3") running the embedded exporter.
/// `extra_obj`: an OBJ (with its MTL) added as ordinary geometry, the moving objects at a frozen
/// pose (`dynamic::MovingMesh::posed_obj`).
pub fn mitsuba(
    scene_toml: &Path,
    out_dir: &Path,
    python: &str,
    extra_obj: Option<&Path>,
) -> Result<MitsubaExport> {
    if !scene_toml.is_file() {
        return Err(VlfError::Io {
            path: scene_toml.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such scene file"),
        });
    }
    let exporter_err = |message: String| VlfError::Export {
        target: "mitsuba",
        message,
    };
    let dir = tempfile::tempdir().map_err(|e| exporter_err(format!("temporary folder: {e}")))?;
    let script = dir.path().join("vlf_mitsuba_export.py");
    std::fs::write(&script, MITSUBA_EXPORTER).map_err(|e| VlfError::write(&script, e))?;
    let mut command = Command::new(python);
    command
        .arg(&script)
        .arg(scene_toml)
        .arg("--export")
        .arg(out_dir);
    if let Some(obj) = extra_obj {
        command.arg("--extra-obj").arg(obj);
    }
    let output = command.output().map_err(|e| {
        exporter_err(format!(
            "cannot run `{python}` ({e}): the exporter is Python; install Python 3.11 or \
                 newer, then `pip install mitsuba numpy`"
        ))
    })?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() {
        // the exporter ends with "error: ..." (or a traceback): pass on its last line only
        let last = stderr
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("no message");
        return Err(exporter_err(format!(
            "{}: {}",
            scene_toml.display(),
            last.trim_start_matches("error: ")
        )));
    }
    let mut export = MitsubaExport {
        cameras: Vec::new(),
        notes: Vec::new(),
    };
    for line in stderr.lines() {
        // "camera NAME: mitsuba PATH -D spp=N ..." names each written view
        match line
            .strip_prefix("camera ")
            .and_then(|l| l.split_once(": mitsuba "))
        {
            Some((_, rest)) => export.cameras.push(PathBuf::from(
                rest.split(" -D ").next().unwrap_or(rest).trim(),
            )),
            None if !line.trim().is_empty() => export.notes.push(line.to_string()),
            None => {}
        }
    }
    Ok(export)
}
