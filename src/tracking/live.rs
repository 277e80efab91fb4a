//! Live tracking, whatever the protocol: a thread per source receives UDP packets (or reads a
//! VRPN server's TCP stream, `vrpn.rs`), a parser (`osc.rs`, `dtrack.rs`) turns each into
//! measurements in the tracker's frame, the
//! calibration (`calibration.rs`) moves them into the room, and the merged state (head, wand,
//! left hand, targets, buttons, joystick, navigation) goes to the renderer through a crossbeam
//! channel.
//! The renderer takes the latest state (older ones are dropped); `vlf track` takes every one. A
//! source that goes quiet leaves the last state in place, and the tracker says so (status,
//! and the log once).

use super::calibration::RoomFromTracker;
use super::pose::{HeldPoses, Pose, RawPoses, Targets, MAX_TARGETS};
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

pub use super::pose::WandPose;

/// Everything a live source has said so far, in the room.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveState {
    pub pose: Pose,
    pub wand: Option<WandPose>,
    /// the left hand (as the wand: identity points along -z), once one has been seen; held
    /// where it was last tracked, as the wand is
    pub left_hand: Option<WandPose>,
    /// the declared targets (`[[tracking.target]]`, by index), each once it has been seen and
    /// then held where it was last tracked, as the hands are
    pub targets: Targets,
    /// bit i: button i held
    pub buttons: u64,
    /// the wand's joystick: x right, y up (forward), -1..1
    pub joystick: [f32; 2],
    /// the head, wand, left hand and targets as last sent, before the calibration (the
    /// tracker's frame)
    pub raw: RawPoses,
}

impl LiveState {
    pub fn new(pose: Pose) -> LiveState {
        LiveState {
            pose,
            wand: None,
            left_hand: None,
            targets: Targets::default(),
            buttons: 0,
            joystick: [0.0; 2],
            raw: RawPoses::default(),
        }
    }

    /// The wand, the left hand and the targets, where seen.
    pub fn held(&self) -> HeldPoses {
        HeldPoses {
            wand: self.wand,
            left_hand: self.left_hand,
            targets: self.targets,
        }
    }
}

/// One thing a packet said, in the tracker's frame (positions in its units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Measurement {
    /// the head; without an orientation the last one is kept
    Head {
        position: Vec3,
        rotation: Option<Quat>,
    },
    Wand {
        position: Vec3,
        rotation: Quat,
    },
    LeftHand {
        position: Vec3,
        rotation: Quat,
    },
    /// the declared target `index` (its place in `RoomFromTracker::targets`)
    Target {
        index: usize,
        position: Vec3,
        rotation: Quat,
    },
    /// all buttons at once (bit i: button i)
    Buttons(u64),
    Button {
        index: u32,
        pressed: bool,
    },
    Joystick([f32; 2]),
    /// navigation: where the room stands in the world (not calibrated: world coordinates)
    Room {
        position: Vec3,
        yaw_deg: f32,
    },
}

impl LiveState {
    /// Apply one measurement through the calibration.
    pub fn apply(&mut self, m: Measurement, calibration: &RoomFromTracker) {
        match m {
            Measurement::Head { position, rotation } => {
                calibration.head(&mut self.pose, position, rotation);
                let last = self.raw.head.map_or(Quat::IDENTITY, |h| h.rotation);
                self.raw.head = Some(WandPose {
                    position,
                    rotation: rotation.unwrap_or(last),
                });
            }
            Measurement::Wand { position, rotation } => {
                self.wand = Some(calibration.held(position, rotation));
                self.raw.wand = Some(WandPose { position, rotation });
            }
            Measurement::LeftHand { position, rotation } => {
                self.left_hand = Some(calibration.held(position, rotation));
                self.raw.left_hand = Some(WandPose { position, rotation });
            }
            Measurement::Target {
                index,
                position,
                rotation,
            } if index < MAX_TARGETS => {
                self.targets[index] = Some(calibration.held(position, rotation));
                self.raw.targets[index] = Some(WandPose { position, rotation });
            }
            Measurement::Target { .. } => {}
            Measurement::Buttons(mask) => self.buttons = mask,
            Measurement::Button { index, pressed } if index < 64 => {
                self.buttons = if pressed {
                    self.buttons | 1 << index
                } else {
                    self.buttons & !(1 << index)
                }
            }
            Measurement::Button { .. } => {}
            Measurement::Joystick(j) => self.joystick = j.map(|v| v.clamp(-1.0, 1.0)),
            Measurement::Room { position, yaw_deg } => {
                self.pose.room_position = position;
                self.pose.room_yaw_deg = yaw_deg;
            }
        }
    }
}

/// A live state and when its packet arrived.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    pub state: LiveState,
    pub received: Instant,
}

/// Parses one packet into measurements, or says why it is not one.
pub type Parser =
    fn(&[u8], &RoomFromTracker, &mut Vec<Measurement>) -> std::result::Result<(), String>;

pub struct LiveTracker {
    samples: Receiver<Sample>,
    state: LiveState,
    last_packet: Option<Instant>,
    /// the current state's arrival, until `take_fresh` hands it out once
    fresh: Option<Instant>,
    reported_quiet: bool,
    stop: Arc<AtomicBool>,
    /// the UDP port listened on (VRPN: the server's TCP port)
    pub port: u16,
    /// e.g. "OSC on UDP 9000"
    pub name: String,
}

/// The receiving side of a live tracker, owned by its thread: measurements in, calibrated
/// states out to the renderer.
pub struct Feed {
    tx: Sender<Sample>,
    state: LiveState,
    calibration: RoomFromTracker,
    stop: Arc<AtomicBool>,
}

impl Feed {
    /// Apply a packet's measurements (received at `received`) and hand the state over; false
    /// once the tracker is dropped (the thread should end).
    pub fn push(&mut self, measurements: &[Measurement], received: Instant) -> bool {
        for m in measurements {
            self.state.apply(*m, &self.calibration);
        }
        measurements.is_empty()
            || self
                .tx
                .send(Sample {
                    state: self.state,
                    received,
                })
                .is_ok()
    }

    /// The room-from-tracker calibration (its ids say which sensor is what).
    pub fn calibration(&self) -> &RoomFromTracker {
        &self.calibration
    }

    /// Whether the tracker was dropped.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

impl LiveTracker {
    /// Run `receive` on a thread named `vlf-<protocol>`, feeding a tracker called `name`
    /// (e.g. "OSC on UDP 9000"); `start` is the pose until the first measurement.
    pub fn spawn_thread(
        protocol: &str,
        name: String,
        port: u16,
        start: Pose,
        calibration: RoomFromTracker,
        receive: impl FnOnce(Feed) + Send + 'static,
    ) -> Result<LiveTracker> {
        let (tx, rx) = crossbeam::channel::unbounded();
        let stop = Arc::new(AtomicBool::new(false));
        let start_state = LiveState::new(start);
        let feed = Feed {
            tx,
            state: start_state,
            calibration,
            stop: stop.clone(),
        };
        std::thread::Builder::new()
            .name(format!("vlf-{}", protocol.to_lowercase()))
            .spawn(move || receive(feed))
            .map_err(|e| VlfError::io(name.as_str(), e))?;
        Ok(LiveTracker {
            samples: rx,
            state: start_state,
            last_packet: None,
            fresh: None,
            reported_quiet: false,
            stop,
            port,
            name,
        })
    }

    /// Listen on `address` (e.g. "0.0.0.0:9000"; port 0 picks a free one) for `protocol`
    /// ("OSC", "DTrack") packets read by `parse`. `start` is the pose until the first packet.
    pub fn spawn(
        protocol: &str,
        address: &str,
        start: Pose,
        calibration: RoomFromTracker,
        parse: Parser,
    ) -> Result<LiveTracker> {
        let socket = UdpSocket::bind(address).map_err(|e| VlfError::Config {
            path: address.into(),
            message: format!("cannot listen for {protocol} tracking on {address}: {e} (is another program using the port?)"),
        })?;
        socket
            .set_read_timeout(Some(Duration::from_millis(50)))
            .map_err(|e| VlfError::io(address, e))?;
        let port = socket
            .local_addr()
            .map_err(|e| VlfError::io(address, e))?
            .port();
        let name = format!("{protocol} on UDP {port}");
        let thread_name = name.clone();
        LiveTracker::spawn_thread(protocol, name, port, start, calibration, move |feed| {
            receive(socket, feed, parse, &thread_name)
        })
    }

    /// The latest pose (older queued poses are dropped) and whether the source is live.
    pub fn latest(&mut self) -> (Pose, TrackingStatus) {
        let (state, status) = self.latest_state();
        (state.pose, status)
    }

    /// The latest state (older ones dropped) and whether the source is live.
    pub fn latest_state(&mut self) -> (LiveState, TrackingStatus) {
        if let Some(s) = self.samples.try_iter().last() {
            self.take(s);
        }
        (self.state, self.status())
    }

    /// When the current state arrived, once per state: for the latency from a pose's arrival
    /// to the frame that first shows it.
    pub fn take_fresh(&mut self) -> Option<Instant> {
        self.fresh.take()
    }

    /// The next state in arrival order (none dropped), waiting up to `timeout`.
    pub fn next(&mut self, timeout: Duration) -> Option<Sample> {
        let s = self.samples.recv_timeout(timeout).ok()?;
        self.take(s);
        Some(s)
    }

    fn take(&mut self, s: Sample) {
        self.state = s.state;
        self.last_packet = Some(s.received);
        self.fresh = Some(s.received);
        self.reported_quiet = false;
    }

    /// Live, quiet (logged once per silence) or waiting for the first packet.
    pub fn status(&mut self) -> TrackingStatus {
        let status = match self.last_packet {
            None => TrackingStatus::Waiting,
            Some(t) if t.elapsed() > QUIET_AFTER => TrackingStatus::Quiet(t.elapsed()),
            Some(_) => TrackingStatus::Live,
        };
        if let TrackingStatus::Quiet(d) = status {
            if !self.reported_quiet {
                log::warn!(
                    "tracking ({}) quiet for {:.1} s: holding the last pose",
                    self.name,
                    d.as_secs_f32()
                );
                self.reported_quiet = true;
            }
        }
        status
    }
}

impl Drop for LiveTracker {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

fn receive(socket: UdpSocket, mut feed: Feed, parse: Parser, name: &str) {
    let mut buf = vec![0u8; 65536];
    let mut measurements = Vec::new();
    let mut warned = false;
    while !feed.stopped() {
        let Ok((n, _)) = socket.recv_from(&mut buf) else {
            continue;
        };
        let received = Instant::now();
        measurements.clear();
        if let Err(e) = parse(&buf[..n], &feed.calibration, &mut measurements) {
            // one warning per source; the rest at debug level
            if !warned {
                log::warn!("tracking ({name}): a packet was ignored: {e}");
                warned = true;
            } else {
                log::debug!("tracking ({name}): a packet was ignored: {e}");
            }
            continue;
        }
        if !feed.push(&measurements, received) {
            return;
        }
    }
}

/// One state as `vlf track` prints it: seconds since the start, head and wand (room metres,
/// yaw/pitch/roll degrees as `pose::head_rotation_from_angles` takes them), the left hand and
/// each target (called as in `targets`, the declared names) where one has been seen, buttons
/// held, joystick.
pub fn describe(t: f64, state: &LiveState, targets: &[String]) -> String {
    let angles = |q: Quat| {
        let (yaw, pitch, roll) = q.to_euler(glam::EulerRot::YXZ);
        // rounded to the printed tenth, + 0.0 turning -0.0 into 0.0
        let d = |r: f32| (r.to_degrees() * 10.0).round() / 10.0 + 0.0;
        format!(
            "yaw {:6.1} pitch {:6.1} roll {:6.1}",
            d(yaw),
            d(pitch),
            d(roll)
        )
    };
    let at = |p: Vec3| format!("({:7.3}, {:7.3}, {:7.3})", p.x, p.y, p.z);
    let head = &state.pose;
    let mut line = format!(
        "{t:8.3} s  head {} {}",
        at(head.head),
        angles(head.head_rotation)
    );
    match &state.wand {
        Some(w) => line.push_str(&format!("  wand {} {}", at(w.position), angles(w.rotation))),
        None => line.push_str("  wand -"),
    }
    if let Some(h) = &state.left_hand {
        line.push_str(&format!(
            "  left_hand {} {}",
            at(h.position),
            angles(h.rotation)
        ));
    }
    for (name, target) in targets.iter().zip(&state.targets) {
        if let Some(h) = target {
            line.push_str(&format!(
                "  {name} {} {}",
                at(h.position),
                angles(h.rotation)
            ));
        }
    }
    let held: Vec<String> = (0..64)
        .filter(|i| state.buttons & (1 << i) != 0)
        .map(|i: u32| i.to_string())
        .collect();
    line.push_str(&format!(
        "  buttons [{}]  joystick ({:5.2}, {:5.2})",
        held.join(","),
        state.joystick[0],
        state.joystick[1]
    ));
    line
}
