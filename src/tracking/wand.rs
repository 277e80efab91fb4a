//! Wand navigation (pure functions, applied by the CAVE's frame loop): pushing the tracked
//! wand's joystick forward flies along the direction the wand points, sideways turns the world
//! about the viewer's head, and a button resets. In walk mode (`[navigation] fly = false`,
//! G toggles) the motion stays horizontal, so the head keeps its height.

use super::pose::{Pose, WandPose};
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
pub fn step(
    pose: &Pose,
    wand: &WandPose,
    joystick: [f32; 2],
    nav: &Navigation,
    fly: bool,
    dt: f32,
) -> (Vec3, f32) {
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
    (
        head - Quat::from_rotation_y(yaw.to_radians()) * pose.head,
        yaw,
    )
}

/// Whether `button` went down between two button states (bit i: button i).
pub fn pressed(before: u64, now: u64, button: u32) -> bool {
    button < 64 && now & (1 << button) != 0 && before & (1 << button) == 0
}

/// A wand, hand or target given in a configuration or keyframe, its keys named with `key` before
/// them ("wand_", "left_hand_", or "" in a `[[tracking.target]]` table): `<key>position` (room
/// metres) and its orientation as angles (`<key>yaw_deg` about the room's up axis, positive turns
/// left; then `<key>pitch_deg`, positive points up) or a quaternion `<key>orientation = [x, y, z,
/// w]`; pointing along the room's -z when neither is given. None without a position; `at` names
/// the keys' table in errors.
pub fn held_pose(
    key: &str,
    position: Option<[f32; 3]>,
    angles: [Option<f32>; 2],
    orientation: Option<[f32; 4]>,
    at: &str,
) -> Result<Option<WandPose>, String> {
    let Some(position) = position else {
        if orientation.is_some() || angles.iter().any(Option::is_some) {
            return Err(format!(
                "{at}{key}position: an orientation is given without the position"
            ));
        }
        return Ok(None);
    };
    if position.iter().any(|x| !x.is_finite()) {
        return Err(format!(
            "{at}{key}position: {position:?} must be finite (room metres)"
        ));
    }
    let rotation = match orientation {
        Some(_) if angles.iter().any(Option::is_some) => {
            return Err(format!("{at}{key}orientation: give the orientation either as a quaternion or as {key}yaw_deg/{key}pitch_deg, not both"));
        }
        Some(q) => {
            let q = Quat::from_array(q);
            if !q.is_finite() || q.length() < 1e-3 {
                return Err(format!("{at}{key}orientation: {:?} is not a rotation (a finite quaternion [x, y, z, w] of non-zero length)", q.to_array()));
            }
            q.normalize()
        }
        None => {
            let [yaw, pitch] = angles.map(|a| a.unwrap_or(0.0));
            if !(yaw.is_finite() && pitch.is_finite()) {
                return Err(format!(
                    "{at}{key}yaw_deg/{key}pitch_deg: must be finite numbers of degrees"
                ));
            }
            Quat::from_rotation_y(yaw.to_radians()) * Quat::from_rotation_x(pitch.to_radians())
        }
    };
    Ok(Some(WandPose {
        position: Vec3::from(position),
        rotation,
    }))
}
