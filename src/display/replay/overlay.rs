//! The session's events as text over a replayed frame (`vlf replay --overlay`): the frame number,
//! the block and trial, the frame's time, and the frame's events, or the latest event for
//! `EVENT_HOLD_S` after it, in DejaVu Sans (the `dejavu` crate's font, as the windows' status line)
//! on a dark band in the image's top-left corner, drawn on the CPU into the 8-bit image. Nothing
//! outside the band changes.

use crate::study::FrameRecord;
use ab_glyph::{Font, FontRef, PxScale, ScaleFont};

/// How long an event stays over the frames after its own, seconds of the log's `time_s`.
pub const EVENT_HOLD_S: f64 = 1.0;

/// The overlay's lines for `record`, with the events of `log` (the session's frames in order,
/// `record` among them or not) before it.
pub fn lines(log: &[FrameRecord], record: &FrameRecord) -> Vec<String> {
    let mut first = format!(
        "frame {}  block {} trial {}  t {:.3} s",
        record.frame, record.block, record.trial, record.time_s
    );
    if !record.condition.is_empty() {
        first.push_str(&format!("  condition {}", record.condition));
    }
    let mut lines = vec![first];
    if !record.events.is_empty() {
        lines.push(record.events.clone());
        return lines;
    }
    let before = log.partition_point(|r| r.frame < record.frame);
    let latest = log[..before]
        .iter()
        .rev()
        .take_while(|r| record.time_s - r.time_s <= EVENT_HOLD_S)
        .find(|r| !r.events.is_empty());
    if let Some(r) = latest {
        lines.push(format!(
            "{} (frame {}, {:.2} s ago)",
            r.events,
            r.frame,
            record.time_s - r.time_s
        ));
    }
    lines
}

/// `lines` drawn over the top-left corner of `image`: light text on a dark band, the text's
/// height a twentieth of the image's (10 pixels at least). The band, `[x0, y0, x1, y1)`: the
/// only pixels changed.
pub fn draw(image: &mut image::RgbImage, lines: &[String]) -> [u32; 4] {
    let (w, h) = image.dimensions();
    let Ok(font) = FontRef::try_from_slice(dejavu::sans::regular()) else {
        return [0; 4];
    };
    let scale = PxScale::from((h as f32 / 20.0).max(10.0));
    let scaled = font.as_scaled(scale);
    let (pad, line) = (scale.y * 0.3, scaled.height() + scaled.line_gap());
    // each glyph's coverage, over the band
    let mut coverage = vec![0f32; (w * h) as usize];
    let mut widest = 0f32;
    for (n, text) in lines.iter().enumerate() {
        let baseline = pad + scaled.ascent() + line * n as f32;
        let mut x = pad;
        for c in text.chars() {
            let id = scaled.glyph_id(c);
            let glyph = id.with_scale_and_position(scale, ab_glyph::point(x, baseline));
            x += scaled.h_advance(id);
            let Some(outline) = font.outline_glyph(glyph) else {
                continue;
            };
            let b = outline.px_bounds();
            outline.draw(|gx, gy, c| {
                let (px, py) = (b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64);
                if (0..w as i64).contains(&px) && (0..h as i64).contains(&py) {
                    let i = (py as u32 * w + px as u32) as usize;
                    coverage[i] = coverage[i].max(c);
                }
            });
        }
        widest = widest.max(x);
    }
    let x1 = ((widest + pad).ceil() as u32).min(w);
    let y1 = ((pad * 2.0 + line * lines.len() as f32).ceil() as u32).min(h);
    for y in 0..y1 {
        for x in 0..x1 {
            let c = coverage[(y * w + x) as usize];
            let p = image.get_pixel_mut(x, y);
            for (k, v) in p.0.iter_mut().enumerate() {
                // the scene dimmed to a quarter under the band, the text light yellow over it
                let text = [255.0, 255.0, 160.0][k];
                *v = (*v as f32 * 0.25 * (1.0 - c) + text * c).round() as u8;
            }
        }
    }
    [0, 0, x1, y1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::log::Drawn;

    fn record(frame: u64, time_s: f64, events: &str) -> FrameRecord {
        FrameRecord {
            frame,
            time_s,
            drawn: Drawn::Timed,
            pose: crate::tracking::Pose::new(glam::Vec3::ZERO, glam::Vec3::ZERO, 0.0),
            wand: None,
            left_hand: None,
            targets: Default::default(),
            gpu_ms: None,
            cpu_ms: None,
            block: 2,
            trial: 5,
            pose_to_submit_ms: None,
            pose_to_photon_ms: None,
            object_time_s: None,
            raw: Default::default(),
            views: Vec::new(),
            events: events.into(),
            condition: String::new(),
            objects: None,
            flash: None,
            eyes: Vec::new(),
        }
    }

    #[test]
    fn an_event_stays_for_a_second_after_its_frame() {
        let log: Vec<FrameRecord> = (0..30)
            .map(|f| record(f, f as f64 * 0.1, if f == 10 { "stimulus on" } else { "" }))
            .collect();
        assert_eq!(lines(&log, &log[5]).len(), 1);
        assert_eq!(lines(&log, &log[10])[1], "stimulus on");
        assert!(lines(&log, &log[19])[1].starts_with("stimulus on (frame 10, 0.90 s ago)"));
        assert_eq!(lines(&log, &log[21]).len(), 1);
        assert!(lines(&log, &log[0])[0].contains("frame 0  block 2 trial 5"));
    }

    #[test]
    fn the_text_changes_only_its_band() {
        let mut image = image::RgbImage::from_pixel(200, 120, image::Rgb([90, 140, 200]));
        let before = image.clone();
        let band = draw(&mut image, &["frame 12".into(), "trial 3 begins".into()]);
        let [_, _, x1, y1] = band;
        assert!(x1 > 20 && x1 < 200 && y1 > 20 && y1 < 120, "{band:?}");
        let mut inside = 0;
        for (x, y, p) in image.enumerate_pixels() {
            match x < x1 && y < y1 {
                true => inside += usize::from(p != before.get_pixel(x, y)),
                false => assert_eq!(p, before.get_pixel(x, y), "({x}, {y})"),
            }
        }
        assert!(inside > 100, "{inside} pixels of text and band");
    }
}
