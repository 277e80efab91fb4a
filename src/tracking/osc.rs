//! Live tracking over UDP/OSC (`live.rs` runs the source). Messages, numbers as float, int or
//! double (room metres, or tracker units under `[tracking.calibration]`):
//!
//! - `/vlf/head x y z` moves the head and keeps its orientation;
//!   `/vlf/head x y z qx qy qz qw` gives the orientation too (a quaternion, identity looking
//!   along -z with y up);
//! - `/vlf/wand x y z qx qy qz qw`: the wand (identity points along -z);
//! - `/vlf/left_hand x y z qx qy qz qw`: the left hand (as the wand: identity points along -z);
//! - `/vlf/target/<name> x y z qx qy qz qw`: the `[[tracking.target]]` called `<name>` (as the
//!   left hand; a name not declared is ignored);
//! - `/vlf/button i state`: button i (0..63) pressed (state non-zero) or released;
//! - `/vlf/joystick x y`: the wand's joystick, -1..1 (x right, y forward);
//! - `/vlf/room x y z yaw_deg`: navigation, where the room stands in the world (not calibrated).
//!
//! Bundles are unpacked; other addresses are ignored.

use super::calibration::RoomFromTracker;
use super::live::{LiveTracker, Measurement};
pub use super::live::{TrackingStatus, QUIET_AFTER};
use super::pose::Pose;
use crate::error::Result;
use glam::{Quat, Vec3};

/// The OSC source (the live tracker fed by OSC packets).
pub type OscTracker = LiveTracker;

impl LiveTracker {
    /// Listen for OSC on `address` (e.g. "0.0.0.0:9000"; port 0 picks a free one), poses taken
    /// as room metres. `start` is the pose until the first packet.
    pub fn listen(address: &str, start: Pose) -> Result<LiveTracker> {
        LiveTracker::spawn("OSC", address, start, RoomFromTracker::default(), parse)
    }
}

/// Read one OSC packet (message or bundle) into measurements (`ids` names the targets).
pub fn parse(
    packet: &[u8],
    ids: &RoomFromTracker,
    out: &mut Vec<Measurement>,
) -> std::result::Result<(), String> {
    let (_, packet) = rosc::decoder::decode_udp(packet).map_err(|e| format!("not OSC ({e:?})"))?;
    collect(&packet, ids, out);
    Ok(())
}

/// The index of the target an address `/vlf/target/<name>` names, if one is declared so.
fn target_index(address: &str, ids: &RoomFromTracker) -> Option<usize> {
    let name = address.strip_prefix("/vlf/target/")?;
    ids.targets.iter().position(|t| t.name == name)
}

fn floats(args: &[rosc::OscType]) -> Vec<f32> {
    args.iter()
        .filter_map(|a| match a {
            rosc::OscType::Float(f) => Some(*f),
            rosc::OscType::Double(d) => Some(*d as f32),
            rosc::OscType::Int(i) => Some(*i as f32),
            rosc::OscType::Long(i) => Some(*i as f32),
            rosc::OscType::Bool(b) => Some(*b as u8 as f32),
            _ => None,
        })
        .collect()
}

/// A quaternion given as four numbers, if it is one.
fn quaternion(q: &[f32]) -> Option<Quat> {
    let q = Quat::from_xyzw(q[0], q[1], q[2], q[3]);
    (q.is_finite() && q.length() > 1e-3).then(|| q.normalize())
}

fn collect(packet: &rosc::OscPacket, ids: &RoomFromTracker, out: &mut Vec<Measurement>) {
    match packet {
        rosc::OscPacket::Message(m) => {
            let v = floats(&m.args);
            let finite = v.iter().all(|f| f.is_finite());
            let measurement = match (m.addr.as_str(), v.as_slice()) {
                _ if !finite => None,
                ("/vlf/head", [x, y, z]) => Some(Measurement::Head {
                    position: Vec3::new(*x, *y, *z),
                    rotation: None,
                }),
                ("/vlf/head", [x, y, z, q @ ..]) if q.len() == 4 => {
                    quaternion(q).map(|q| Measurement::Head {
                        position: Vec3::new(*x, *y, *z),
                        rotation: Some(q),
                    })
                }
                ("/vlf/wand", [x, y, z, q @ ..]) if q.len() == 4 => {
                    quaternion(q).map(|q| Measurement::Wand {
                        position: Vec3::new(*x, *y, *z),
                        rotation: q,
                    })
                }
                ("/vlf/left_hand", [x, y, z, q @ ..]) if q.len() == 4 => {
                    quaternion(q).map(|q| Measurement::LeftHand {
                        position: Vec3::new(*x, *y, *z),
                        rotation: q,
                    })
                }
                ("/vlf/button", [i, state]) if *i >= 0.0 && *i < 64.0 && i.fract() == 0.0 => {
                    Some(Measurement::Button {
                        index: *i as u32,
                        pressed: *state != 0.0,
                    })
                }
                ("/vlf/joystick", [x, y]) => Some(Measurement::Joystick([*x, *y])),
                ("/vlf/room", [x, y, z, yaw, ..]) => Some(Measurement::Room {
                    position: Vec3::new(*x, *y, *z),
                    yaw_deg: *yaw,
                }),
                (address, [x, y, z, q @ ..])
                    if q.len() == 4 && address.starts_with("/vlf/target/") =>
                {
                    let index = target_index(address, ids);
                    (index.zip(quaternion(q))).map(|(index, q)| Measurement::Target {
                        index,
                        position: Vec3::new(*x, *y, *z),
                        rotation: q,
                    })
                }
                _ => None,
            };
            match measurement {
                Some(m) => out.push(m),
                None => log::debug!("OSC tracking: ignored {} with {} numbers", m.addr, v.len()),
            }
        }
        rosc::OscPacket::Bundle(b) => {
            for p in &b.content {
                collect(p, ids, out);
            }
        }
    }
}
