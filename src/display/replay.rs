//! `vlf replay`: the frames of a session log (`crate::study::log`) drawn again offscreen, each view
//! exactly as the live run drew it: the logged pose, wand and left hand through the same walls (the
//! moving objects on them), and the logged settings of every view (eye rays per pixel, the paced
//! tiles, mirror reflections) in place of the pacer's, in its logged condition (its light field,
//! exposure and object switches: `conditions.rs`). Each frame's images go to `OUT/frame-<n>/`
//! as the headless run writes its last frame (`<wall>-<eye>.png`, projectors' outputs, the
//! overview).

use super::conditions::{Conditions, MainField};
use super::frame::{FrameOfViews, Poses, Slots};
use super::headless::{write_kept, Kept};
use super::DisplayConfig;
use crate::error::{Result, VlfError};
use crate::lightfield::{LightField, ResidentLightField};
use crate::study::{FrameRecord, SessionMeta};
use crate::tracking::HeldPoses;
use std::path::Path;

/// Draw `frames` (of the log's `meta`) from the light field the session drew, images into
/// `out`; `progress` hears of each. The folders written, in order.
pub fn replay(
    (lf, resident): (&LightField, &ResidentLightField),
    meta: &SessionMeta,
    frames: &[FrameRecord],
    (out, exr): (&Path, bool),
    progress: &dyn crate::progress::Progress,
) -> Result<Vec<std::path::PathBuf>> {
    let config_path = meta.display_config.as_path();
    let mut config = DisplayConfig::load(config_path)?;
    // the logged settings are drawn as they are: nothing is probed
    config.fit_frame_time = false;
    let poses = config.pose_source(config_path)?;
    // the conditions' light fields made again as the run made them (propagation repeats bit
    // for bit)
    let main = MainField {
        source: &meta.light_field,
        lf,
        resident,
    };
    let conditions = Conditions::prepare(&config, config_path, main, progress)?;
    let mut frame = FrameOfViews::cave(
        (lf, resident),
        &config,
        config_path,
        &poses,
        Slots::PerWall,
        conditions.as_ref(),
    )?;
    let names: Vec<String> = (frame.wall_views().iter())
        .map(|v| v.name(&config))
        .collect();
    if names != meta.views {
        return Err(VlfError::Display(format!(
            "{}: its views are now {names:?}, the session drew {:?}: the display configuration changed since",
            config_path.display(),
            meta.views
        )));
    }
    let mut written = Vec::new();
    progress.begin(
        frames.len() as u64,
        "frames",
        "drawing the logged frames again",
    );
    for (k, record) in frames.iter().enumerate() {
        frame.force_view_settings(record.views.clone());
        // each frame in its logged condition (a log without conditions: as the config starts)
        if !record.condition.is_empty() && frame.condition() != Some(record.condition.as_str()) {
            frame.set_condition(&record.condition)?;
        }
        let held = HeldPoses {
            wand: record.wand,
            left_hand: record.left_hand,
        };
        let poses = Poses::Tracked {
            pose: &record.pose,
            held: &held,
            arrived: None,
        };
        let images = frame.read_back(poses)?;
        let mut kept = Kept::of(&config, frame.wall_views(), images);
        kept.exposure = frame.exposure();
        let dir = out.join(format!("frame-{:06}", record.frame));
        std::fs::create_dir_all(&dir).map_err(|e| VlfError::io(&dir, e))?;
        write_kept(&config, frame.wall_views(), &kept, &dir, exr)?;
        written.push(dir);
        progress.advance_to(k as u64 + 1, &format!("frame {}", record.frame));
    }
    progress.finish();
    Ok(written)
}
