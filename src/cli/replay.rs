//! `vlf replay`: a session log's frames (`vlf cave --log DIR`) drawn again offscreen, exactly as
//! the live run drew them, into one folder per frame and/or a video of one view; or seen from a
//! third-person camera; with the events overlaid as text if asked.

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
    /// Where the images go: OUT/frame-<n>/<wall>-<eye>.png and the overview (default
    /// replay-out; with --video, no images unless --out is given)
    #[arg(long)]
    out: Option<PathBuf>,
    /// The frames to draw: N, A..B (B not included) or A..=B; every logged frame by default
    #[arg(long)]
    frames: Option<String>,
    /// Also write EXR (linear radiance) per wall and eye
    #[arg(long)]
    exr: bool,
    /// Also an H.264 video (MP4) of one view (or of the third-person camera), by the ffmpeg
    /// program, at the display's refresh rate (else the logged frames' rate)
    #[arg(long)]
    video: Option<PathBuf>,
    /// The view the video shows, as the log names it (e.g. front-left); default the first
    #[arg(long)]
    view: Option<String>,
    /// The video's frames per second, instead of the display's refresh rate
    #[arg(long)]
    fps: Option<f64>,
    /// Draw from a camera outside the participant (the avatar and moving objects posed as
    /// logged): by default 1.8 m behind and 0.6 m above the logged head, looking at it
    #[arg(long)]
    third_person: bool,
    /// The third-person camera's place, world metres x,y,z (implies --third-person)
    #[arg(long, value_parser = parse_point)]
    camera: Option<[f32; 3]>,
    /// The point the third-person camera looks at, x,y,z (default: just below the logged head)
    #[arg(long, value_parser = parse_point)]
    look_at: Option<[f32; 3]>,
    /// The third-person camera's vertical field of view, degrees
    #[arg(long, default_value_t = 60.0)]
    fov: f32,
    /// The third-person camera's image size WxH
    #[arg(long, value_parser = super::parse_size, default_value = "640x360")]
    size: [u32; 2],
    /// The frame number, block and trial, and the events (each held for a second) as text
    /// over the PNG images and the video
    #[arg(long)]
    overlay: bool,
}

/// A point `x,y,z` in metres.
fn parse_point(s: &str) -> std::result::Result<[f32; 3], String> {
    let parts: Vec<&str> = s.split(',').collect();
    let numbers: Vec<f32> = (parts.iter())
        .filter_map(|p| p.trim().parse().ok())
        .filter(|v: &f32| v.is_finite())
        .collect();
    numbers
        .try_into()
        .map_err(|_| format!("{s:?}: expected three numbers x,y,z in metres, e.g. 0,1.7,3"))
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
    let frames: Vec<_> = (records.iter())
        .filter(|r| wanted.as_ref().is_none_or(|w| w.contains(&r.frame)))
        .cloned()
        .collect();
    if frames.is_empty() {
        bail!(
            "{}: no logged frame in --frames {}",
            a.log.display(),
            a.frames.unwrap_or_default()
        );
    }
    let out = match (&a.out, &a.video) {
        (Some(out), _) => Some(out.clone()),
        (None, None) => Some(PathBuf::from("replay-out")),
        (None, Some(_)) => None,
    };
    let third = a.third_person || a.camera.is_some() || a.look_at.is_some();
    if !(a.fov > 1.0 && a.fov < 179.0) {
        bail!(
            "--fov {}: give a field of view between 1 and 179 degrees",
            a.fov
        );
    }
    if third && a.view.is_some() {
        bail!("--view picks a wall's view; the third-person camera is one view of its own: give one of --view and --third-person");
    }
    let output = vlf::display::replay::ReplayOutput {
        images: out.as_deref(),
        exr: a.exr,
        video: (a.video.as_deref()).map(|path| vlf::display::replay::VideoOut {
            path,
            view: a.view.as_deref(),
            fps: a.fps,
        }),
        camera: third.then(|| vlf::display::replay::ThirdPerson {
            eye: a.camera.map(glam::Vec3::from),
            look_at: a.look_at.map(glam::Vec3::from),
            fov_y_deg: a.fov,
            size: a.size,
        }),
        overlay: a.overlay.then_some(records.as_slice()),
    };
    let ctx = GpuContext::new()?;
    let (lf, resident) = light_field(&ctx, &meta)?;
    let folders = vlf::display::replay::replay_with(
        (&lf, &resident),
        &meta,
        &frames,
        &output,
        &Bars::default(),
    )?;
    if let (Some(out), Some(first), Some(last)) = (&out, folders.first(), folders.last()) {
        println!(
            "{} frame(s) of {} drawn again into {} ({} .. {})",
            folders.len(),
            a.log.display(),
            out.display(),
            first.display(),
            last.display()
        );
    }
    if let Some(video) = &a.video {
        println!(
            "{} frame(s) of {} in {}",
            frames.len(),
            a.log.display(),
            video.display()
        );
    }
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
