//! Input of a windowed CAVE: gamepads (gilrs) polled every frame; keyboard and mouse arrive
//! as window events (`mod.rs`) and land in the `Navigator`.

use super::App;

impl App<'_> {
    pub(super) fn poll_gamepads(&mut self) -> [f32; 4] {
        let Some(g) = self.gamepads.as_mut() else {
            return [0.0; 4];
        };
        let mut reset = false;
        while let Some(event) = g.next_event() {
            if let gilrs::EventType::ButtonPressed(gilrs::Button::Start, _) = event.event {
                reset = true;
            }
            if let gilrs::EventType::ButtonPressed(gilrs::Button::North, _) = event.event {
                self.navigator.fly = !self.navigator.fly;
            }
        }
        if reset {
            self.navigator.reset();
        }
        let dead = |v: f32| if v.abs() < 0.15 { 0.0 } else { v };
        let mut axes = [0.0f32; 4];
        for (_, pad) in g.gamepads() {
            axes[0] += dead(pad.value(gilrs::Axis::LeftStickX));
            axes[1] -= dead(pad.value(gilrs::Axis::LeftStickY));
            axes[2] += dead(pad.value(gilrs::Axis::RightStickX));
            axes[3] -= dead(pad.value(gilrs::Axis::RightStickY));
        }
        axes
    }
}
