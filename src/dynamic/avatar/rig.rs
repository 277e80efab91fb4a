//! The rig: from a tracked head and hands to every joint's world transform.
//!
//! - The eyes' point (OpenXR's view origin, between the eyes) sits at a fixed offset from the
//!   head joint, read from the bind pose: over the vertices that the head (or a joint below
//!   it) moves most, 45% of the way from the head joint up to the top of the head and 70% of
//!   the way from the head joint forward to the front of the face (+z), at the head joint's x.
//! - The body stands upright under the head with its yaw following the head's: model space
//!   (+y up, facing +z) is turned about +y by the head's yaw plus half a turn (OpenXR looks
//!   along -z), and placed so that the posed eyes' point lands on the tracked head. So the
//!   body shifts a little as the head pitches about its joint, and a participant who crouches
//!   gets an avatar that sinks into the floor (the legs have no IK yet).
//! - The head joint takes the head's full orientation, its pitch and roll relative to the body.
//! - Each arm: analytic two-bone IK from the upper arm's joint to the hand target, the elbow
//!   bent towards a pole down, outwards and back (model space `(±0.4, -1, -0.4)`); out of reach
//!   the arm is straight and points at the target. The hand joint takes the tracked hand's
//!   orientation: the wand's -z along the forearm-to-hand bone of the bind pose, its +y along
//!   the model's forward (+z, the thumb's side in a T- or A-pose) across that bone.
//! - An untracked hand: the arm hangs, reaching 98% of its length down and a little out from
//!   the shoulder, the hand at its bind pose relative to the forearm.

use super::ik;
use super::names::{self, Role};
use super::skeleton::Skeleton;
use super::SkinnedMesh;
use glam::{Affine3A, Mat3, Quat, Vec3};
use std::f32::consts::PI;

/// One arm's joints and what the rig needs of its bind pose.
struct Arm {
    upper: usize,
    fore: usize,
    hand: usize,
    upper_length: f32,
    fore_length: f32,
    /// the bind pose's unit bone directions (upper arm -> forearm, forearm -> hand), model space
    upper_dir: Vec3,
    fore_dir: Vec3,
    /// the elbow's pole, model space
    pole: Vec3,
    /// the model's outward direction on this side (+x for the left, glTF avatars face +z)
    out: Vec3,
    /// the hand joint's bind rotation relative to the grip frame (wand -z along the hand)
    hand_from_grip: Quat,
}

pub(super) struct Rig {
    /// the joint of each of `Role::ALL`, where the skin has one
    roles: [Option<usize>; 9],
    head: usize,
    /// the head joint's bind rotation turned half a turn about +y: its world rotation is the
    /// tracked view's times this (an OpenXR view looks along -z, the model along +z)
    head_from_view: Quat,
    /// the eyes' point in the head joint's frame
    eye_in_head: Vec3,
    /// the eyes' point and the top of the head in model space, and the lowest vertex's height
    pub eyes: Vec3,
    pub top: f32,
    pub floor: f32,
    arms: [Arm; 2],
}

impl Rig {
    /// The rig for a skeleton, or what it lacks (an error message without the file's name).
    pub fn new(skel: &Skeleton, mesh: &SkinnedMesh) -> std::result::Result<Rig, String> {
        let roles = Role::ALL.map(|r| names::find(&skel.names, r));
        let role = |r: Role| {
            Role::ALL
                .iter()
                .position(|&x| x == r)
                .and_then(|i| roles[i])
        };
        let missing: Vec<String> = Role::REQUIRED
            .iter()
            .filter(|&&r| role(r).is_none())
            .map(|r| format!("{} (or {})", r.name(), alternatives(*r)))
            .collect();
        if !missing.is_empty() {
            let shown: Vec<&str> = skel.names.iter().take(60).map(String::as_str).collect();
            return Err(format!(
                "the skin has no joint for {}; its joints are: {}{}",
                missing.join(", "),
                shown.join(", "),
                if skel.names.len() > 60 { ", ..." } else { "" }
            ));
        }
        let get = |r: Role| role(r).unwrap_or(0);
        let head = get(Role::Head);
        let left = arm(
            skel,
            [Role::UpperArmLeft, Role::ForearmLeft, Role::HandLeft].map(get),
            Vec3::X,
        )?;
        let right = arm(
            skel,
            [Role::UpperArmRight, Role::ForearmRight, Role::HandRight].map(get),
            Vec3::NEG_X,
        )?;
        let (eyes, top, floor) = eyes_of(skel, mesh, head);
        let view = Quat::from_rotation_y(PI);
        Ok(Rig {
            roles,
            head,
            head_from_view: view * skel.bind_rotation(head),
            eye_in_head: skel.inverse_bind[head].transform_point3(eyes),
            eyes,
            top,
            floor,
            arms: [left, right],
        })
    }

    pub fn joint(&self, role: Role) -> Option<usize> {
        Role::ALL
            .iter()
            .position(|&x| x == role)
            .and_then(|i| self.roles[i])
    }

    /// Every joint's world transform for a tracked head and hands.
    pub fn pose(
        &self,
        skel: &Skeleton,
        head: Affine3A,
        hands: [Option<Affine3A>; 2],
    ) -> Vec<Affine3A> {
        let (_, view, at) = head.to_scale_rotation_translation();
        let view = view.normalize();
        let body_turn = Quat::from_rotation_y(yaw(view) + PI);
        let mut overrides = vec![None; skel.len()];
        overrides[self.head] = Some((body_turn.inverse() * view * self.head_from_view).normalize());
        let first = skel.forward(&overrides);
        let eyes = first[self.head].transform_point3(self.eye_in_head);
        let body = Affine3A::from_rotation_translation(body_turn, at - body_turn * eyes);
        let to_model = body.inverse();
        for (arm, hand) in self.arms.iter().zip(hands) {
            let shoulder: Vec3 = first[arm.upper].translation.into();
            let reach = arm.upper_length + arm.fore_length;
            let target = match hand {
                Some(h) => to_model.transform_point3(h.translation.into()),
                None => shoulder + (Vec3::NEG_Y + 0.12 * arm.out).normalize() * 0.98 * reach,
            };
            let (elbow, wrist) = ik::two_bone(
                shoulder,
                arm.upper_length,
                arm.fore_length,
                target,
                arm.pole,
            );
            let upper_rest = skel.bind_rotation(arm.upper);
            let upper_to = (elbow - shoulder).try_normalize().unwrap_or(arm.upper_dir);
            overrides[arm.upper] = Some(ik::aim(upper_rest, arm.upper_dir, upper_to, arm.pole));
            let fore_rest = skel.bind_rotation(arm.fore);
            let fore_to = (wrist - elbow).try_normalize().unwrap_or(upper_to);
            overrides[arm.fore] = Some(ik::aim(fore_rest, arm.fore_dir, fore_to, arm.pole));
            if let Some(h) = hand {
                let (_, grip, _) = h.to_scale_rotation_translation();
                overrides[arm.hand] =
                    Some((body_turn.inverse() * grip.normalize() * arm.hand_from_grip).normalize());
            }
        }
        skel.forward(&overrides)
            .into_iter()
            .map(|p| body * p)
            .collect()
    }
}

/// The head's yaw: the angle about +y that turns -z to its horizontal forward direction (the
/// top of the head's direction when it looks straight up or down).
fn yaw(view: Quat) -> f32 {
    let forward = view * Vec3::NEG_Z;
    let mut flat = Vec3::new(forward.x, 0.0, forward.z);
    if flat.length() < 1e-4 {
        let up = view * Vec3::Y;
        let sign = if forward.y < 0.0 { 1.0 } else { -1.0 };
        flat = sign * Vec3::new(up.x, 0.0, up.z);
    }
    if flat.length() < 1e-6 {
        return 0.0;
    }
    (-flat.x).atan2(-flat.z)
}

/// Other names accepted for a joint, for an error message.
fn alternatives(role: Role) -> String {
    match role {
        Role::Head => "mixamorig:Head".to_string(),
        Role::UpperArmLeft => "mixamorig:LeftArm, upperarm_l, leftUpperArm".to_string(),
        Role::ForearmLeft => "mixamorig:LeftForeArm, lowerarm_l, leftLowerArm".to_string(),
        Role::HandLeft => "mixamorig:LeftHand, leftHand".to_string(),
        Role::UpperArmRight => "mixamorig:RightArm, upperarm_r, rightUpperArm".to_string(),
        Role::ForearmRight => "mixamorig:RightForeArm, lowerarm_r, rightLowerArm".to_string(),
        Role::HandRight => "mixamorig:RightHand, rightHand".to_string(),
        other => other.aliases().join(", "),
    }
}

fn arm(
    skel: &Skeleton,
    [upper, fore, hand]: [usize; 3],
    out: Vec3,
) -> std::result::Result<Arm, String> {
    let side = if out.x > 0.0 { "left" } else { "right" };
    if !skel.descends(fore, upper) || !skel.descends(hand, fore) || upper == fore || fore == hand {
        return Err(format!(
            "the {side} arm's joints {}, {}, {} are not a chain (each below the one before)",
            skel.names[upper], skel.names[fore], skel.names[hand]
        ));
    }
    let (s, e, w) = (
        skel.bind_position(upper),
        skel.bind_position(fore),
        skel.bind_position(hand),
    );
    let (upper_length, fore_length) = ((e - s).length(), (w - e).length());
    if upper_length < 1e-4 || fore_length < 1e-4 {
        return Err(format!(
            "the {side} arm's bones are too short to bend ({upper_length} m, {fore_length} m)"
        ));
    }
    let fore_dir = (w - e) / fore_length;
    let thumb = ik::reference(Vec3::Z, fore_dir);
    let back = -fore_dir;
    let grip = Quat::from_mat3(&Mat3::from_cols(thumb.cross(back), thumb, back)).normalize();
    Ok(Arm {
        upper,
        fore,
        hand,
        upper_length,
        fore_length,
        upper_dir: (e - s) / upper_length,
        fore_dir,
        pole: Vec3::new(0.4 * out.x, -1.0, -0.4).normalize(),
        out,
        hand_from_grip: (grip.inverse() * skel.bind_rotation(hand)).normalize(),
    })
}

/// The eyes' point, the top of the head and the floor (lowest vertex) in model space.
fn eyes_of(skel: &Skeleton, mesh: &SkinnedMesh, head: usize) -> (Vec3, f32, f32) {
    let joint = skel.bind_position(head);
    let floor = mesh
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::INFINITY, f32::min);
    let (mut top, mut front) = (f32::NEG_INFINITY, f32::NEG_INFINITY);
    for (v, p) in mesh.positions.iter().enumerate() {
        let (js, ws) = (mesh.joints[v], mesh.weights[v]);
        let main = (0..4).fold(0, |b, k| if ws[k] > ws[b] { k } else { b });
        if skel.descends(js[main] as usize, head) {
            top = top.max(p.y);
            front = front.max(p.z);
        }
    }
    if !top.is_finite() || top <= joint.y || front <= joint.z {
        // no vertex follows the head: a typical adult's offset
        let top = mesh.positions.iter().map(|p| p.y).fold(joint.y, f32::max);
        return (joint + Vec3::new(0.0, 0.09, 0.08), top, floor);
    }
    let eyes = Vec3::new(
        joint.x,
        joint.y + 0.45 * (top - joint.y),
        joint.z + 0.7 * (front - joint.z),
    );
    (eyes, top, floor)
}
