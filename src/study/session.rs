//! A run's study side, frame by frame: the experiment script's commands (`control.rs`) take
//! effect at the start of a frame, the frame's row goes to the session log (`log.rs`) at its
//! end with the events of that frame, and each command is acknowledged with the frame's number.
//! The display loops call `begin_frame`, `pose` and `end_frame`; without a log or a control
//! connection each does nothing.

use super::control::{Command, ControlServer, Pending};
use super::log::{FrameRecord, SessionLog};
use crate::error::Result;
use crate::tracking::pose::Pose;
use glam::Vec3;

pub struct Session<'p> {
    log: Option<&'p mut SessionLog>,
    control: Option<&'p ControlServer>,
    /// the room's place in the world set by `teleport` (position, yaw in degrees)
    teleport: Option<(Vec3, f32)>,
    /// rows go to the log (`log` turns it off and on)
    logging: bool,
    /// the experiment's block and trial (`trial`)
    trial: (u32, u32),
    /// the script asked the run to end with this frame
    pub stop: bool,
    /// this frame's commands, acknowledged at its end
    pending: Vec<Pending>,
    events: Vec<String>,
    time_s: f64,
}

impl<'p> Session<'p> {
    pub fn new(log: Option<&'p mut SessionLog>, control: Option<&'p ControlServer>) -> Session<'p> {
        Session {
            log,
            control,
            teleport: None,
            logging: true,
            trial: (0, 0),
            stop: false,
            pending: Vec::new(),
            events: Vec::new(),
            time_s: 0.0,
        }
    }

    /// A frame begins: what the script sent since the last one takes effect now.
    pub fn begin_frame(&mut self) {
        self.time_s = self.log.as_ref().map_or(0.0, |l| l.elapsed_s());
        let Some(control) = self.control else { return };
        for p in control.take() {
            match &p.command {
                Command::Event { text } => self.events.push(text.clone()),
                Command::Teleport { position, yaw_deg } => {
                    self.teleport = Some((Vec3::from(*position), *yaw_deg));
                    self.events
                        .push(format!("teleport to {position:?}, yaw {yaw_deg} deg"));
                }
                Command::Trial { block, trial } => {
                    self.trial = (*block, *trial);
                    self.events.push(format!("block {block} trial {trial}"));
                }
                Command::Log { on } => {
                    self.logging = *on;
                    self.events
                        .push(format!("log {}", if *on { "on" } else { "off" }));
                }
                Command::State => {}
                Command::Stop => {
                    self.stop = true;
                    self.events.push("stop".into());
                }
            }
            self.pending.push(p);
        }
    }

    /// The frame's pose as the script has placed the room.
    pub fn pose(&self, mut pose: Pose) -> Pose {
        if let Some((position, yaw)) = self.teleport {
            pose.room_position = position;
            pose.room_yaw_deg = yaw;
        }
        pose
    }

    /// Seconds since the session began, when this frame began (0 without a log).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The frame is drawn: its row (with its events, and `note` among them) to the log, and
    /// its commands acknowledged with its number and pose.
    pub fn end_frame(&mut self, mut record: FrameRecord, note: Option<String>) -> Result<()> {
        self.events.extend(note);
        record.events = std::mem::take(&mut self.events).join("; ");
        (record.block, record.trial) = self.trial;
        if let (Some(log), true) = (self.log.as_deref_mut(), self.logging) {
            log.record(&record)?;
        }
        for p in self.pending.drain(..) {
            let mut extra = serde_json::Map::new();
            if p.command == Command::State {
                let (h, r) = (record.pose.head, record.pose.room_position);
                extra.insert("head".into(), serde_json::json!([h.x, h.y, h.z]));
                extra.insert("room".into(), serde_json::json!([r.x, r.y, r.z]));
                extra.insert("room_yaw_deg".into(), record.pose.room_yaw_deg.into());
                extra.insert(
                    "logging".into(),
                    (self.log.is_some() && self.logging).into(),
                );
            }
            p.ack(record.frame, extra);
        }
        Ok(())
    }
}
