//! Wand navigation (pure functions, applied by the CAVE's frame loop): pushing the tracked
//! wand's joystick forward flies along the direction the wand points, sideways turns the world
//! about the viewer's head, and a button resets. In walk mode (`[navigation] fly = false`,
//! G toggles) the motion stays horizontal, so the head keeps its height.

use super::live::WandPose;
use super::tracking::Pose;
use super::Navigation;
use glam::{Quat, Vec3};

/// Joystick values below this are taken as zero (a Flystick's stick rests near, not at, 0).
pub const DEAD_ZONE: f32 = 0.1;

fn dead(v: f32) -> f32 {
    if v.abs() < DEAD_ZONE {
        0.0
    } else {
        v.clamp(-1.0, 1.0)
    }
}

/// Where the room stands in the world after `dt` seconds of the joystick at `joystick`
/// (x right, y forward; -1..1) with the wand at `wand` (room): (room position, room yaw in
/// degrees). Forward moves at `nav.walk_speed` along the wand's pointing direction (its -z),
/// levelled unless `fly`; right turns right at `nav.turn_speed_deg`, about the tracked head
/// (its place in the world stays where it is).
pub fn step(pose: &Pose, wand: &WandPose, joystick: [f32; 2], nav: &Navigation, fly: bool, dt: f32) -> (Vec3, f32) {
    let [x, y] = joystick.map(dead);
    let room = Quat::from_rotation_y(pose.room_yaw_deg.to_radians());
    let mut direction = room * (wand.rotation * Vec3::NEG_Z);
    if !fly {
        direction.y = 0.0;
    }
    let direction = direction.normalize_or_zero();
    let moved = pose.room_position + direction * y * nav.walk_speed * dt;
    let head = moved + room * pose.head;
    let yaw = pose.room_yaw_deg - x * nav.turn_speed_deg * dt;
    (head - Quat::from_rotation_y(yaw.to_radians()) * pose.head, yaw)
}

/// Whether `button` went down between two button states (bit i: button i).
pub fn pressed(before: u64, now: u64, button: u32) -> bool {
    button < 64 && now & (1 << button) != 0 && before & (1 << button) == 0
}
