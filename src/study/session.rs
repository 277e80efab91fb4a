//! A run's study side, frame by frame: the experiment script's commands (`control.rs`) take
//! effect at the start of a frame, the frame's row goes to the session log (`log.rs`) at its
//! end with the events of that frame, and each command is acknowledged with the frame's number.
//! The display loops call `begin_frame`, `pose` and `end_frame`; without a log or a control
//! connection each does nothing. With LSL outlets (`lsl.rs`) every frame's pose, times and
//! events go out on them as well, in LSL's clock.

use super::control::{Command, ControlServer, Pending};
use super::log::{FrameRecord, SessionLog};
use super::lsl::{FrameSample, LslOutlets};
use crate::error::{names_or_none, Result};
use crate::stats::Distribution;
use crate::tracking::pose::Pose;
use glam::Vec3;
use std::time::{Duration, Instant};

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
    /// the LSL outlets (`vlf cave --lsl`), and this frame's command markers for them
    lsl: Option<LslOutlets>,
    markers: Vec<String>,
    /// the display's refresh period: the photons follow the GPU's end by one (None: unknown)
    refresh: Option<Duration>,
    /// when this frame's pose was sampled, or arrived from the tracker
    pose_at: Option<Instant>,
    /// every timed frame's pose_to_submit_ms and pose_to_photon_ms, for the report
    latencies: Vec<(f64, f64)>,
    /// the latency test (`flash`): Some(true) white walls this frame, Some(false) black
    flash: Option<bool>,
    /// the display's moving objects by name, and this frame's changes to them for the display
    objects: Vec<String>,
    object_changes: Vec<ObjectChange>,
    /// the display's conditions by name, each with its start pose (the room's place and yaw);
    /// the one in effect ("" without conditions), and this frame's switch for the display
    conditions: Vec<(String, Option<(Vec3, f32)>)>,
    condition: String,
    condition_change: Option<String>,
    /// commands this display does not take (by name), each with why: refused, nothing changed
    refused: Vec<(&'static str, String)>,
    /// when this frame's photons are due, where the display predicts it (the headset's runtime)
    due: Option<Instant>,
}

/// A change the script made to the moving objects, for the display to apply this frame.
#[derive(Clone, Debug, PartialEq)]
pub enum ObjectChange {
    Visible(String, bool),
    Shadows(bool),
    Reflections(bool),
}

/// Motion to photon over a run's timed frames, in `vlf cave`'s report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MotionToPhoton {
    /// from the pose's arrival (live tracking) or sampling to the frame's submission, ms
    pub pose_to_submit_ms: Distribution,
    /// from the same to the frame's predicted photons: its GPU end plus one refresh period
    /// (without `refresh_hz`, the GPU end alone: a lower bound), ms
    pub pose_to_photon_ms: Distribution,
    /// the refresh period the prediction adds, ms (None: the display gives no `refresh_hz`)
    pub refresh_ms: Option<f64>,
}

impl MotionToPhoton {
    /// The report's line.
    pub fn line(&self) -> String {
        let (s, p) = (&self.pose_to_submit_ms, &self.pose_to_photon_ms);
        let model = match self.refresh_ms {
            Some(ms) => format!("GPU end + one refresh, {ms:.3} ms"),
            None => "GPU end; no refresh_hz: a lower bound".into(),
        };
        format!(
            "  motion to photon ({} frames): pose -> submitted p50 {:.3} ms, p99 {:.3} ms; pose -> photons (predicted: {model}) p50 {:.3} ms, p99 {:.3} ms\n",
            s.samples, s.median, s.p99, p.median, p.p99
        )
    }
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
            lsl: None,
            markers: Vec::new(),
            refresh: None,
            pose_at: None,
            latencies: Vec::new(),
            flash: None,
            objects: Vec::new(),
            object_changes: Vec::new(),
            conditions: Vec::new(),
            condition: String::new(),
            condition_change: None,
            refused: Vec::new(),
            due: None,
        }
    }

    /// Commands this display does not take (`vlf xr`: the latency test, conditions), by name,
    /// each refused with its reason.
    pub fn refusing(mut self, refused: Vec<(&'static str, String)>) -> Self {
        self.refused = refused;
        self
    }

    /// This frame's photons are due at `due` (the headset runtime's predicted display time on
    /// this process's clock): the log's `pose_to_photon_ms` and LSL's stamps take it in place
    /// of the GPU's end plus a refresh period.
    pub fn display_due(&mut self, due: Option<Instant>) {
        self.due = due;
    }

    /// The display's conditions by name, each with its start pose (`DisplayConfig::
    /// study_conditions`; the `condition` command refuses any other name): the first is in
    /// effect from the first frame, its start pose with it.
    pub fn with_conditions(mut self, conditions: Vec<(String, Option<(Vec3, f32)>)>) -> Self {
        self.conditions = conditions;
        if let Some(name) = self.conditions.first().map(|c| c.0.clone()) {
            self.switch_condition(&name);
        }
        self
    }

    /// The condition switched to this frame, for the display (`FrameOfViews::set_condition`).
    pub fn take_condition(&mut self) -> Option<String> {
        self.condition_change.take()
    }

    /// The condition in effect ("" where the display has none).
    pub fn condition(&self) -> &str {
        &self.condition
    }

    /// Switch to the condition `name` (checked): its start pose, if it has one, is the room's.
    fn switch_condition(&mut self, name: &str) {
        let start = self
            .conditions
            .iter()
            .find(|c| c.0 == name)
            .and_then(|c| c.1);
        if let Some(start) = start {
            self.teleport = Some(start);
        }
        self.condition = name.to_string();
        self.condition_change = Some(name.to_string());
    }

    /// The `condition` command: switched from this frame, an event; Err (nothing changed) for a
    /// name the display has no condition of.
    fn condition_command(&mut self, command: &Command) -> std::result::Result<(), String> {
        let Command::Condition { name } = command else {
            return Ok(());
        };
        if !self.conditions.iter().any(|c| &c.0 == name) {
            let names: Vec<&str> = self.conditions.iter().map(|c| c.0.as_str()).collect();
            return Err(format!(
                "no condition called {name:?} (the display config's [[condition]] names: {})",
                names_or_none(&names)
            ));
        }
        self.switch_condition(name);
        self.events.push(format!("condition {name}"));
        Ok(())
    }

    /// The names of the display's moving objects (`show`/`hide` refuse any other).
    pub fn with_objects(mut self, names: Vec<String>) -> Self {
        self.objects = names;
        self
    }

    /// This frame's changes to the moving objects, in the order the script sent them.
    pub fn take_object_changes(&mut self) -> Vec<ObjectChange> {
        std::mem::take(&mut self.object_changes)
    }

    /// The display's refresh rate (`DisplayConfig::refresh_hz`), for each frame's predicted
    /// photon time, and LSL outlets to send every frame on.
    pub fn with_display(mut self, refresh_hz: Option<f32>, lsl: Option<LslOutlets>) -> Self {
        self.refresh = refresh_hz.map(|hz| Duration::from_secs_f64(1.0 / hz as f64));
        self.lsl = lsl;
        self
    }

    /// A frame begins: what the script sent since the last one takes effect now.
    pub fn begin_frame(&mut self) {
        if let Some(lsl) = &mut self.lsl {
            lsl.pace();
        }
        self.time_s = self.log.as_ref().map_or(0.0, |l| l.elapsed_s());
        self.pose_at = None;
        // a flash lasts one frame; the walls stay black until the test ends
        if self.flash == Some(true) {
            self.flash = Some(false);
        }
        let Some(control) = self.control else { return };
        for (line, reply) in control.take_refused() {
            if self.lsl.is_some() {
                let command = serde_json::Value::String(line);
                self.markers.push(command_marker(command, &reply));
            }
        }
        for p in control.take() {
            let name = p.command.name();
            let not_here = (self.refused.iter()).find(|(n, _)| *n == name);
            let checked = match not_here {
                Some((_, why)) => Err(why.clone()),
                None => (self.object_command(&p.command))
                    .and_then(|_| self.condition_command(&p.command)),
            };
            if let Err(error) = checked {
                let reply = p.refuse(&error);
                if self.lsl.is_some() {
                    self.markers.push(reply);
                }
                continue;
            }
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
                Command::Flash { end } => {
                    self.flash = (!end).then_some(true);
                    self.events
                        .push(if *end { "flash end" } else { "flash" }.into());
                }
                Command::Stop => {
                    self.stop = true;
                    self.events.push("stop".into());
                }
                // taken by object_command
                Command::Show { .. }
                | Command::Hide { .. }
                | Command::Shadows { .. }
                | Command::Reflections { .. }
                | Command::Condition { .. } => {}
            }
            self.pending.push(p);
        }
    }

    /// A command on the moving objects: noted as this frame's change and event; Err (nothing
    /// changed) for a name the display has no object of.
    fn object_command(&mut self, command: &Command) -> std::result::Result<(), String> {
        let change = match command {
            Command::Show { object } | Command::Hide { object } => {
                if !self.objects.contains(object) {
                    return Err(format!(
                        "no moving object called {object:?} (the display config's [[object]] names: {})",
                        names_or_none(&self.objects)
                    ));
                }
                ObjectChange::Visible(object.clone(), matches!(command, Command::Show { .. }))
            }
            Command::Shadows { on } => ObjectChange::Shadows(*on),
            Command::Reflections { on } => ObjectChange::Reflections(*on),
            _ => return Ok(()),
        };
        self.events.push(match &change {
            ObjectChange::Visible(name, on) => {
                format!("{} {name}", if *on { "show" } else { "hide" })
            }
            ObjectChange::Shadows(on) => format!("shadows {}", if *on { "on" } else { "off" }),
            ObjectChange::Reflections(on) => {
                format!("reflections {}", if *on { "on" } else { "off" })
            }
        });
        self.object_changes.push(change);
        Ok(())
    }

    /// The frame's pose as the script has placed the room; `sampled`: when it was sampled, or
    /// arrived from the tracker.
    pub fn pose(&mut self, mut pose: Pose, sampled: Instant) -> Pose {
        self.pose_at = Some(sampled);
        if let Some((position, yaw)) = self.teleport {
            pose.room_position = position;
            pose.room_yaw_deg = yaw;
        }
        pose
    }

    /// A cluster's rank other than 0 follows rank 0's session (`crate::framelock::StudyState`):
    /// its condition (`condition`: the name in this rank's display), flash and stop go into
    /// this rank's log. On rank 0 (and in one process) they are this session's own already.
    pub fn follow(&mut self, study: &crate::framelock::StudyState, condition: Option<&str>) {
        if let Some(name) = condition {
            if self.condition != name {
                self.condition = name.to_string();
            }
        }
        self.flash = study.flash;
        self.stop |= study.stop;
    }

    /// The latency test's walls this frame: Some(true) full white, Some(false) black, None the
    /// scene (`flash`).
    pub fn flash(&self) -> Option<bool> {
        self.flash
    }

    /// Motion to photon over the timed frames so far (None before one).
    pub fn motion_to_photon(&self) -> Option<MotionToPhoton> {
        if self.latencies.is_empty() {
            return None;
        }
        let (submit, photon): (Vec<f64>, Vec<f64>) = self.latencies.iter().copied().unzip();
        Some(MotionToPhoton {
            pose_to_submit_ms: Distribution::of(&submit),
            pose_to_photon_ms: Distribution::of(&photon),
            refresh_ms: self.refresh.map(|p| p.as_secs_f64() * 1e3),
        })
    }

    /// Seconds since the session began, when this frame began (0 without a log).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The frame is drawn (the loops call this once its GPU work is done): its row (with its
    /// events, and `note` among them, its block, trial, condition and flash) to the log, its
    /// commands acknowledged with its number and pose, and all of it to the LSL outlets.
    pub fn end_frame(&mut self, mut record: FrameRecord, note: Option<String>) -> Result<()> {
        // the photons of a frame shown (timed or presented) one refresh after the GPU's end
        let shown = record.pose_to_submit_ms.is_some();
        let due =
            (self.due.take()).unwrap_or_else(|| Instant::now() + self.refresh.unwrap_or_default());
        if let (true, Some(pose_at)) = (shown, self.pose_at) {
            record.pose_to_photon_ms = Some(due.duration_since(pose_at).as_secs_f64() * 1e3);
        }
        if let (Some(submit), Some(photon), Some(_)) = (
            record.pose_to_submit_ms,
            record.pose_to_photon_ms,
            record.cpu_ms,
        ) {
            self.latencies.push((submit, photon));
        }
        self.events.extend(note);
        let events = std::mem::take(&mut self.events);
        record.events = events.join("; ");
        (record.block, record.trial) = self.trial;
        record.condition.clone_from(&self.condition);
        record.flash = self.flash;
        if let (Some(log), true) = (self.log.as_deref_mut(), self.logging) {
            log.record(&record)?;
        }
        self.acknowledge(&record);
        let Some(lsl) = &self.lsl else {
            return Ok(());
        };
        let late = match (record.cpu_ms, self.refresh) {
            (Some(ms), Some(period)) => {
                let refreshes = ms / (period.as_secs_f64() * 1e3);
                Some((refreshes > 1.0, (refreshes.ceil() as u32).saturating_sub(1)))
            }
            _ => None,
        };
        let sample = FrameSample {
            record: &record,
            pose_at: self.pose_at.unwrap_or_else(Instant::now),
            due,
            shown,
            late,
        };
        let mut markers = events;
        markers.append(&mut self.markers);
        lsl.frame(&sample, &markers)
    }

    /// This frame's commands acknowledged with its number (and `state` with its pose); each
    /// with its reply a marker for LSL.
    fn acknowledge(&mut self, record: &FrameRecord) {
        for p in std::mem::take(&mut self.pending) {
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
                extra.insert("condition".into(), self.condition.clone().into());
            }
            let command = serde_json::to_value(&p.command).unwrap_or_default();
            let reply = p.ack(record.frame, extra);
            if self.lsl.is_some() {
                self.markers.push(command_marker(command, &reply));
            }
        }
    }
}

/// A command and its reply as one marker: `{"command": ..., "reply": ...}`.
fn command_marker(command: serde_json::Value, reply: &str) -> String {
    let reply: serde_json::Value = serde_json::from_str(reply).unwrap_or(reply.into());
    serde_json::json!({ "command": command, "reply": reply }).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::log::Drawn;
    use std::io::{BufRead, Write};

    fn record(frame: u64) -> FrameRecord {
        FrameRecord {
            frame,
            time_s: 0.0,
            drawn: Drawn::Shown,
            pose: Pose {
                head: Vec3::ZERO,
                head_rotation: glam::Quat::IDENTITY,
                room_position: Vec3::ZERO,
                room_yaw_deg: 0.0,
            },
            wand: None,
            left_hand: None,
            targets: Default::default(),
            gpu_ms: None,
            cpu_ms: None,
            block: 0,
            trial: 0,
            pose_to_submit_ms: Some(0.1),
            pose_to_photon_ms: None,
            object_time_s: None,
            raw: Default::default(),
            views: Vec::new(),
            events: String::new(),
            condition: String::new(),
            objects: None,
            flash: None,
            eyes: Vec::new(),
        }
    }

    /// Frames from `*frame` on until a command has arrived and taken effect; its reply.
    fn until_reply(
        session: &mut Session<'_>,
        frame: &mut u64,
        replies: &mut impl BufRead,
        walls: &mut Vec<Option<bool>>,
    ) -> serde_json::Value {
        loop {
            session.begin_frame();
            walls.push(session.flash());
            let took = !session.pending.is_empty();
            session.end_frame(record(*frame), None).unwrap();
            *frame += 1;
            if took {
                let mut line = String::new();
                replies.read_line(&mut line).unwrap();
                return serde_json::from_str(&line).unwrap();
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn a_flash_whitens_one_frame_then_the_walls_stay_black_until_the_test_ends() {
        let server = ControlServer::bind("127.0.0.1:0").unwrap();
        let mut session = Session::new(None, Some(&server));
        let mut client = std::net::TcpStream::connect(server.addr).unwrap();
        let mut replies = std::io::BufReader::new(client.try_clone().unwrap());
        let (mut frame, mut walls) = (0, Vec::new());
        writeln!(client, r#"{{"cmd": "flash"}}"#).unwrap();
        let flash = until_reply(&mut session, &mut frame, &mut replies, &mut walls);
        assert_eq!(
            (flash["ok"].as_bool(), flash["cmd"].as_str()),
            (Some(true), Some("flash"))
        );
        let white = flash["frame"].as_u64().unwrap() as usize;
        assert_eq!(walls[white], Some(true));
        assert!(walls[..white].iter().all(|w| w.is_none()));
        writeln!(client, r#"{{"cmd": "flash", "end": true}}"#).unwrap();
        let end = until_reply(&mut session, &mut frame, &mut replies, &mut walls);
        let back = end["frame"].as_u64().unwrap() as usize;
        assert!(back > white);
        assert!(walls[white + 1..back].iter().all(|w| *w == Some(false)));
        assert_eq!(walls[back], None);
    }

    #[test]
    fn object_commands_reach_the_display_and_an_unknown_object_is_refused() {
        let server = ControlServer::bind("127.0.0.1:0").unwrap();
        let mut session = Session::new(None, Some(&server)).with_objects(vec!["body".into()]);
        let mut client = std::net::TcpStream::connect(server.addr).unwrap();
        client
            .set_read_timeout(Some(Duration::from_millis(20)))
            .unwrap();
        let mut replies = std::io::BufReader::new(client.try_clone().unwrap());
        for line in [
            r#"{"cmd": "hide", "object": "chair"}"#,
            r#"{"cmd": "hide", "object": "body"}"#,
            r#"{"cmd": "shadows", "on": false}"#,
            r#"{"cmd": "reflections", "on": false}"#,
        ] {
            writeln!(client, "{line}").unwrap();
        }
        let (mut changes, mut lines) = (Vec::new(), Vec::new());
        for frame in 0..400 {
            session.begin_frame();
            changes.extend(session.take_object_changes());
            session.end_frame(record(frame), None).unwrap();
            let mut line = String::new();
            while replies.read_line(&mut line).is_ok_and(|n| n > 0) {
                lines.push(serde_json::from_str::<serde_json::Value>(&line).unwrap());
                line.clear();
            }
            if lines.len() == 4 {
                break;
            }
        }
        assert_eq!(
            changes,
            [
                ObjectChange::Visible("body".into(), false),
                ObjectChange::Shadows(false),
                ObjectChange::Reflections(false)
            ]
        );
        assert_eq!(lines.len(), 4, "{lines:?}");
        let refused = &lines[0];
        let error = refused["error"].as_str().unwrap();
        assert_eq!(refused["ok"].as_bool(), Some(false));
        assert!(error.contains("chair") && error.contains("body"), "{error}");
        for ack in &lines[1..] {
            assert_eq!(ack["ok"].as_bool(), Some(true), "{ack}");
            assert!(ack["frame"].as_u64().is_some());
        }
    }

    #[test]
    fn a_condition_switches_with_its_start_pose_and_an_unknown_one_is_refused() {
        let server = ControlServer::bind("127.0.0.1:0").unwrap();
        let start = (Vec3::new(0.0, 0.0, 2.6), 15.0);
        let conditions = vec![("gi-on".to_string(), None), ("gi-off".into(), Some(start))];
        let mut session = Session::new(None, Some(&server)).with_conditions(conditions);
        // the first is in effect from the first frame, for the display to bind
        assert_eq!(session.condition(), "gi-on");
        assert_eq!(session.take_condition().as_deref(), Some("gi-on"));
        let mut client = std::net::TcpStream::connect(server.addr).unwrap();
        client
            .set_read_timeout(Some(Duration::from_millis(20)))
            .unwrap();
        let mut replies = std::io::BufReader::new(client.try_clone().unwrap());
        let (mut frame, mut walls) = (0, Vec::new());
        writeln!(client, r#"{{"cmd": "condition", "name": "sepia"}}"#).unwrap();
        // refused as the frame takes it: nothing pending, the reply at once
        let mut line = String::new();
        for f in 0..400 {
            session.begin_frame();
            session.end_frame(record(f), None).unwrap();
            if replies.read_line(&mut line).is_ok_and(|n| n > 0) {
                break;
            }
        }
        let refused: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(refused["ok"], false);
        let error = refused["error"].as_str().unwrap();
        assert!(
            error.contains("sepia") && error.contains("gi-on, gi-off"),
            "{error}"
        );
        assert_eq!(session.take_condition(), None, "nothing changed");
        assert_eq!(session.condition(), "gi-on");
        client.set_read_timeout(None).unwrap();
        writeln!(client, r#"{{"cmd": "condition", "name": "gi-off"}}"#).unwrap();
        let switched = until_reply(&mut session, &mut frame, &mut replies, &mut walls);
        assert_eq!(switched["ok"], true);
        assert_eq!(session.take_condition().as_deref(), Some("gi-off"));
        let pose = session.pose(record(0).pose, Instant::now());
        assert_eq!((pose.room_position, pose.room_yaw_deg), start);
        writeln!(client, r#"{{"cmd": "state"}}"#).unwrap();
        let state = until_reply(&mut session, &mut frame, &mut replies, &mut walls);
        assert_eq!(state["condition"], "gi-off", "{state}");
    }
}
