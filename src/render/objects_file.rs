//! A file of moving objects alone: a display config's `[[object]]` and `[object_lighting]`
//! tables in a TOML of their own, for the displays that have no display config (the headset:
//! `vlf xr --objects`) and for stills (`vlf render --objects`, `vlf export mitsuba --objects`).
//! It lives above `dynamic` (the objects) and `probes` (their lighting), which it joins.

use super::probes::ObjectLighting;
use crate::dynamic::{check_objects, ObjectConfig};
use crate::error::{Result, VlfError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A file of moving objects (`vlf xr --objects`, `vlf render --objects`, `vlf export mitsuba
/// --objects`): a display config's object tables, nothing else (unknown keys are refused).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ObjectsFile {
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectConfig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_lighting: Option<ObjectLighting>,
}

impl ObjectsFile {
    /// Read and check a file of objects; an error names the file and the table and key (the
    /// meshes are loaded later, relative to this file, by `dynamic::Objects::load`).
    pub fn load(path: &Path) -> Result<ObjectsFile> {
        let text = std::fs::read_to_string(path).map_err(|e| VlfError::io(path, e))?;
        ObjectsFile::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<ObjectsFile> {
        let err = |message: String| VlfError::Config {
            path: path.to_path_buf(),
            message,
        };
        let file: ObjectsFile =
            toml::from_str(text).map_err(|e| err(e.to_string().trim_end().to_string()))?;
        if file.objects.is_empty() {
            return Err(err(
                "no [[object]] table: give at least one (name, mesh, kind, follow, ...)".into(),
            ));
        }
        check_objects(&file.objects).map_err(err)?;
        if let Some(l) = &file.object_lighting {
            l.check().map_err(err)?;
        }
        Ok(file)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_key_is_named_with_the_file() {
        let path = Path::new("body.toml");
        let text = "[[object]]\nname = \"body\"\nmesh = \"m.glb\"\nfollow_me = \"head\"\n";
        let e = ObjectsFile::parse(text, path).unwrap_err().to_string();
        assert!(e.contains("body.toml") && e.contains("follow_me"), "{e}");
        let e = ObjectsFile::parse("", path).unwrap_err().to_string();
        assert!(e.contains("[[object]]"), "{e}");
    }
}
