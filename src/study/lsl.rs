//! Lab Streaming Layer outlets (`vlf cave --lsl`; the `lsl` crate, liblsl's official bindings,
//! behind the default cargo feature `lsl`): three streams that LabRecorder records into one XDF
//! file beside a lab's other devices (skin conductance, ECG, eye trackers), in LSL's clock.
//!
//! - `vlf.pose` (type `MoCap`, float32, the display's refresh rate): one sample per frame, the
//!   head and the wand (position and rotation in the room, NaN without a wand), the room's place
//!   in the world, the pose's age at the predicted photon time and the frame number
//!   (`POSE_CHANNELS`), stamped with the time the pose was sampled (or arrived from the tracker);
//! - `vlf.frames` (type `Markers`, double, the refresh rate): one sample per frame, the frame
//!   number, its predicted display time in LSL's clock (NaN for a frame read back, not shown),
//!   its GPU and CPU milliseconds, whether it was late and how many refreshes it missed
//!   (`FRAME_CHANNELS`), stamped with the predicted display time;
//! - `vlf.events` (type `Markers`, strings, irregular): the session log's events of each frame
//!   (the script's event texts, `block 1 trial 3`, teleports, `log off`, `stop`) and every
//!   control command with its reply (`{"command": ..., "reply": ...}`, refused ones too),
//!   stamped with the predicted display time of the frame they took effect in.
//!
//! The CAVE has no runtime that predicts when a frame reaches the eye: the predicted display
//! time is the frame's GPU end plus one refresh period (half a period on average to the next
//! vertical blank, half to scan out to the middle of the picture; projectors add their own
//! input lag, which a photodiode measures). A headless run has no display to pace it: with
//! `--lsl` its frames start one refresh period apart, so the streams carry the rate they declare.
//! Built without the feature, `LslOutlets::open` says how to build it.

use super::log::FrameRecord;
use crate::error::Result;
use std::time::{Duration, Instant};

/// The pose stream's channels: label, unit.
pub const POSE_CHANNELS: [(&str, &str); 20] = [
    ("head_x", "metres"),
    ("head_y", "metres"),
    ("head_z", "metres"),
    ("head_qx", "quaternion"),
    ("head_qy", "quaternion"),
    ("head_qz", "quaternion"),
    ("head_qw", "quaternion"),
    ("wand_x", "metres"),
    ("wand_y", "metres"),
    ("wand_z", "metres"),
    ("wand_qx", "quaternion"),
    ("wand_qy", "quaternion"),
    ("wand_qz", "quaternion"),
    ("wand_qw", "quaternion"),
    ("room_x", "metres"),
    ("room_y", "metres"),
    ("room_z", "metres"),
    ("room_yaw_deg", "degrees"),
    ("pose_to_photon_ms", "milliseconds"),
    ("frame", "count"),
];

/// The frame stream's channels: label, unit.
pub const FRAME_CHANNELS: [(&str, &str); 6] = [
    ("frame", "count"),
    ("display_time", "seconds (LSL clock)"),
    ("gpu_ms", "milliseconds"),
    ("cpu_ms", "milliseconds"),
    ("late", "0 or 1"),
    ("missed_refreshes", "count"),
];

/// The three streams' names.
pub const STREAMS: [&str; 3] = ["vlf.pose", "vlf.frames", "vlf.events"];

/// A frame as the outlets send it: its row, when its pose was sampled, when its photons are
/// due (one refresh after its GPU's end), whether it is shown (a frame read back is not: its
/// display time is NaN, its samples still stamped when it was due) and whether it was late and
/// by how many refreshes (None: not timed, or no refresh rate).
pub struct FrameSample<'r> {
    pub record: &'r FrameRecord,
    pub pose_at: Instant,
    pub due: Instant,
    pub shown: bool,
    pub late: Option<(bool, u32)>,
}

/// The run's outlets, and a headless run's pacing.
pub struct LslOutlets {
    #[cfg(feature = "lsl")]
    streams: with_lsl::Streams,
    /// headless: frames held one refresh period apart (the next one's start)
    pace: Option<(Duration, Option<Instant>)>,
}

impl LslOutlets {
    /// The three outlets for a run of the display `name` (rate: its `refresh_hz`, else
    /// irregular); `headless`: frames held to that rate.
    pub fn open(name: &str, refresh_hz: Option<f32>, headless: bool) -> Result<LslOutlets> {
        #[cfg(not(feature = "lsl"))]
        {
            let _ = (name, refresh_hz, headless);
            Err(crate::error::VlfError::Display(
                "--lsl: this vlf was built without Lab Streaming Layer (cargo feature `lsl`, on by default): build it with its default features or `--features lsl` (liblsl is built with cmake: `bash tools/setup.sh demo` installs it)".into(),
            ))
        }
        #[cfg(feature = "lsl")]
        {
            let period = refresh_hz.map(|hz| Duration::from_secs_f64(1.0 / hz as f64));
            Ok(LslOutlets {
                streams: with_lsl::Streams::open(name, refresh_hz)?,
                pace: period.filter(|_| headless).map(|p| (p, None)),
            })
        }
    }

    /// A headless run: wait for the next frame's start, one refresh period after the last one's
    /// (a frame that overran its period starts the next at once, and the beat starts again).
    pub fn pace(&mut self) {
        let Some((period, next)) = &mut self.pace else {
            return;
        };
        let now = Instant::now();
        match *next {
            Some(at) if at > now => {
                std::thread::sleep(at - now);
                *next = Some(at + *period);
            }
            _ => *next = Some(now + *period),
        }
    }

    /// A frame's samples on `vlf.pose` and `vlf.frames`, and its markers on `vlf.events`.
    pub fn frame(&self, sample: &FrameSample<'_>, markers: &[String]) -> Result<()> {
        #[cfg(feature = "lsl")]
        self.streams.frame(sample, markers)?;
        #[cfg(not(feature = "lsl"))]
        let _ = (sample, markers);
        Ok(())
    }
}

/// The pose sample's values, in `POSE_CHANNELS` order.
pub fn pose_values(sample: &FrameSample<'_>) -> Vec<f32> {
    let r = sample.record;
    let (p, q) = (r.pose.head, r.pose.head_rotation);
    let mut v = vec![p.x, p.y, p.z, q.x, q.y, q.z, q.w];
    match &r.wand {
        Some(w) => {
            let (p, q) = (w.position, w.rotation);
            v.extend([p.x, p.y, p.z, q.x, q.y, q.z, q.w]);
        }
        None => v.extend([f32::NAN; 7]),
    }
    let room = r.pose.room_position;
    v.extend([room.x, room.y, room.z, r.pose.room_yaw_deg]);
    let photon_ms = match sample.shown {
        true => duration_ms(sample.pose_at, sample.due) as f32,
        false => f32::NAN,
    };
    v.push(photon_ms);
    v.push(r.frame as f32);
    v
}

/// Milliseconds from `from` to `to` (negative where `to` is earlier).
fn duration_ms(from: Instant, to: Instant) -> f64 {
    match to.checked_duration_since(from) {
        Some(d) => d.as_secs_f64() * 1e3,
        None => -(from - to).as_secs_f64() * 1e3,
    }
}

#[cfg(feature = "lsl")]
mod with_lsl {
    //! The outlets themselves (liblsl through the `lsl` crate).

    use super::{duration_ms, pose_values, FrameSample, FRAME_CHANNELS, POSE_CHANNELS, STREAMS};
    use crate::error::{Result, VlfError};
    use lsl::{ChannelFormat, ExPushable, StreamInfo, StreamOutlet};
    use std::time::Instant;

    pub struct Streams {
        pose: StreamOutlet,
        frames: StreamOutlet,
        events: StreamOutlet,
    }

    fn lsl_error(what: &str) -> impl Fn(lsl::Error) -> VlfError + '_ {
        move |e| {
            VlfError::Display(format!(
                "LSL {what}: {e:?}; liblsl could not open or send it (check that this machine has a network interface up, and the lsl_api.cfg that LSLAPICFG names if it is set)"
            ))
        }
    }

    /// An outlet of `channels` (label, unit) with their labels and units in its description.
    fn outlet(
        (name, kind, source): (&str, &str, &str),
        rate: f64,
        format: ChannelFormat,
        channels: &[(&str, &str)],
    ) -> Result<StreamOutlet> {
        let count = channels.len().max(1) as u32;
        let mut info =
            StreamInfo::new(name, kind, count, rate, format, source).map_err(lsl_error(name))?;
        let mut desc = info.desc();
        desc.append_child_value("manufacturer", "vlf");
        let mut list = desc.append_child("channels");
        for (label, unit) in channels {
            let mut c = list.append_child("channel");
            c.append_child_value("label", label);
            c.append_child_value("unit", unit);
        }
        StreamOutlet::new(&info, 0, 360).map_err(lsl_error(name))
    }

    impl Streams {
        pub fn open(name: &str, refresh_hz: Option<f32>) -> Result<Streams> {
            let rate = refresh_hz.map_or(lsl::IRREGULAR_RATE, |hz| hz as f64);
            let source = |s: &str| format!("vlf:{name}:{s}");
            let (f32s, f64s) = (ChannelFormat::Float32, ChannelFormat::Double64);
            let pose = (STREAMS[0], "MoCap", source("pose"));
            let frames = (STREAMS[1], "Markers", source("frames"));
            let events = (STREAMS[2], "Markers", source("events"));
            Ok(Streams {
                pose: outlet((pose.0, pose.1, &pose.2), rate, f32s, &POSE_CHANNELS)?,
                frames: outlet((frames.0, frames.1, &frames.2), rate, f64s, &FRAME_CHANNELS)?,
                events: outlet(
                    (events.0, events.1, &events.2),
                    lsl::IRREGULAR_RATE,
                    ChannelFormat::String,
                    &[("event", "text")],
                )?,
            })
        }

        pub fn frame(&self, s: &FrameSample<'_>, markers: &[String]) -> Result<()> {
            let r = s.record;
            let pose_time = lsl_time(s.pose_at);
            self.pose
                .push_sample_ex(&pose_values(s), pose_time, true)
                .map_err(lsl_error(STREAMS[0]))?;
            let at = lsl_time(s.due);
            let shown = s.shown.then_some(at);
            let opt = |v: Option<f64>| v.unwrap_or(f64::NAN);
            let (late, missed) = match s.late {
                Some((late, missed)) => (late as u8 as f64, missed as f64),
                None => (f64::NAN, f64::NAN),
            };
            let row = vec![
                r.frame as f64,
                opt(shown),
                opt(r.gpu_ms),
                opt(r.cpu_ms),
                late,
                missed,
            ];
            self.frames
                .push_sample_ex(&row, at, true)
                .map_err(lsl_error(STREAMS[1]))?;
            for m in markers {
                self.events
                    .push_sample_ex(&vec![m.as_str()], at, true)
                    .map_err(lsl_error(STREAMS[2]))?;
            }
            Ok(())
        }
    }

    /// `at` in LSL's clock (`lsl::local_clock`, seconds).
    fn lsl_time(at: Instant) -> f64 {
        let (now, clock) = (Instant::now(), lsl::local_clock());
        clock + duration_ms(now, at) * 1e-3
    }
}
