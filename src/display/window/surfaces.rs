//! The windows of a windowed CAVE: which windows a wall gets (per eye, per projector), where
//! they go (monitor, position), their surfaces, the part of a window each eye's image covers,
//! and drawing the views' images onto them every frame.

use super::App;
use crate::display::present::{present_pass, present_pipeline, PresentBinding};
use crate::display::{MonitorRef, Stereo};
use crate::error::{Result, VlfError};
use crate::gpu::types::GpuPresent;
use crate::gpu::GpuContext;
use std::sync::Arc;
use winit::event_loop::ActiveEventLoop;
use winit::window::{Fullscreen, Window};

/// One eye's part of a window and the bindings that put its image there.
pub(super) struct WindowPart {
    /// which part of the window: 0 whole, 1 left/top half, 2 right/bottom half
    part: u8,
    binding: PresentBinding,
}

pub(super) struct WallWindow {
    pub(super) window: Arc<Window>,
    /// the title it opened with (`vlf: <wall>`); the status line is appended to it, and winit
    /// reads no title back on X11 (`Window::title` is empty there)
    pub(super) title: String,
    pub(super) surface: wgpu::Surface<'static>,
    pub(super) config: wgpu::SurfaceConfiguration,
    stereo: Stereo,
    parts: Vec<WindowPart>,
}

/// Where a window goes: its title and size, its monitor's shift from the wall's monitor index
/// and its x offset from the wall's window position.
struct Placement {
    title: String,
    pixels: [u32; 2],
    shift: u32,
    x_offset: i32,
}

impl App<'_> {
    pub(super) fn open_windows(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let monitors: Vec<winit::monitor::MonitorHandle> =
            event_loop.available_monitors().collect();
        let names: Vec<String> = monitors
            .iter()
            .enumerate()
            .map(|(i, m)| m.name().unwrap_or_else(|| format!("monitor {i}")))
            .collect();
        self.config
            .check_outputs(&names)
            .map_err(VlfError::Display)?;
        for (wall_index, wall) in self.config.walls.iter().enumerate() {
            // a wall whose eyes go to separate outputs gets a window per eye; one driven by
            // projectors a window per projector (per eye): each shows what headless writes as
            // <wall>-<eye>-<projector>.png, on the next monitor or beside the previous window
            let mut groups: Vec<(&'static str, Vec<(&'static str, u8)>)> = match wall.stereo {
                Stereo::Mono => vec![("", vec![("mono", 0)])],
                Stereo::Separate => {
                    vec![("left", vec![("left", 0)]), ("right", vec![("right", 0)])]
                }
                Stereo::SideBySide | Stereo::TopBottom => {
                    vec![("", vec![("left", 1), ("right", 2)])]
                }
            };
            // a cluster rank drawing one eye of the wall (`Wall::only_eye`) opens its window only
            let drawn = wall.eyes();
            groups.retain(|(_, eyes)| eyes.iter().all(|e| drawn.iter().any(|d| d.0 == e.0)));
            let outputs: Vec<(Option<usize>, [u32; 2])> = if wall.projectors.is_empty() {
                vec![(None, wall.pixels)]
            } else {
                (wall.projectors.iter().enumerate())
                    .map(|(k, p)| (Some(k), p.pixels))
                    .collect()
            };
            let mut shift = 0;
            let mut x_offset = 0;
            for (suffix, eyes) in groups {
                for &(projector, pixels) in &outputs {
                    let qualifiers: Vec<String> = [
                        (!suffix.is_empty()).then(|| format!("{suffix} eye")),
                        projector.map(|k| format!("projector {}", wall.projectors[k].name)),
                    ]
                    .into_iter()
                    .flatten()
                    .collect();
                    let title = match qualifiers.is_empty() {
                        true => format!("vlf: {}", wall.name),
                        false => format!("vlf: {} ({})", wall.name, qualifiers.join(", ")),
                    };
                    let place = Placement {
                        title,
                        pixels,
                        shift,
                        x_offset,
                    };
                    let title = place.title.clone();
                    let (window, surface, surface_config) =
                        self.create_window(event_loop, &monitors, &names, wall_index, place)?;
                    let parts = eyes
                        .iter()
                        .map(|&(eye, part)| {
                            let slot = self.slot_of(wall_index, eye);
                            self.window_part(slot, projector, part)
                        })
                        .collect::<Result<Vec<_>>>()?;
                    self.windows.push(WallWindow {
                        window,
                        title,
                        surface,
                        config: surface_config,
                        stereo: wall.stereo,
                        parts,
                    });
                    shift += 1;
                    x_offset += pixels[0] as i32;
                }
            }
        }
        Ok(())
    }

    /// The slot (view) of `wall` seen by `eye`.
    fn slot_of(&self, wall: usize, eye: &str) -> usize {
        (self.frame.wall_views().iter())
            .position(|v| v.wall == wall && v.eye == eye)
            .expect("a view per wall and eye")
    }

    /// One window of a wall, placed on its monitor (index + `shift` when there is one) or at
    /// its window position (+ `x_offset`), with its surface configured.
    fn create_window(
        &mut self,
        event_loop: &ActiveEventLoop,
        monitors: &[winit::monitor::MonitorHandle],
        names: &[String],
        wall_index: usize,
        place: Placement,
    ) -> Result<(
        Arc<Window>,
        wgpu::Surface<'static>,
        wgpu::SurfaceConfiguration,
    )> {
        let ctx = self.ctx().clone();
        let wall = &self.config.walls[wall_index];
        let monitor = match &wall.output.monitor {
            Some(MonitorRef::Index(n)) => monitors
                .get((*n + place.shift) as usize)
                .or(monitors.get(*n as usize))
                .cloned(),
            Some(MonitorRef::Name(name)) => monitors
                .iter()
                .zip(names)
                .find(|(_, n)| *n == name)
                .map(|(m, _)| m.clone()),
            None => None,
        };
        let mut attributes = Window::default_attributes()
            .with_title(place.title)
            .with_inner_size(winit::dpi::PhysicalSize::new(
                place.pixels[0],
                place.pixels[1],
            ));
        let origin = monitor
            .as_ref()
            .map(|m| m.position())
            .unwrap_or(winit::dpi::PhysicalPosition::new(0, 0));
        if let Some([x, y]) = wall.output.window {
            attributes = attributes.with_position(winit::dpi::PhysicalPosition::new(
                origin.x + x + place.x_offset,
                origin.y + y,
            ));
        } else {
            attributes = attributes.with_position(origin);
        }
        if wall.output.fullscreen {
            attributes = attributes.with_fullscreen(Some(Fullscreen::Borderless(monitor.clone())));
        }
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| {
            VlfError::Display(format!("wall {:?}: cannot open a window: {e}", wall.name))
        })?);
        let surface = ctx.instance.create_surface(window.clone()).map_err(|e| {
            VlfError::Display(format!(
                "wall {:?}: no GPU surface for its window: {e}",
                wall.name
            ))
        })?;
        if !ctx.adapter.is_surface_supported(&surface) {
            return Err(VlfError::Display(format!(
                "the adapter {} cannot present to wall {:?}'s window",
                ctx.summary.name, wall.name
            )));
        }
        let caps = surface.get_capabilities(&ctx.adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or(caps.formats.first().copied())
            .ok_or_else(|| {
                VlfError::Display(format!(
                    "wall {:?}: the window's surface offers no format",
                    wall.name
                ))
            })?;
        let size = window.inner_size();
        let surface_config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&ctx.device, &surface_config);
        if self.present.is_none() {
            self.present = Some(present_pipeline(&ctx, format)?);
        }
        Ok((window, surface, surface_config))
    }

    /// One eye's part of a window: it shows `projector`'s output of `slot` (None: the wall).
    fn window_part(
        &mut self,
        slot: usize,
        projector: Option<usize>,
        part: u8,
    ) -> Result<WindowPart> {
        let ctx = self.ctx().clone();
        let overlay = self.overlay_view().clone();
        let present = (self.present.as_ref()).expect("present pipeline made with the first window");
        let outputs = (self.frame.outputs())
            .ok_or_else(|| VlfError::Display("the walls' views have no outputs".into()))?;
        let binding = PresentBinding::new(&ctx, present, outputs.shown(slot, projector), &overlay);
        Ok(WindowPart { part, binding })
    }

    /// Each window's parts drawn from the views' images onto its next surface texture, and
    /// submitted; the textures to present (a window without one this frame is left out).
    /// `flash`: the latency test's walls instead of the views (Some(true) white, else black).
    pub(super) fn draw_windows(
        &mut self,
        ctx: &GpuContext,
        flash: Option<bool>,
    ) -> Result<Vec<wgpu::SurfaceTexture>> {
        let present = self.present.as_ref().expect("windows open");
        // the condition's exposure on the display's (`--exposure`)
        let exposure = self.options.exposure * self.frame.exposure();
        let mut outputs = Vec::new();
        for w in &mut self.windows {
            let Some(texture) = next_texture(ctx, w)? else {
                continue;
            };
            let (width, height) = (w.config.width as f32, w.config.height as f32);
            for p in &w.parts {
                let (origin, size) = viewport(w.stereo, p.part, width, height);
                let params = GpuPresent {
                    viewport_origin: origin,
                    viewport_size: size,
                    exposure,
                    encode_srgb: (!present.surface_is_srgb) as u32,
                    show_overlay: (self.status.is_some() && p.part < 2) as u32,
                    _pad0: 0,
                };
                p.binding.set(ctx, &params);
            }
            let view = texture.texture.create_view(&Default::default());
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let clear = match flash {
                    Some(true) => wgpu::Color::WHITE,
                    _ => wgpu::Color::BLACK,
                };
                let mut pass = present_pass(&mut encoder, &view, wgpu::LoadOp::Clear(clear));
                pass.set_pipeline(&present.pipeline);
                for p in w.parts.iter().filter(|_| flash.is_none()) {
                    let (origin, size) = viewport(w.stereo, p.part, width, height);
                    pass.set_viewport(origin[0], origin[1], size[0], size[1], 0.0, 1.0);
                    pass.set_bind_group(0, &p.binding.bind_group, &[]);
                    pass.draw(0..3, 0..1);
                }
            }
            ctx.queue.submit([encoder.finish()]);
            outputs.push(texture);
        }
        Ok(outputs)
    }
}

/// The window's next surface texture; None when there is none this frame (the surface is
/// reconfigured when it went out of date).
pub(super) fn next_texture(
    ctx: &GpuContext,
    w: &mut WallWindow,
) -> Result<Option<wgpu::SurfaceTexture>> {
    match w.surface.get_current_texture() {
        wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
            Ok(Some(t))
        }
        wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
            let size = w.window.inner_size();
            w.config.width = size.width.max(1);
            w.config.height = size.height.max(1);
            w.surface.configure(&ctx.device, &w.config);
            Ok(None)
        }
        wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => Ok(None),
        wgpu::CurrentSurfaceTexture::Validation => Err(VlfError::Display(
            "the window's surface failed validation".into(),
        )),
    }
}

/// The eye's part of a window: (origin, size) in pixels.
fn viewport(stereo: Stereo, part: u8, width: f32, height: f32) -> ([f32; 2], [f32; 2]) {
    match (stereo, part) {
        (Stereo::SideBySide, 1) => ([0.0, 0.0], [width / 2.0, height]),
        (Stereo::SideBySide, _) => ([width / 2.0, 0.0], [width / 2.0, height]),
        (Stereo::TopBottom, 1) => ([0.0, 0.0], [width, height / 2.0]),
        (Stereo::TopBottom, _) => ([0.0, height / 2.0], [width, height / 2.0]),
        _ => ([0.0, 0.0], [width, height]),
    }
}
