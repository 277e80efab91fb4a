//! Experiment control (`vlf cave --control ADDR`): an experiment script (Python, Unity, ...)
//! connects over TCP and sends one JSON command per line; each is acknowledged, on the same
//! connection, with the frame number where it took effect, or refused with the reason and
//! nothing changed. The protocol (`docs/guide/studies.md`):
//!
//! - `{"cmd": "event", "text": "trial 3 begins"}`: an event marker, in the session log's row of
//!   that frame;
//! - `{"cmd": "teleport", "position": [x, y, z], "yaw_deg": a}`: the room's place in the world
//!   from that frame on (the tracked head moves with it);
//! - `{"cmd": "trial", "block": 1, "trial": 3}`: the experiment's block and trial, in every
//!   row of the session log from that frame on;
//! - `{"cmd": "log", "on": false}`: stop (or resume) writing rows to the session log;
//! - `{"cmd": "state"}`: the frame, the head and the room, the log's state;
//! - `{"cmd": "stop"}`: end the run; the headless run reads that frame back as its last;
//! - `{"cmd": "condition", "name": "gi-off"}`: one of the display config's named conditions
//!   (`[[condition]]`: light field, exposure, objects, start pose) from that frame on;
//! - `{"cmd": "flash"}`: a latency test for a photodiode: every wall full white for that frame,
//!   then black until `{"cmd": "flash", "end": true}` brings the scene back (the windows; the
//!   views are drawn all the while, so the frame time does not change).
//!
//! Replies: `{"ok": true, "cmd": ..., "frame": N, ...}` or `{"ok": false, "error": "..."}`. A
//! client that goes away changes nothing on screen. Every client has a thread of its own; the
//! frame loop takes what arrived once a frame (`ControlServer::take`), never waiting.

use crate::error::{Result, VlfError};
use crossbeam::channel::{unbounded, Receiver, Sender};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};

/// A command, as a line of JSON names it.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum Command {
    Event {
        text: String,
    },
    Teleport {
        position: [f32; 3],
        yaw_deg: f32,
    },
    Trial {
        block: u32,
        trial: u32,
    },
    Log {
        on: bool,
    },
    State,
    Stop,
    Flash {
        #[serde(default)]
        end: bool,
    },
    /// show or hide a moving object (the display config's `[[object]]` name)
    Show {
        object: String,
    },
    Hide {
        object: String,
    },
    /// the moving objects' shadows on the scene, and their reflections in its mirrors
    Shadows {
        on: bool,
    },
    Reflections {
        on: bool,
    },
    /// a named condition of the display config (`[[condition]]`)
    Condition {
        name: String,
    },
}

impl Command {
    /// The command's name, as its `cmd` gives it.
    pub fn name(&self) -> &'static str {
        match self {
            Command::Event { .. } => "event",
            Command::Teleport { .. } => "teleport",
            Command::Trial { .. } => "trial",
            Command::Log { .. } => "log",
            Command::State => "state",
            Command::Stop => "stop",
            Command::Flash { .. } => "flash",
            Command::Show { .. } => "show",
            Command::Hide { .. } => "hide",
            Command::Shadows { .. } => "shadows",
            Command::Reflections { .. } => "reflections",
            Command::Condition { .. } => "condition",
        }
    }
}

/// A command that arrived, waiting for the frame loop; `ack` answers its client.
pub struct Pending {
    pub command: Command,
    reply: Sender<String>,
}

impl Pending {
    /// Took effect at `frame`; `extra` adds fields to the reply (`state`'s). Returns the reply
    /// as sent.
    pub fn ack(self, frame: u64, extra: serde_json::Map<String, serde_json::Value>) -> String {
        let mut reply = serde_json::Map::new();
        reply.insert("ok".into(), true.into());
        reply.insert("cmd".into(), self.command.name().into());
        reply.insert("frame".into(), frame.into());
        reply.extend(extra);
        let reply = serde_json::Value::Object(reply).to_string();
        // a client that went away hears nothing; the run goes on
        let _ = self.reply.send(reply.clone());
        reply
    }

    /// Refused when the frame loop took it (a name the run does not know): nothing changed.
    /// Returns the reply as sent.
    pub fn refuse(self, error: &str) -> String {
        let reply = serde_json::json!({"ok": false, "cmd": self.command.name(), "error": error});
        let reply = reply.to_string();
        let _ = self.reply.send(reply.clone());
        reply
    }
}

/// The listening end: clients connect to `addr`.
pub struct ControlServer {
    pub addr: SocketAddr,
    commands: Receiver<Pending>,
    /// the lines refused, with their replies (for the LSL event stream)
    refused: Receiver<(String, String)>,
}

impl ControlServer {
    /// Listen on `addr` (port 0: any free port; `addr` then says which).
    pub fn bind(addr: &str) -> Result<ControlServer> {
        let listener = TcpListener::bind(addr).map_err(|e| {
            VlfError::Display(format!(
                "--control {addr}: cannot listen there ({e}); give host:port, e.g. 127.0.0.1:7400"
            ))
        })?;
        let local = listener
            .local_addr()
            .map_err(|e| VlfError::Display(format!("--control {addr}: {e}")))?;
        let (sender, commands) = unbounded();
        let (refusals, refused) = unbounded();
        std::thread::Builder::new()
            .name("vlf control: accept".into())
            .spawn(move || {
                for stream in listener.incoming().flatten() {
                    let senders = (sender.clone(), refusals.clone());
                    let _ = std::thread::Builder::new()
                        .name("vlf control: client".into())
                        .spawn(move || serve_client(stream, senders));
                }
            })
            .map_err(|e| VlfError::Display(format!("control thread: {e}")))?;
        Ok(ControlServer {
            addr: local,
            commands,
            refused,
        })
    }

    /// The commands that arrived since the last call, in order (never waits).
    pub fn take(&self) -> Vec<Pending> {
        self.commands.try_iter().collect()
    }

    /// The lines refused since the last call, each with its reply (never waits).
    pub fn take_refused(&self) -> Vec<(String, String)> {
        self.refused.try_iter().collect()
    }
}

/// One client: its lines parsed into commands for the frame loop, its replies written back; a
/// refused line, with its reply, to `refusals` too.
fn serve_client(
    stream: TcpStream,
    (commands, refusals): (Sender<Pending>, Sender<(String, String)>),
) {
    let Ok(mut writer) = stream.try_clone() else {
        return;
    };
    let (reply, replies) = unbounded::<String>();
    // replies go out as the frame loop acknowledges, whatever the client sends meanwhile
    let out = std::thread::spawn(move || {
        for line in replies {
            if writeln!(writer, "{line}")
                .and_then(|_| writer.flush())
                .is_err()
            {
                return;
            }
        }
    });
    for line in BufReader::new(stream).lines() {
        let Ok(line) = line else { break };
        if line.trim().is_empty() {
            continue;
        }
        match parse(&line) {
            Ok(command) => {
                let pending = Pending {
                    command,
                    reply: reply.clone(),
                };
                if commands.send(pending).is_err() {
                    break;
                }
            }
            Err(error) => {
                let refused = serde_json::json!({ "ok": false, "error": error }).to_string();
                let _ = refusals.send((line.clone(), refused.clone()));
                let _ = reply.send(refused);
            }
        }
    }
    drop(reply);
    let _ = out.join();
}

/// A line as a command, or why it is not one (the reply says so; nothing changes).
pub fn parse(line: &str) -> std::result::Result<Command, String> {
    let command: Command = serde_json::from_str(line).map_err(|e| {
        format!(
            "{e} in {line:?}: a command is one JSON object per line, e.g. {{\"cmd\": \"event\", \"text\": \"trial 1\"}} (commands: event, teleport, trial, log, state, stop, flash, show, hide, shadows, reflections, condition)"
        )
    })?;
    if let Command::Teleport { position, yaw_deg } = &command {
        if !(position.iter().all(|p| p.is_finite()) && yaw_deg.is_finite()) {
            return Err("teleport: position and yaw_deg must be finite numbers".into());
        }
    }
    Ok(command)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_parse_and_bad_ones_say_why() {
        assert_eq!(
            parse(r#"{"cmd": "event", "text": "trial 1"}"#),
            Ok(Command::Event {
                text: "trial 1".into()
            })
        );
        assert_eq!(parse(r#"{"cmd":"stop"}"#), Ok(Command::Stop));
        assert_eq!(
            parse(r#"{"cmd":"flash"}"#),
            Ok(Command::Flash { end: false })
        );
        assert_eq!(
            parse(r#"{"cmd":"flash","end":true}"#),
            Ok(Command::Flash { end: true })
        );
        let unknown = parse(r#"{"cmd": "fly"}"#).unwrap_err();
        assert!(
            unknown.contains("fly") && unknown.contains("commands:"),
            "{unknown}"
        );
        let extra = parse(r#"{"cmd": "log", "on": true, "colour": 1}"#).unwrap_err();
        assert!(extra.contains("colour"), "{extra}");
        assert!(parse("not json").is_err());
    }
}
