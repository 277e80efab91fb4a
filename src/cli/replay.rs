//! `vlf replay`: a session log's frames (`vlf cave --log DIR`) drawn again offscreen, exactly as
//! the live run drew them, into one folder per frame.

use super::progress::Bars;
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::PathBuf;
use vlf::gpu::GpuContext;
use vlf::study::SessionLog;

/// `vlf replay`'s arguments.
#[derive(Args)]
pub struct ReplayArgs {
    /// The session log's folder (session.json, frames.csv)
    log: PathBuf,
    /// Where the images go: OUT/frame-<n>/<wall>-<eye>.png and the overview
    #[arg(long, default_value = "replay-out")]
    out: PathBuf,
    /// The frames to draw: N, A..B (B not included) or A..=B; every logged frame by default
    #[arg(long)]
    frames: Option<String>,
    /// Also write EXR (linear radiance) per wall and eye
    #[arg(long)]
    exr: bool,
}

/// The frame numbers `spec` names: N, A..B or A..=B.
fn frame_range(spec: &str) -> Result<std::ops::RangeInclusive<u64>> {
    let number = |s: &str| -> Result<u64> {
        s.trim()
            .parse()
            .with_context(|| format!("--frames {spec}: {s:?} is not a frame number"))
    };
    Ok(if let Some((a, b)) = spec.split_once("..=") {
        number(a)?..=number(b)?
    } else if let Some((a, b)) = spec.split_once("..") {
        let end = number(b)?;
        if end == 0 {
            bail!("--frames {spec}: an empty range");
        }
        number(a)?..=end - 1
    } else {
        let n = number(spec)?;
        n..=n
    })
}

/// `vlf replay`.
pub fn run(a: ReplayArgs) -> Result<()> {
    let (meta, records) = SessionLog::read(&a.log)?;
    let wanted = a.frames.as_deref().map(frame_range).transpose()?;
    let frames: Vec<_> = (records.into_iter())
        .filter(|r| wanted.as_ref().is_none_or(|w| w.contains(&r.frame)))
        .collect();
    if frames.is_empty() {
        bail!(
            "{}: no logged frame in --frames {}",
            a.log.display(),
            a.frames.unwrap_or_default()
        );
    }
    let ctx = GpuContext::new()?;
    let (lf, resident) = light_field(&ctx, &meta)?;
    let folders = vlf::display::replay::replay(
        (&lf, &resident),
        &meta,
        &frames,
        (&a.out, a.exr),
        &Bars::default(),
    )?;
    println!(
        "{} frame(s) of {} drawn again into {} ({} .. {})",
        folders.len(),
        a.log.display(),
        a.out.display(),
        folders[0].display(),
        folders[folders.len() - 1].display()
    );
    Ok(())
}

/// The light field the session drew: its .vlf file, or its scene propagated again with the
/// logged settings (propagation repeats bit for bit), checked against the logged scene hash.
fn light_field(
    ctx: &std::sync::Arc<GpuContext>,
    meta: &vlf::study::SessionMeta,
) -> Result<(
    vlf::lightfield::LightField,
    vlf::lightfield::ResidentLightField,
)> {
    let (lf, resident) = match &meta.propagation {
        None => {
            let lf = vlf::lightfield::file::load(&meta.light_field)?;
            let resident = lf.upload(ctx.clone())?;
            (lf, resident)
        }
        Some(params) => {
            let scene = vlf::scene::Scene::load(&meta.light_field)?;
            let (lf, resident, _) =
                vlf::propagate::propagate(ctx.clone(), &scene, params, &Bars::default())?;
            (lf, resident)
        }
    };
    if lf.meta.scene_hash != meta.scene_hash {
        bail!(
            "{}: the scene changed since the session (hash {} then, {} now)",
            meta.light_field.display(),
            meta.scene_hash,
            lf.meta.scene_hash
        );
    }
    Ok((lf, resident))
}
