//! Navigation added to the tracked pose, shared by the windowed CAVE and the headset: keys,
//! mouse drag, gamepad or thumbstick axes and the tracked wand's joystick move and turn the room
//! in the world.

use super::live::LiveState;
use super::pose::Pose;
use glam::{Quat, Vec3};
use std::collections::HashSet;
use winit::keyboard::KeyCode;

/// Navigation added to the tracked pose: the room moved and turned in the world.
#[derive(Default)]
pub(crate) struct Navigator {
    offset: Vec3,
    yaw_deg: f32,
    pub(crate) fly: bool,
    pub(crate) keys: HashSet<KeyCode>,
    pub(crate) dragging: bool,
    pub(crate) last_cursor_x: Option<f64>,
    pub(crate) mouse_turn_deg: f32,
    /// the tracked wand's buttons last frame (for the reset button's press)
    wand_buttons: u64,
}

impl Navigator {
    /// Move by keys held and by stick axes `pad` = [strafe right, back, turn right, sink].
    pub(crate) fn step(&mut self, dt: f32, nav: &super::Navigation, pad: [f32; 4], base_yaw: f32) {
        let key = |k: KeyCode| if self.keys.contains(&k) { 1.0f32 } else { 0.0 };
        let forward = key(KeyCode::KeyW) + key(KeyCode::ArrowUp)
            - key(KeyCode::KeyS)
            - key(KeyCode::ArrowDown)
            - pad[1];
        let strafe = key(KeyCode::KeyD) - key(KeyCode::KeyA) + pad[0];
        let turn = key(KeyCode::KeyQ) + key(KeyCode::ArrowLeft)
            - key(KeyCode::KeyE)
            - key(KeyCode::ArrowRight)
            - pad[2];
        let rise = key(KeyCode::KeyR) - key(KeyCode::KeyF) - pad[3];
        self.yaw_deg += turn * nav.turn_speed_deg * dt + std::mem::take(&mut self.mouse_turn_deg);
        let rotation = Quat::from_rotation_y((base_yaw + self.yaw_deg).to_radians());
        let ahead = rotation * Vec3::NEG_Z;
        let right = rotation * Vec3::X;
        let mut velocity = ahead * forward + right * strafe;
        if self.fly || nav.fly {
            velocity += Vec3::Y * rise;
        }
        if velocity.length() > 1.0 {
            velocity = velocity.normalize();
        }
        self.offset += velocity * nav.walk_speed * dt;
    }

    pub(crate) fn apply(&self, base: Pose) -> Pose {
        Pose {
            room_position: base.room_position + self.offset,
            room_yaw_deg: base.room_yaw_deg + self.yaw_deg,
            ..base
        }
    }

    pub(crate) fn reset(&mut self) {
        self.offset = Vec3::ZERO;
        self.yaw_deg = 0.0;
    }

    /// The tracked wand (`wand.rs`): its reset button resets; while the source is live its
    /// joystick flies along the wand and turns about the head (a quiet source's last joystick
    /// value is not acted on).
    pub(crate) fn wand(&mut self, state: &LiveState, live: bool, nav: &super::Navigation, dt: f32) {
        if super::wand::pressed(self.wand_buttons, state.buttons, nav.wand_reset_button) {
            self.reset();
        }
        self.wand_buttons = state.buttons;
        if let (Some(wand), true) = (&state.wand, live) {
            let pose = self.apply(state.pose);
            let (position, yaw) =
                super::wand::step(&pose, wand, state.joystick, nav, self.fly || nav.fly, dt);
            self.offset += position - pose.room_position;
            self.yaw_deg += yaw - pose.room_yaw_deg;
        }
    }
}
