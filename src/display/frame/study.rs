//! A study's state on a frame of views as a cluster shares it (`crate::framelock::StudyState`):
//! rank 0 reads it off its frame after its session's changes, every other rank sets it on its
//! own, so that every wall switches condition, shows or hides an object, and turns shadows or
//! reflections on or off in the same frame.

use super::FrameOfViews;
use crate::display::conditions::Conditions;
use crate::error::{Result, VlfError};
use crate::framelock::StudyState;
use crate::study::log::ObjectSwitches;

/// How many moving objects' show/hide state a cluster's frame state carries (one bit each).
pub const SHARED_OBJECTS: usize = 64;

impl<'a> FrameOfViews<'a> {
    /// A study's `conditions` on a frame made without them: their light fields bound (those of
    /// other geometry on renderers of their own, `geometries.rs`), the initial condition in
    /// effect from the next frame.
    pub fn use_conditions(&mut self, conditions: &'a Conditions) -> Result<()> {
        self.bind_conditions(conditions)?;
        self.conditions = Some(conditions);
        self.set_condition(&conditions.list[conditions.initial].name)
    }

    /// The study's state this frame draws with: its condition, the moving objects hidden (bit
    /// k: the display's object k), their shadows and reflections; `flash` and `stop` as the
    /// session has them.
    pub fn study_state(&self, flash: Option<bool>, stop: bool) -> StudyState {
        let switches = self.object_switches();
        let objects_hidden = (self.object_names().iter().enumerate())
            .filter(|(k, name)| *k < SHARED_OBJECTS && switches.hidden.contains(name))
            .fold(0u64, |bits, (k, _)| bits | 1 << k);
        StudyState {
            condition: self.condition.map(|k| k as u32),
            objects_hidden,
            shadows: switches.shadows,
            reflections: switches.reflections,
            flash,
            stop,
        }
    }

    /// Rank 0's study state on this rank's frame, from the next frame drawn: its condition
    /// (rebound only where it changed) and the moving objects' switches.
    pub fn follow_study(&mut self, study: &StudyState) -> Result<()> {
        if let (Some(k), Some(conditions)) = (study.condition, self.conditions) {
            if self.condition != Some(k as usize) {
                let c = conditions.list.get(k as usize).ok_or_else(|| {
                    VlfError::Display(format!(
                        "rank 0 switched to condition {k}, this rank's display has {} conditions: every rank must load the same display config",
                        conditions.list.len()
                    ))
                })?;
                let name = c.name.clone();
                self.set_condition(&name)?;
            }
        }
        let switches = ObjectSwitches {
            hidden: (self.object_names().into_iter().enumerate())
                .filter(|(k, _)| *k < SHARED_OBJECTS && study.objects_hidden >> k & 1 == 1)
                .map(|(_, name)| name)
                .collect(),
            shadows: study.shadows,
            reflections: study.reflections,
        };
        if switches != self.object_switches() {
            self.set_object_switches(&switches);
        }
        Ok(())
    }
}
