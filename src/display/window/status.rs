//! The status line a windowed CAVE shows over each wall's top-left corner when tracking goes
//! quiet or waits for its source (and in the window titles), drawn with DejaVu Sans.

use super::App;

const OVERLAY_SIZE: [u32; 2] = [720, 30];

/// A line on stdout, flushed at once (a watcher reads it while the windows are up).
pub(super) fn say(line: &str) {
    use std::io::Write;
    println!("{line}");
    let _ = std::io::stdout().flush();
}

/// The status line as RGBA8 (white text on a translucent black band), with DejaVu Sans.
fn rasterise_status(text: &str) -> Vec<u8> {
    use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
    let [w, h] = OVERLAY_SIZE;
    let mut pixels = vec![0u8; (w * h * 4) as usize];
    let Ok(font) = FontRef::try_from_slice(dejavu::sans::regular()) else {
        return pixels;
    };
    let scale = PxScale::from(16.0);
    let scaled = font.as_scaled(scale);
    let mut x = 8.0f32;
    let baseline = 6.0 + scaled.ascent();
    let mut coverage = vec![0f32; (w * h) as usize];
    for c in text.chars() {
        let glyph = scaled.scaled_glyph(c);
        let advance = scaled.h_advance(glyph.id);
        let glyph = glyph
            .id
            .with_scale_and_position(scale, ab_glyph::point(x, baseline));
        if let Some(outline) = font.outline_glyph(glyph) {
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, c| {
                let (px, py) = (
                    bounds.min.x as i32 + gx as i32,
                    bounds.min.y as i32 + gy as i32,
                );
                if px >= 0 && py >= 0 && (px as u32) < w && (py as u32) < h {
                    let i = (py as u32 * w + px as u32) as usize;
                    coverage[i] = coverage[i].max(c);
                }
            });
        }
        x += advance;
    }
    let band = (x + 8.0).min(w as f32) as u32;
    for py in 0..h {
        for px in 0..band {
            let i = (py * w + px) as usize;
            let c = coverage[i];
            let v = (255.0 * c) as u8;
            pixels[i * 4..i * 4 + 4].copy_from_slice(&[
                v,
                v,
                (255.0 * c * 0.6) as u8,
                (150.0 + 105.0 * c) as u8,
            ]);
        }
    }
    pixels
}

impl App<'_> {
    /// After a frame is presented on `windows` windows: the first frame, or a new condition's
    /// status line, is on screen now. Said on stdout ("first frame on screen", "status line on
    /// screen: ...") for whoever watches the run (a test takes its screenshots then); a status
    /// line is kept for the report.
    pub(super) fn announce_presented(&mut self, windows: usize) {
        if self.shown == 1 {
            say(&format!("first frame on screen ({windows} window(s))"));
        }
        if let Some(t) = self.status_to_announce.take() {
            say(&format!("status line on screen: {t}"));
            self.status_messages.push(t);
        }
    }

    pub(super) fn overlay_view(&mut self) -> &wgpu::TextureView {
        if self.overlay.is_none() {
            let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
            let texture = crate::render::texture_2d(
                &self.ctx().device,
                "status overlay",
                OVERLAY_SIZE,
                wgpu::TextureFormat::Rgba8Unorm,
                usage,
            );
            let view = texture.create_view(&Default::default());
            self.overlay = Some((texture, view));
        }
        &self.overlay.as_ref().unwrap().1
    }

    pub(super) fn set_status(&mut self, text: Option<String>) {
        if text == self.status {
            return;
        }
        // log a new condition once; the seconds counting up only redraw the line
        let kind = |t: &Option<String>| {
            t.as_ref().map(|t| {
                t.split(|c: char| c.is_ascii_digit())
                    .next()
                    .unwrap_or_default()
                    .to_string()
            })
        };
        if let (Some(t), true) = (&text, kind(&text) != kind(&self.status)) {
            log::warn!("{t}");
            self.status_to_announce = Some(t.clone());
        }
        for w in &self.windows {
            w.window.set_title(&match &text {
                Some(t) => format!("{} | {t}", w.title),
                None => w.title.clone(),
            });
        }
        if let Some(t) = &text {
            let pixels = rasterise_status(t);
            let (texture, _) = self
                .overlay
                .as_ref()
                .expect("overlay made with the first window");
            self.ctx().queue.write_texture(
                texture.as_image_copy(),
                &pixels,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(OVERLAY_SIZE[0] * 4),
                    rows_per_image: Some(OVERLAY_SIZE[1]),
                },
                wgpu::Extent3d {
                    width: OVERLAY_SIZE[0],
                    height: OVERLAY_SIZE[1],
                    depth_or_array_layers: 1,
                },
            );
        }
        self.status = text;
    }
}
