//! Live head tracking over UDP/OSC. A thread receives `/vlf/head x y z` (room metres; the
//! orientation kept) or `/vlf/head x y z qx qy qz qw` (with the head's orientation) and,
//! optionally, `/vlf/room x y z yaw_deg` (navigation), and hands poses to the renderer through
//! a crossbeam channel; the renderer takes the latest (older ones are dropped). A source that
//! goes quiet leaves the last pose in place, and the tracker says so (status and log).

use super::tracking::Pose;
use crate::error::{Result, VlfError};
use crossbeam::channel::{Receiver, Sender};
use glam::{Quat, Vec3};
use std::net::UdpSocket;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long without a packet before the source counts as quiet.
pub const QUIET_AFTER: Duration = Duration::from_millis(500);

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrackingStatus {
    Live,
    /// no pose for this long: the last pose is held
    Quiet(Duration),
    /// nothing received yet: the start pose is used
    Waiting,
}

pub struct OscTracker {
    poses: Receiver<Pose>,
    pose: Pose,
    last_packet: Option<Instant>,
    reported_quiet: bool,
    stop: Arc<AtomicBool>,
    pub port: u16,
}

impl OscTracker {
    /// Listen on `address` (e.g. "0.0.0.0:9000"; port 0 picks a free one). `start` is the pose
    /// until the first packet.
    pub fn listen(address: &str, start: Pose) -> Result<OscTracker> {
        let socket = UdpSocket::bind(address).map_err(|e| VlfError::Config {
            path: address.into(),
            message: format!("cannot listen for OSC tracking on {address}: {e}"),
        })?;
        socket.set_read_timeout(Some(Duration::from_millis(50))).map_err(|e| VlfError::io(address, e))?;
        let port = socket.local_addr().map_err(|e| VlfError::io(address, e))?.port();
        let (tx, rx) = crossbeam::channel::unbounded();
        let stop = Arc::new(AtomicBool::new(false));
        let stop_flag = stop.clone();
        std::thread::Builder::new()
            .name("vlf-osc".into())
            .spawn(move || receive(socket, tx, start, stop_flag))
            .map_err(|e| VlfError::io(address, e))?;
        Ok(OscTracker { poses: rx, pose: start, last_packet: None, reported_quiet: false, stop, port })
    }

    /// The latest pose (older queued poses are dropped) and whether the source is live.
    pub fn latest(&mut self) -> (Pose, TrackingStatus) {
        if let Some(p) = self.poses.try_iter().last() {
            self.pose = p;
            self.last_packet = Some(Instant::now());
            self.reported_quiet = false;
        }
        let status = match self.last_packet {
            None => TrackingStatus::Waiting,
            Some(t) if t.elapsed() > QUIET_AFTER => TrackingStatus::Quiet(t.elapsed()),
            Some(_) => TrackingStatus::Live,
        };
        if let TrackingStatus::Quiet(d) = status {
            if !self.reported_quiet {
                log::warn!("OSC tracking on port {} quiet for {:.1} s: holding the last pose", self.port, d.as_secs_f32());
                self.reported_quiet = true;
            }
        }
        (self.pose, status)
    }
}

impl Drop for OscTracker {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

fn receive(socket: UdpSocket, tx: Sender<Pose>, start: Pose, stop: Arc<AtomicBool>) {
    let mut pose = start;
    let mut buf = [0u8; rosc::decoder::MTU];
    while !stop.load(Ordering::Relaxed) {
        let Ok((n, _)) = socket.recv_from(&mut buf) else { continue };
        let Ok((_, packet)) = rosc::decoder::decode_udp(&buf[..n]) else {
            log::warn!("OSC tracking: a packet that is not OSC was ignored");
            continue;
        };
        let mut changed = false;
        apply(&packet, &mut pose, &mut changed);
        if changed && tx.send(pose).is_err() {
            return;
        }
    }
}

fn floats(args: &[rosc::OscType]) -> Vec<f32> {
    args.iter()
        .filter_map(|a| match a {
            rosc::OscType::Float(f) => Some(*f),
            rosc::OscType::Double(d) => Some(*d as f32),
            rosc::OscType::Int(i) => Some(*i as f32),
            _ => None,
        })
        .collect()
}

fn apply(packet: &rosc::OscPacket, pose: &mut Pose, changed: &mut bool) {
    match packet {
        rosc::OscPacket::Message(m) => {
            let v = floats(&m.args);
            match (m.addr.as_str(), v.as_slice()) {
                ("/vlf/head", [x, y, z, qx, qy, qz, qw, ..]) if v[..7].iter().all(|f| f.is_finite()) && Quat::from_xyzw(*qx, *qy, *qz, *qw).length() > 1e-3 => {
                    pose.head = Vec3::new(*x, *y, *z);
                    pose.head_rotation = Quat::from_xyzw(*qx, *qy, *qz, *qw).normalize();
                    *changed = true;
                }
                ("/vlf/head", [x, y, z]) if [x, y, z].iter().all(|f| f.is_finite()) => {
                    pose.head = Vec3::new(*x, *y, *z);
                    *changed = true;
                }
                ("/vlf/room", [x, y, z, yaw, ..]) if [x, y, z, yaw].iter().all(|f| f.is_finite()) => {
                    pose.room_position = Vec3::new(*x, *y, *z);
                    pose.room_yaw_deg = *yaw;
                    *changed = true;
                }
                _ => log::debug!("OSC tracking: ignored {} with {} numbers", m.addr, v.len()),
            }
        }
        rosc::OscPacket::Bundle(b) => {
            for p in &b.content {
                apply(p, pose, changed);
            }
        }
    }
}
