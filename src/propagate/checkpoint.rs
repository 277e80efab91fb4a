//! Checkpoints of a running propagation (`vlf propagate --checkpoint N`, `--resume`): every N
//! iterations the unshot and total state is written atomically beside the output; resuming
//! reloads it and continues to exactly the result an uninterrupted run gives (propagation is
//! deterministic, and the state is restored bit for bit).

use super::PropagationParams;
use crate::error::{Result, VlfError};
use crate::lightfield::file::{decode_sections, encode_sections, write_atomic};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"VLFCHKPT";
const VERSION: u32 = 1;
const SECTIONS: [&[u8; 4]; 5] = [b"META", b"UNTX", b"TOTX", b"UNTT", b"TOTT"];

/// Where and how often to checkpoint.
#[derive(Clone, Debug)]
pub struct CheckpointPlan {
    pub path: PathBuf,
    /// save every this many iterations (0: never)
    pub every: u32,
    /// continue from `path` if it exists
    pub resume: bool,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CheckpointMeta {
    pub vlf_version: String,
    pub scene_hash: String,
    pub params: PropagationParams,
    pub iteration: u32,
    pub emitted_power: f64,
    /// residual after each iteration so far
    pub residuals: Vec<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    pub meta: CheckpointMeta,
    pub unshot: Vec<[f32; 4]>,
    pub total: Vec<[f32; 4]>,
    pub tile_unshot: Vec<[f32; 4]>,
    pub tile_total: Vec<[f32; 4]>,
}

impl Checkpoint {
    pub fn save(&self, path: &Path) -> Result<()> {
        let meta = serde_json::to_vec_pretty(&self.meta).expect("metadata serialises");
        let sections: [(&[u8; 4], &[u8]); 5] = [
            (SECTIONS[0], &meta),
            (SECTIONS[1], bytemuck::cast_slice(&self.unshot)),
            (SECTIONS[2], bytemuck::cast_slice(&self.total)),
            (SECTIONS[3], bytemuck::cast_slice(&self.tile_unshot)),
            (SECTIONS[4], bytemuck::cast_slice(&self.tile_total)),
        ];
        write_atomic(path, &encode_sections(MAGIC, VERSION, &sections))
    }

    pub fn load(path: &Path) -> Result<Checkpoint> {
        let bytes = std::fs::read(path).map_err(|e| VlfError::io(path, e))?;
        let err = |message: String| VlfError::LightFieldFile {
            path: path.to_path_buf(),
            message,
        };
        let s =
            decode_sections(&bytes, MAGIC, VERSION, &SECTIONS, "vlf checkpoint").map_err(err)?;
        let meta: CheckpointMeta = serde_json::from_slice(s[0])
            .map_err(|e| err(format!("section META is not valid: {e}")))?;
        let vec = |b: &[u8], name: &str| -> Result<Vec<[f32; 4]>> {
            if !b.len().is_multiple_of(16) {
                return Err(err(format!("section {name} is not whole texels")));
            }
            Ok(b.chunks_exact(16)
                .map(bytemuck::pod_read_unaligned)
                .collect())
        };
        Ok(Checkpoint {
            unshot: vec(s[1], "UNTX")?,
            total: vec(s[2], "TOTX")?,
            tile_unshot: vec(s[3], "UNTT")?,
            tile_total: vec(s[4], "TOTT")?,
            meta,
        })
    }

    /// Refuse a checkpoint of another scene or other settings.
    pub fn check(&self, scene_hash: &str, params: &PropagationParams, path: &Path) -> Result<()> {
        let err = |message: String| VlfError::LightFieldFile {
            path: path.to_path_buf(),
            message,
        };
        if self.meta.scene_hash != scene_hash {
            return Err(err("it was made for another scene (or the scene's files changed); delete it or drop --resume".into()));
        }
        if &self.meta.params != params {
            return Err(err(format!(
                "it was made with other settings ({:?}); resume with the same settings or drop --resume",
                self.meta.params
            )));
        }
        Ok(())
    }
}
