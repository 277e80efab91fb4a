//! VRPN's native protocol over TCP, read without the VRPN library (`[tracking] source =
//! "vrpn"`; `live.rs` runs the source). vlf connects to the server (`host[:port]`, port 3883
//! by default; reconnecting every second while it cannot), and both sides exchange the 24-byte
//! cookie `vrpn: ver. 07.xx  0`. Then the server sends messages: a header of five big-endian
//! 32-bit integers (length = 24 + payload length, seconds, microseconds, sender, type) padded
//! to 24 bytes, and the payload padded to a multiple of 8. Negative types describe senders (-1)
//! and types (-2) by name (`[length + 1][name\0]`); vlf never announces a UDP port, so the
//! server sends everything over the TCP connection. From the device named `device`:
//!
//! - `vrpn_Tracker Pos_Quat`: sensor (i32), padding, position (3 f64, metres), quaternion
//!   (x, y, z, w as f64); sensor `head_id` is the head, `wand_id` the wand,
//!   `left_hand_id` (if configured) the left hand and a `[[tracking.target]]`'s `id` that target;
//! - `vrpn_Button Change` (button i32, state i32) and `vrpn_Button States` (count, states);
//! - `vrpn_Analog Channel`: channel count (f64), channels (f64): 0 and 1 are the joystick.

use super::calibration::RoomFromTracker;
use super::live::{Feed, LiveTracker, Measurement};
use super::pose::Pose;
use crate::error::{Result, VlfError};
use glam::{DQuat, DVec3};
use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

pub const DEFAULT_PORT: u16 = 3883;
const HEADER: usize = 24;
const COOKIE: usize = 24;

/// Split `host[:port]`.
pub fn server_address(server: &str) -> std::result::Result<(String, u16), String> {
    match server.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() => {
            let port = port
                .parse::<u16>()
                .map_err(|_| format!("{port:?} is not a TCP port"))?;
            Ok((host.to_string(), port))
        }
        _ if !server.is_empty() => Ok((server.to_string(), DEFAULT_PORT)),
        _ => Err("the server's host is empty".into()),
    }
}

impl LiveTracker {
    /// Connect to the VRPN server `server` (`host[:port]`) and follow device `device`'s
    /// tracker, buttons and analogs. `start` is the pose until the first report.
    pub fn connect_vrpn(
        server: &str,
        device: &str,
        start: Pose,
        calibration: RoomFromTracker,
    ) -> Result<LiveTracker> {
        let (host, port) = server_address(server).map_err(|e| VlfError::Config {
            path: server.into(),
            message: format!("tracking.server: {e}"),
        })?;
        let name = format!("VRPN {device}@{host}:{port}");
        let (device, thread_name) = (device.to_string(), name.clone());
        LiveTracker::spawn_thread("VRPN", name, port, start, calibration, move |feed| {
            run(&host, port, &device, feed, &thread_name)
        })
    }
}

fn run(host: &str, port: u16, device: &str, mut feed: Feed, name: &str) {
    let mut warned = false;
    while !feed.stopped() {
        let Err(e) = session(host, port, device, &mut feed) else {
            return;
        };
        // the first failure is a warning, the retries are not
        if !warned {
            log::warn!("tracking ({name}): {e}; trying again every second");
            warned = true;
        } else {
            log::debug!("tracking ({name}): {e}");
        }
        let until = Instant::now() + Duration::from_secs(1);
        while Instant::now() < until && !feed.stopped() {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// One connection, until the tracker is dropped (Ok) or the connection fails (Err).
fn session(
    host: &str,
    port: u16,
    device: &str,
    feed: &mut Feed,
) -> std::result::Result<(), String> {
    let addresses = (host, port)
        .to_socket_addrs()
        .map_err(|e| format!("cannot resolve {host}: {e}"))?;
    let mut last = format!("{host} has no address");
    let mut stream = None;
    for a in addresses {
        match TcpStream::connect_timeout(&a, Duration::from_secs(1)) {
            Ok(s) => {
                stream = Some(s);
                break;
            }
            Err(e) => last = format!("cannot connect to {a}: {e}"),
        }
    }
    let mut stream = stream.ok_or(last)?;
    stream
        .set_nodelay(true)
        .and_then(|_| stream.set_read_timeout(Some(Duration::from_millis(100))))
        .map_err(|e| e.to_string())?;
    let mut buf = Vec::new();
    let mut chunk = vec![0u8; 65536];
    let mut cookie_done = false;
    let mut senders: HashMap<i32, String> = HashMap::new();
    let mut types: HashMap<i32, String> = HashMap::new();
    let mut out = Vec::new();
    while !feed.stopped() {
        match stream.read(&mut chunk) {
            Ok(0) => return Err("the VRPN server closed the connection".into()),
            Ok(n) => buf.extend_from_slice(&chunk[..n]),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                continue
            }
            Err(e) => return Err(format!("reading from the VRPN server: {e}")),
        }
        let received = Instant::now();
        if !cookie_done {
            if buf.len() < COOKIE {
                continue;
            }
            let reply = answer_cookie(&buf[..COOKIE])?;
            stream
                .write_all(&reply)
                .map_err(|e| format!("writing the cookie: {e}"))?;
            buf.drain(..COOKIE);
            cookie_done = true;
        }
        out.clear();
        let mut at = 0;
        while let Some(Message {
            sender,
            kind,
            payload,
            size,
        }) = message(&buf[at..])?
        {
            match kind {
                -1 => drop(senders.insert(sender, name(payload)?)),
                -2 => drop(types.insert(sender, name(payload)?)),
                k if k >= 0 && senders.get(&sender).is_some_and(|s| s == device) => {
                    if let Some(t) = types.get(&k) {
                        decode(t, payload, feed.calibration(), &mut out)?;
                    }
                }
                _ => {}
            }
            at += size;
        }
        buf.drain(..at);
        if !feed.push(&out, received) {
            return Ok(());
        }
    }
    Ok(())
}

/// Check the server's cookie and answer with the same version (remote logging off).
pub fn answer_cookie(cookie: &[u8]) -> std::result::Result<Vec<u8>, String> {
    if !cookie.starts_with(b"vrpn: ver. 07.") || cookie.len() < 16 {
        return Err(format!(
            "not a VRPN 07 server (it sent {:?})",
            String::from_utf8_lossy(&cookie[..cookie.len().min(16)])
        ));
    }
    let mut reply = cookie[..16].to_vec();
    reply.extend_from_slice(b"  0");
    reply.resize(COOKIE, 0);
    Ok(reply)
}

fn be_i32(b: &[u8], at: usize) -> i32 {
    i32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn be_f64(b: &[u8], at: usize) -> f64 {
    f64::from_be_bytes(std::array::from_fn(|i| b[at + i]))
}

/// One message off the stream.
pub struct Message<'a> {
    pub sender: i32,
    /// negative: a system message (-1 sender, -2 type description)
    pub kind: i32,
    pub payload: &'a [u8],
    /// bytes it took on the stream, padding included
    pub size: usize,
}

/// The next complete message at the start of `buf`, or None until more has arrived.
pub fn message(buf: &[u8]) -> std::result::Result<Option<Message<'_>>, String> {
    if buf.len() < HEADER {
        return Ok(None);
    }
    let length = be_i32(buf, 0);
    if length < HEADER as i32 || length > 1 << 24 {
        return Err(format!("a message of length {length} (damaged stream)"));
    }
    let payload = length as usize - HEADER;
    let total = HEADER + payload.div_ceil(8) * 8;
    if buf.len() < total {
        return Ok(None);
    }
    Ok(Some(Message {
        sender: be_i32(buf, 12),
        kind: be_i32(buf, 16),
        payload: &buf[HEADER..HEADER + payload],
        size: total,
    }))
}

/// A sender or type description's name.
fn name(payload: &[u8]) -> std::result::Result<String, String> {
    if payload.len() < 4 {
        return Err("a name description without its length".into());
    }
    let n = be_i32(payload, 0).max(1) as usize;
    let bytes = payload
        .get(4..4 + n - 1)
        .ok_or("a name description shorter than its length")?;
    Ok(String::from_utf8_lossy(bytes).into_owned())
}

/// The calibration's sensors, if the head, the wand, the left hand and the targets are sensors of
/// their own on the one device (one sensor cannot be two of them); else which key to change.
pub fn distinct_sensors(ids: RoomFromTracker) -> std::result::Result<RoomFromTracker, String> {
    if ids.left_hand_id == Some(ids.wand_id) {
        return Err(format!(
            "tracking.calibration.left_hand_id: sensor {} is the wand's (wand_id, 1 unless given): give the left hand its own sensor",
            ids.wand_id
        ));
    }
    if let Some(i) = ids.target_of(ids.wand_id) {
        return Err(format!(
            "{}id: sensor {} is the wand's (tracking.calibration.wand_id, 1 unless given): give the target its own sensor",
            super::target::at(i, &ids.targets[i].name),
            ids.wand_id
        ));
    }
    Ok(ids)
}

/// One message of the followed device as measurements.
pub fn decode(
    kind: &str,
    p: &[u8],
    ids: &RoomFromTracker,
    out: &mut Vec<Measurement>,
) -> std::result::Result<(), String> {
    let short = || format!("{kind}: {} bytes is too short", p.len());
    match kind {
        "vrpn_Tracker Pos_Quat" => {
            if p.len() < 64 {
                return Err(short());
            }
            let sensor = be_i32(p, 0);
            let position = DVec3::new(be_f64(p, 8), be_f64(p, 16), be_f64(p, 24)).as_vec3();
            let q = DQuat::from_xyzw(be_f64(p, 32), be_f64(p, 40), be_f64(p, 48), be_f64(p, 56))
                .as_quat();
            if !(position.is_finite() && q.is_finite() && q.length() > 1e-3) {
                return Err(format!("{kind}: sensor {sensor} is not a pose"));
            }
            let rotation = q.normalize();
            if sensor == ids.head_id as i32 {
                out.push(Measurement::Head {
                    position,
                    rotation: Some(rotation),
                });
            } else if sensor == ids.wand_id as i32 {
                out.push(Measurement::Wand { position, rotation });
            } else if ids.left_hand_id.is_some_and(|id| sensor == id as i32) {
                out.push(Measurement::LeftHand { position, rotation });
            } else if let Some(index) = u32::try_from(sensor).ok().and_then(|s| ids.target_of(s)) {
                out.push(Measurement::Target {
                    index,
                    position,
                    rotation,
                });
            }
        }
        "vrpn_Button Change" => {
            if p.len() < 8 {
                return Err(short());
            }
            let (button, state) = (be_i32(p, 0), be_i32(p, 4));
            if (0..64).contains(&button) {
                out.push(Measurement::Button {
                    index: button as u32,
                    pressed: state != 0,
                });
            }
        }
        "vrpn_Button States" => {
            let n = if p.len() >= 4 {
                be_i32(p, 0).clamp(0, 64) as usize
            } else {
                return Err(short());
            };
            if p.len() < 4 + 4 * n {
                return Err(short());
            }
            out.push(Measurement::Buttons(
                (0..n)
                    .filter(|i| be_i32(p, 4 + 4 * i) != 0)
                    .fold(0u64, |m, i| m | 1 << i),
            ));
        }
        "vrpn_Analog Channel" => {
            let n = if p.len() >= 8 {
                be_f64(p, 0).clamp(0.0, 128.0) as usize
            } else {
                return Err(short());
            };
            if p.len() < 8 + 8 * n {
                return Err(short());
            }
            let channel = |i: usize| {
                if i < n {
                    be_f64(p, 8 + 8 * i) as f32
                } else {
                    0.0
                }
            };
            out.push(Measurement::Joystick([channel(0), channel(1)]));
        }
        _ => {}
    }
    Ok(())
}
