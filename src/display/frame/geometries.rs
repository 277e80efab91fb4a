//! A study's conditions on a frame of views: their light fields bound before the first frame.
//! Those of the `--scene`'s geometry (other light or materials on the same triangles) are added
//! to its renderer; each other geometry (a condition's scene of its own) gets a renderer of its
//! own, made like the first (the moving objects, eye rays per pixel, first hits) and drawing into
//! the same wall or eye images. A switch to another geometry swaps the renderer in use; nothing
//! is made or uploaded at a switch.

use super::{FrameOfViews, Sink};
use crate::display::conditions::{ConditionField, Conditions};
use crate::error::Result;
use crate::gpu::MemoryLedger;
use crate::render::{ObjectsToDraw, Renderer};

impl<'a> FrameOfViews<'a> {
    /// Bind every light field of `conditions` and note where each is (`placement`).
    pub(super) fn bind_conditions(&mut self, conditions: &'a Conditions) -> Result<()> {
        let ledger = MemoryLedger::default();
        let mut placement = vec![(0, 0)];
        for f in &conditions.fields {
            let g = f.geometry;
            if g >= self.parked.len() {
                self.parked.resize_with(g + 1, || None);
                self.parked_pacers.resize_with(g + 1, || None);
            }
            let field = match (g, &mut self.parked[g]) {
                (0, _) => self.renderer.add_light_field(&f.resident, &f.lf, &ledger)?,
                (_, Some(r)) => r.add_light_field(&f.resident, &f.lf, &ledger)?,
                (_, None) => {
                    let r = self.renderer_like(f)?;
                    self.parked[g] = Some(r);
                    0
                }
            };
            placement.push((g, field));
        }
        self.placement = placement;
        // every renderer's view groups for every light field it now has, on the frame's images
        let Self {
            renderer,
            parked,
            sink,
            ..
        } = self;
        for r in std::iter::once(&*renderer).chain(parked.iter().flatten()) {
            match sink {
                Sink::Outputs { outputs, .. } => outputs.bind_renderer(r),
                Sink::Targets(targets) => targets.iter_mut().for_each(|t| r.bind_targets(t)),
            }
        }
        Ok(())
    }

    /// A renderer for `field`'s geometry made as the frame's first: the moving objects (their
    /// probes baked from this light field), eye rays per pixel, first hits, the objects'
    /// shadows and reflections as they are.
    fn renderer_like(&self, field: &ConditionField) -> Result<Renderer> {
        let lighting = self.renderer.object_lighting();
        let to_draw = (self.objects.as_ref().zip(lighting)).map(|(o, lighting)| ObjectsToDraw {
            mesh: o.mesh(),
            lighting,
        });
        let ledger = MemoryLedger::default();
        let mut r = Renderer::with_objects(&field.resident, &field.lf, &ledger, to_draw)?;
        r.set_samples_per_pixel(self.renderer.samples_per_pixel())?;
        r.set_first_hits(self.renderer.first_hits())?;
        r.set_edge_antialiasing(self.renderer.edge_antialiasing())?;
        let (shadows, in_mirrors) = self.object_switches;
        r.set_object_switches(shadows, in_mirrors);
        Ok(r)
    }

    /// Draw with geometry `g`'s renderer from the next view on (bound by `bind_conditions`),
    /// paced by its own pacer (where the frame time is fitted: `fit_frame_time` probes every
    /// geometry before the first frame).
    pub(super) fn use_geometry(&mut self, g: usize) {
        if g == self.geometry {
            return;
        }
        let next = self.parked[g].take().expect("bound with the conditions");
        let previous = std::mem::replace(&mut self.renderer, next);
        self.parked[self.geometry] = Some(previous);
        let pacer = self.parked_pacers[g].take();
        self.parked_pacers[self.geometry] = std::mem::replace(&mut self.pacer, pacer);
        self.geometry = g;
    }
}
