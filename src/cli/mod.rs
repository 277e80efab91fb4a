//! The binary's own modules: one per subcommand (its clap arguments and its body), the
//! propagation settings they share (`params.rs`), the light field they draw from
//! (`light_field.rs`), the terminal's bars (`progress.rs`) and the lab's subcommands (`lab.rs`,
//! feature `lab`); here, what several of them use.

pub mod cave;
pub mod compare;
pub mod demo;
pub mod edge_args;
pub mod export;
#[cfg(feature = "lab")]
pub mod lab;
pub mod light_field;
pub mod params;
pub mod progress;
pub mod propagate;
pub mod reference;
pub mod render;
pub mod replay;
pub mod still_objects;
pub mod track;
pub mod verify;
pub mod xr;

use anyhow::{Context, Result};
use std::path::Path;

pub fn parse_size(s: &str) -> std::result::Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?}: expected WxH, e.g. 1024x768"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("{s:?}: width is not a number"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("{s:?}: height is not a number"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("{s:?}: width and height must be 1..16384"));
    }
    Ok([w, h])
}

pub fn print_warnings(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    let tmp = path.with_extension("json.tmp");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
