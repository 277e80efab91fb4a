//! The MPI side of a CAVE cluster (feature `mpi`, rsmpi over the system's Open MPI): start-up
//! (who draws what, the light field loaded from a shared path or sent by rank 0), the frame
//! lock (rank 0's `FrameState` to every rank, a swap barrier before present) and the end
//! (every rank's report gathered and checked by rank 0).
//!
//! Every exchange is point to point, non-blocking and polled against a deadline, never a
//! blocking collective: a rank that dies, hangs or fails is noticed by rank 0 within
//! `[cluster] timeout_s` (by the others within twice that when rank 0 itself is lost), each
//! survivor prints which rank was lost, rank 0 prints the cluster report and ends the job with
//! MPI_Abort (which also takes down a hung rank). When mpirun itself ends the job (its default
//! when a rank is killed), every rank gets SIGTERM: a watcher thread then prints the lost rank
//! (a peer whose process is gone, on the same host; else the ranks rank 0 was waiting for) and
//! rank 0's partial report before exiting.

use super::*;
use crate::display::conditions::{Conditions, MainField};
use crate::display::{headless, window, DisplayConfig};
use crate::error::{Result, VlfError};
use crate::framelock::{FrameLock, FrameState};
use crate::gpu::GpuContext;
use crate::lightfield::file;
use mpi::request::StaticScope;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Tag;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::io::Write;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const STATE: Tag = 1;
const ARRIVE: Tag = 2;
const GO: Tag = 3;
const LOST: Tag = 4;
const FAIL: Tag = 5;
const REPORT: Tag = 6;
const DONE: Tag = 7;
const HELLO: Tag = 8;
const PLAN: Tag = 9;
const LIGHT_FIELD: Tag = 10;
/// light field bytes per message (MPI counts are 32-bit)
const CHUNK: usize = 256 << 20;

struct Message {
    from: i32,
    tag: Tag,
    bytes: Vec<u8>,
}

/// What a rank tells rank 0 at start-up.
#[derive(Serialize, Deserialize)]
struct Hello {
    host: String,
    pid: u32,
    can_read_light_field: bool,
}

/// What rank 0 tells each rank at start-up.
#[derive(Serialize, Deserialize)]
struct Plan {
    /// host and process id of every rank
    peers: Vec<(String, u32)>,
    views: Vec<(usize, Option<String>)>,
    receive_light_field: bool,
    /// the GPU this rank opens (`[cluster] gpu`, a node's `gpu`)
    gpu: AdapterChoice,
}

/// What the SIGTERM watcher needs: kept current by the frame lock.
#[derive(Default)]
struct Watch {
    rank: u32,
    size: u32,
    host: String,
    peers: Vec<(String, u32)>,
    frame: u64,
    /// ranks rank 0 is waiting for at the swap barrier now
    waiting: Vec<u32>,
    shown: Vec<[u64; 2]>,
    swap_ms: Vec<f64>,
    cpu_ms: Vec<f64>,
    /// present to present, milliseconds
    frame_ms: Vec<f64>,
    last_present: Option<Instant>,
    display: String,
    adapter: String,
    /// this rank's GPU: index asked for and PCI bus address
    gpu: Option<RankGpu>,
    /// eye rays per pixel the frame pacer gave this rank's views (headless, paced)
    pacer: Option<crate::render::budget::PacerReport>,
    timeout_s: f64,
    json: Option<std::path::PathBuf>,
    /// the run's end is being handled (a lost rank reported): SIGTERM then ends quietly
    ending: bool,
}

/// One rank's end of the frame lock.
struct Link {
    world: SimpleCommunicator,
    rank: i32,
    size: i32,
    timeout: Duration,
    startup: Duration,
    /// the first frame is done (before it, the start-up timeout applies)
    started: bool,
    stash: VecDeque<Message>,
    lost: Vec<LostRank>,
    current: Option<FrameState>,
    frame_began: Instant,
    quit_seen: bool,
    /// rank 0: the ranks it sends the light field to
    receivers: Vec<i32>,
    /// rank 0 went silent (not: it reported a loss or its own failure)
    leader_gone: bool,
    watch: Arc<Mutex<Watch>>,
}

fn cluster_err(message: String) -> VlfError {
    VlfError::Cluster(message)
}

impl Link {
    fn leader(&self) -> bool {
        self.rank == 0
    }

    /// How long rank 0 may take to answer: it waits `timeout` for the slowest rank first.
    fn leader_wait(&self) -> Duration {
        match self.started {
            true => self.timeout * 2 + Duration::from_secs(1),
            false => self.startup,
        }
    }

    fn wait(&self) -> Duration {
        if self.started {
            self.timeout
        } else {
            self.startup
        }
    }

    /// Send `bytes` to `to`, polling until sent or `within` has passed (then false; the
    /// buffer is left to MPI).
    fn send(&self, to: i32, tag: Tag, bytes: Vec<u8>, within: Duration) -> bool {
        let deadline = Instant::now() + within;
        let buf: &'static mut [u8] = Box::leak(bytes.into_boxed_slice());
        let ptr: *mut [u8] = buf;
        let mut request =
            (self.world.process_at_rank(to)).immediate_send_with_tag(StaticScope, &*buf, tag);
        loop {
            match request.test() {
                Ok(_) => {
                    // SAFETY: MPI is done with the buffer leaked above; nothing else refers to it
                    drop(unsafe { Box::from_raw(ptr) });
                    return true;
                }
                Err(r) => request = r,
            }
            if Instant::now() > deadline {
                std::mem::forget(request);
                return false;
            }
            std::thread::sleep(Duration::from_micros(20));
        }
    }

    /// The next message with one of `tags` (from `from`, or anyone), or None after `within`;
    /// other messages are kept for later.
    fn recv(&mut self, tags: &[Tag], from: Option<i32>, within: Duration) -> Option<Message> {
        let wanted = |m: &Message| tags.contains(&m.tag) && from.is_none_or(|f| f == m.from);
        if let Some(i) = self.stash.iter().position(wanted) {
            return self.stash.remove(i);
        }
        let deadline = Instant::now() + within;
        let mut polls = 0u32;
        loop {
            if let Some(probed) = self.world.any_process().immediate_matched_probe() {
                let (from, tag) = (probed.1.source_rank(), probed.1.tag());
                let (bytes, _) = probed.matched_receive_vec::<u8>();
                let m = Message { from, tag, bytes };
                if wanted(&m) {
                    return Some(m);
                }
                self.stash.push_back(m);
                continue;
            }
            if Instant::now() > deadline {
                return None;
            }
            polls += 1;
            // spin briefly (the barrier's latency), then sleep
            if polls > 2000 {
                std::thread::sleep(Duration::from_micros(100));
            } else {
                std::thread::yield_now();
            }
        }
    }

    /// Record `rank` lost; the error to return.
    fn lose(&mut self, rank: i32, reason: String) -> VlfError {
        let e = cluster_err(format!("lost rank {rank}: {reason}"));
        self.leader_gone |= rank == 0;
        self.lost.push(LostRank {
            rank: rank as u32,
            reason,
        });
        e
    }

    /// A LOST message from rank 0: the ranks it lost (rank 0 itself when it failed).
    fn lost_from(&mut self, m: &Message) -> VlfError {
        let lost: Vec<LostRank> = serde_json::from_slice(&m.bytes).unwrap_or_default();
        let text: Vec<String> = (lost.iter())
            .map(|l| format!("rank {}: {}", l.rank, l.reason))
            .collect();
        self.lost.extend(lost);
        cluster_err(format!("rank 0 ended the run: lost {}", text.join("; ")))
    }

    fn alive_followers(&self) -> Vec<i32> {
        (1..self.size)
            .filter(|r| !self.lost.iter().any(|l| l.rank as i32 == *r))
            .collect()
    }
}

impl FrameLock for Link {
    fn is_leader(&self) -> bool {
        self.leader()
    }

    fn share(&mut self, state: FrameState) -> Result<FrameState> {
        let state = if self.leader() {
            for r in self.alive_followers() {
                if !self.send(r, STATE, bytemuck::bytes_of(&state).to_vec(), self.wait()) {
                    let s = self.wait().as_secs_f64();
                    return Err(self.lose(r, format!("took no frame state within {s} s")));
                }
            }
            state
        } else {
            let within = self.leader_wait();
            match self.recv(&[STATE, LOST], Some(0), within) {
                None => {
                    let s = within.as_secs_f64();
                    return Err(self.lose(0, format!("sent no frame state within {s} s")));
                }
                Some(m) if m.tag == LOST => return Err(self.lost_from(&m)),
                Some(m) => bytemuck::pod_read_unaligned::<FrameState>(&m.bytes),
            }
        };
        self.quit_seen |= state.is_quit();
        self.current = Some(state);
        self.frame_began = Instant::now();
        self.watch.lock().unwrap_or_else(|e| e.into_inner()).frame = state.frame;
        Ok(state)
    }

    fn swap(&mut self) -> Result<()> {
        self.swap_timed(true)
    }

    fn swap_untimed(&mut self) -> Result<()> {
        self.swap_timed(false)
    }
}

impl Link {
    /// The swap barrier; `counted`: the frame's times go into the report.
    fn swap_timed(&mut self, counted: bool) -> Result<()> {
        let cpu_ms = self.frame_began.elapsed().as_secs_f64() * 1e3;
        let t0 = Instant::now();
        let frame = self.current.map_or(0, |s| s.frame);
        if self.leader() {
            self.leader_swap(frame)?;
        } else {
            let within = self.leader_wait();
            if !self.send(0, ARRIVE, frame.to_le_bytes().to_vec(), within) {
                return Err(self.lose(0, "took no swap-barrier arrival".into()));
            }
            match self.recv(&[GO, LOST], Some(0), within) {
                None => {
                    let s = within.as_secs_f64();
                    return Err(self.lose(
                        0,
                        format!("did not release the swap barrier of frame {frame} within {s} s"),
                    ));
                }
                Some(m) if m.tag == LOST => return Err(self.lost_from(&m)),
                Some(_) => {}
            }
        }
        // the first frame (shader compilation, every rank getting ready) is not timed
        let timed = std::mem::replace(&mut self.started, true) && counted;
        let digest = self.current.map_or(0, |s| s.pose_digest());
        let mut w = self.watch.lock().unwrap_or_else(|e| e.into_inner());
        if timed {
            w.swap_ms.push(t0.elapsed().as_secs_f64() * 1e3);
            w.cpu_ms.push(cpu_ms);
        }
        w.shown.push([frame, digest as u64]);
        let now = Instant::now();
        if let Some(last) = w.last_present.replace(now) {
            if counted {
                w.frame_ms.push((now - last).as_secs_f64() * 1e3);
            }
        }
        Ok(())
    }
}

impl Link {
    /// Rank 0 at the swap barrier: every rank's arrival at `frame`, then the release.
    fn leader_swap(&mut self, frame: u64) -> Result<()> {
        let mut waiting = self.alive_followers();
        let within = self.wait();
        let deadline = Instant::now() + within;
        while !waiting.is_empty() {
            self.watch.lock().unwrap_or_else(|e| e.into_inner()).waiting =
                waiting.iter().map(|&r| r as u32).collect();
            let left = deadline.saturating_duration_since(Instant::now());
            match self.recv(&[ARRIVE, FAIL], None, left) {
                None => {
                    let s = within.as_secs_f64();
                    let reason = format!("did not reach the swap barrier of frame {frame} within {s} s (dead, hung or without its display)");
                    let mut e = None;
                    for r in waiting.clone() {
                        e = Some(self.lose(r, reason.clone()));
                    }
                    return Err(e.expect("someone was waiting"));
                }
                Some(m) if m.tag == FAIL => {
                    return Err(self.lose(m.from, String::from_utf8_lossy(&m.bytes).into()));
                }
                Some(m) => {
                    let theirs = u64::from_le_bytes(m.bytes[..8].try_into().unwrap_or([0; 8]));
                    if theirs != frame {
                        let reason =
                            format!("arrived at the swap barrier with frame {theirs}, not {frame}");
                        return Err(self.lose(m.from, reason));
                    }
                    waiting.retain(|&r| r != m.from);
                }
            }
        }
        self.watch
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .waiting
            .clear();
        for r in self.alive_followers() {
            if !self.send(r, GO, frame.to_le_bytes().to_vec(), within) {
                return Err(self.lose(r, "took no swap-barrier release".into()));
            }
        }
        Ok(())
    }

    /// This rank's part of the report.
    fn rank_report(&self, views: Vec<ViewTiming>, error: Option<String>) -> RankReport {
        let w = self.watch.lock().unwrap_or_else(|e| e.into_inner());
        RankReport {
            rank: self.rank as u32,
            host: w.host.clone(),
            pid: std::process::id(),
            views,
            cpu_frame_ms: Stats::of(&w.cpu_ms),
            swap_wait_ms: Stats::of(&w.swap_ms),
            frame_ms: Stats::of(&w.frame_ms),
            frame_ms_series: w.frame_ms.iter().map(|&t| t as f32).collect(),
            swap_wait_ms_series: w.swap_ms.iter().map(|&t| t as f32).collect(),
            shown: w.shown.clone(),
            gpu: w.gpu.clone(),
            pacer: w.pacer.clone(),
            error,
        }
    }
}

/// Run this process as its rank of the cluster (see the module header); prints the cluster
/// report on rank 0, and ends the process when a rank is lost.
pub fn run(run: &CaveRun, make: &mut MakeLightField) -> Result<()> {
    let sigterm = block_sigterm();
    let universe =
        mpi::initialize().ok_or_else(|| cluster_err("MPI was initialised twice".into()))?;
    let world = universe.world();
    let (rank, size) = (world.rank(), world.size());
    let host = mpi::environment::processor_name().unwrap_or_else(|_| "?".into());
    let display = DisplayConfig::load(&run.config);
    let cluster = (display.as_ref().ok())
        .and_then(|d| d.cluster.clone())
        .unwrap_or_default();
    let watch = Arc::new(Mutex::new(Watch {
        rank: rank as u32,
        size: size as u32,
        host: host.clone(),
        display: display.as_ref().map_or(String::new(), |d| d.name.clone()),
        json: run.json.clone(),
        timeout_s: cluster.timeout_s,
        ..Default::default()
    }));
    spawn_watcher(sigterm, watch.clone());
    let mut link = Link {
        world,
        rank,
        size,
        timeout: Duration::from_secs_f64(cluster.timeout_s),
        startup: Duration::from_secs_f64(cluster.startup_timeout_s),
        started: false,
        stash: VecDeque::new(),
        lost: Vec::new(),
        current: None,
        frame_began: Instant::now(),
        quit_seen: false,
        receivers: Vec::new(),
        leader_gone: false,
        watch,
    };
    let mut adapter = String::new();
    // a panic (a window system gone from under winit) is this rank's failure like an error:
    // reported to rank 0 at once, not left to unwind into MPI_Finalize
    let drawn = display.and_then(|d| {
        let draw = || draw(&mut link, run, &d, &cluster, make, &mut adapter);
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(draw)).unwrap_or_else(|p| {
            let what = (p.downcast_ref::<String>().cloned())
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(cluster_err(format!("panicked: {what}")))
        })
    });
    match drawn {
        Ok(views) => finish(&mut link, run, views, &cluster, adapter),
        Err(e) => fail(&mut link, run, e, &cluster, adapter),
    }
}

/// A study's parts on one rank (`vlf cave --log/--control/--lsl` under mpirun): every rank
/// logs its own views into `<log>/rank<k>` (rank 0's log has the events and commands); rank 0
/// alone takes the script's commands and sends on LSL, and its session's state reaches every
/// rank with the frame state (`crate::framelock::StudyState`).
struct StudyParts {
    log: Option<crate::study::SessionLog>,
    control: Option<crate::study::ControlServer>,
    lsl: Option<crate::study::LslOutlets>,
}

impl StudyParts {
    fn open(
        run: &CaveRun,
        rank: i32,
        local: &DisplayConfig,
        lf: &crate::lightfield::LightField,
        ctx: &GpuContext,
    ) -> Result<StudyParts> {
        let objects = local.object_names().len();
        let studied = run.log.is_some() || run.control.is_some() || !local.conditions.is_empty();
        if studied && objects > crate::display::frame::study::SHARED_OBJECTS {
            return Err(cluster_err(format!(
                "the display has {objects} [[object]] tables: a cluster shares which are shown for the first {} only",
                crate::display::frame::study::SHARED_OBJECTS
            )));
        }
        let log = match &run.log {
            Some(dir) => {
                let mine = dir.join(format!("rank{rank}"));
                let scene = (run.config.as_path(), run.scene.as_path());
                Some(crate::display::session_log(
                    &mine,
                    scene,
                    lf,
                    local,
                    &ctx.summary.name,
                )?)
            }
            None => None,
        };
        let leader = rank == 0;
        let control = match (&run.control, leader) {
            (Some(addr), true) => {
                let server = crate::study::ControlServer::bind(addr)?;
                eprintln!("control: listening on {}", server.addr);
                Some(server)
            }
            _ => None,
        };
        let lsl = match run.lsl && leader {
            true => Some(crate::study::LslOutlets::open(
                &local.name,
                local.refresh_hz,
                run.headless,
            )?),
            false => None,
        };
        Ok(StudyParts { log, control, lsl })
    }
}

/// Start-up, then this rank's frames; its views' timings.
fn draw(
    link: &mut Link,
    run: &CaveRun,
    display: &DisplayConfig,
    cluster: &ClusterConfig,
    make: &mut MakeLightField,
    adapter: &mut String,
) -> Result<Vec<ViewTiming>> {
    let is_vlf = crate::lightfield::file::is_vlf_path(&run.scene);
    let can_read = is_vlf
        && cluster.light_field != LightFieldShare::Broadcast
        && std::fs::File::open(&run.scene).is_ok();
    if !can_read && is_vlf && cluster.light_field == LightFieldShare::Shared && link.rank != 0 {
        return Err(cluster_err(format!("{}: this rank cannot read the light field, and [cluster] light_field = \"shared\" (use \"auto\" to get it from rank 0)", run.scene.display())));
    }
    let plan = plan(link, display, cluster, can_read)?;
    let views: Vec<ViewRef> = (plan.views.iter())
        .map(|(w, e)| {
            (
                *w,
                e.as_deref()
                    .and_then(|e| ["left", "right"].into_iter().find(|x| *x == e)),
            )
        })
        .collect();
    let local = local_config(display, &views, link.leader());
    let names: Vec<String> = (local.walls.iter())
        .flat_map(|w| w.eyes().into_iter().map(|(e, _)| format!("{}-{e}", w.name)))
        .collect();
    println!(
        "vlf cluster: rank {} of {} on {} (pid {}) draws {}",
        link.rank,
        link.size,
        link.watch.lock().unwrap_or_else(|e| e.into_inner()).host,
        std::process::id(),
        names.join(", ")
    );
    let _ = std::io::stdout().flush();
    let ctx = GpuContext::open(plan.gpu)?;
    *adapter = ctx.summary.name.clone();
    {
        let mut watch = link.watch.lock().unwrap_or_else(|e| e.into_inner());
        watch.adapter = adapter.clone();
        watch.gpu = Some(RankGpu {
            name: ctx.summary.name.clone(),
            index: ctx.summary.gpu_index,
            pci_bus_id: ctx.summary.pci_bus_id.clone(),
        });
    }
    let (lf, resident) = light_field(link, &ctx, make, plan.receive_light_field)?;
    // every condition's light field made on every rank before the first frame (`Conditions`)
    let main = MainField {
        source: &run.scene,
        lf: &lf,
        resident: &resident,
    };
    let conditions = Conditions::prepare(&local, &run.config, main, &crate::progress::Silent)?;
    let mut study = StudyParts::open(run, link.rank, &local, &lf, &ctx)?;
    if run.headless {
        let out = run.out.join(format!("rank{}", link.rank));
        let frames = run.frames.unwrap_or(60);
        let report = headless::run_locked(
            &lf,
            &resident,
            &local,
            &run.config,
            headless::HeadlessRun {
                frames,
                out: &out,
                exr: run.exr,
                log: study.log.as_mut(),
                control: study.control.as_ref(),
                lsl: study.lsl.take(),
                conditions: conditions.as_ref(),
                read_back_every_frame: false,
            },
            Some(link),
            &crate::progress::Silent,
        )?;
        link.watch.lock().unwrap_or_else(|e| e.into_inner()).pacer = report.pacer.clone();
        Ok(report.views)
    } else {
        let options = window::WindowOptions {
            frames: run.frames,
            hold: run.hold,
            exposure: run.exposure,
            conditions: conditions.as_ref(),
        };
        let session = crate::study::Session::new(study.log.as_mut(), study.control.as_ref())
            .with_display(local.refresh_hz, study.lsl.take())
            .with_objects(local.object_names());
        let report = window::run_locked(
            &lf,
            &resident,
            &local,
            &run.config,
            options,
            Some(link),
            session,
        )?;
        Ok(report.views)
    }
}

/// Who draws what: every rank says hello to rank 0, which assigns the views and answers.
fn plan(
    link: &mut Link,
    display: &DisplayConfig,
    cluster: &ClusterConfig,
    can_read: bool,
) -> Result<Plan> {
    let me = Hello {
        host: link
            .watch
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .host
            .clone(),
        pid: std::process::id(),
        can_read_light_field: can_read,
    };
    let within = link.startup;
    if !link.leader() {
        let hello = serde_json::to_vec(&me).unwrap_or_default();
        if !link.send(0, HELLO, hello, within) {
            return Err(link.lose(0, "took no start-up message".into()));
        }
        let plan = match link.recv(&[PLAN, LOST], Some(0), within) {
            None => return Err(link.lose(0, format!("sent no plan within {} s", within.as_secs()))),
            Some(m) if m.tag == LOST => return Err(link.lost_from(&m)),
            Some(m) => serde_json::from_slice::<Plan>(&m.bytes)
                .map_err(|e| cluster_err(format!("rank 0's plan: {e}")))?,
        };
        link.watch.lock().unwrap_or_else(|e| e.into_inner()).peers = plan.peers.clone();
        return Ok(plan);
    }
    let mut hellos: Vec<Option<Hello>> = (0..link.size).map(|_| None).collect();
    hellos[0] = Some(me);
    let deadline = Instant::now() + within;
    while hellos.iter().any(Option::is_none) {
        let left = deadline.saturating_duration_since(Instant::now());
        match link.recv(&[HELLO, FAIL], None, left) {
            None => {
                let missing = (hellos.iter().position(Option::is_none)).unwrap_or(0);
                return Err(link.lose(
                    missing as i32,
                    format!("did not start within {} s", within.as_secs()),
                ));
            }
            Some(m) if m.tag == FAIL => {
                return Err(link.lose(m.from, String::from_utf8_lossy(&m.bytes).into()))
            }
            Some(m) => hellos[m.from as usize] = serde_json::from_slice(&m.bytes).ok(),
        }
    }
    let hellos: Vec<Hello> = hellos.into_iter().flatten().collect();
    let peers: Vec<(String, u32)> = hellos.iter().map(|h| (h.host.clone(), h.pid)).collect();
    let hosts: Vec<String> = peers.iter().map(|p| p.0.clone()).collect();
    let config_err = |message| VlfError::Config {
        path: "the display configuration".into(),
        message,
    };
    let assignment = cluster.assign(display, &hosts).map_err(config_err)?;
    let gpus = cluster.gpus(&hosts).map_err(config_err)?;
    link.watch.lock().unwrap_or_else(|e| e.into_inner()).peers = peers.clone();
    let mut mine = None;
    for (r, views) in assignment.into_iter().enumerate() {
        let plan = Plan {
            peers: peers.clone(),
            views: views
                .into_iter()
                .map(|(w, e)| (w, e.map(String::from)))
                .collect(),
            receive_light_field: !hellos[r].can_read_light_field,
            gpu: gpus[r],
        };
        if r != 0 && plan.receive_light_field {
            link.receivers.push(r as i32);
        }
        if r == 0 {
            mine = Some(plan);
        } else if !link.send(
            r as i32,
            PLAN,
            serde_json::to_vec(&plan).unwrap_or_default(),
            within,
        ) {
            return Err(link.lose(r as i32, "took no plan".into()));
        }
    }
    mine.ok_or_else(|| cluster_err("no plan for rank 0".into()))
}

/// This rank's resident light field: made here (loaded from the shared path; propagated on
/// rank 0), or received from rank 0. Rank 0 draws from the very bytes it sends.
fn light_field(
    link: &mut Link,
    ctx: &Arc<GpuContext>,
    make: &mut MakeLightField,
    receive: bool,
) -> Result<(
    crate::lightfield::LightField,
    crate::lightfield::ResidentLightField,
)> {
    let within = link.startup;
    if !link.leader() {
        if !receive {
            return make(ctx);
        }
        let mut bytes = Vec::new();
        let mut total = None;
        while total.is_none_or(|t| bytes.len() < t) {
            let m = match link.recv(&[LIGHT_FIELD, LOST], Some(0), within) {
                None => {
                    return Err(link.lose(
                        0,
                        format!("sent no light field within {} s", within.as_secs()),
                    ))
                }
                Some(m) if m.tag == LOST => return Err(link.lost_from(&m)),
                Some(m) => m,
            };
            match total {
                None => {
                    total =
                        Some(u64::from_le_bytes(m.bytes[..8].try_into().unwrap_or([0; 8])) as usize)
                }
                Some(_) => bytes.extend_from_slice(&m.bytes),
            }
        }
        let lf = file::decode(&bytes)
            .map_err(|e| cluster_err(format!("the light field from rank 0: {e}")))?;
        let resident = lf.upload(ctx.clone())?;
        return Ok((lf, resident));
    }
    let (lf, resident) = make(ctx)?;
    let receivers = link.receivers.clone();
    if receivers.is_empty() {
        return Ok((lf, resident));
    }
    let bytes = file::encode(&lf);
    eprintln!(
        "vlf cluster: rank 0 sends the light field ({:.1} MiB) to rank(s) {receivers:?}",
        bytes.len() as f64 / 1048576.0
    );
    for &r in &receivers {
        if !link.send(
            r,
            LIGHT_FIELD,
            (bytes.len() as u64).to_le_bytes().to_vec(),
            within,
        ) {
            return Err(link.lose(r, "took no light field".into()));
        }
        for chunk in bytes.chunks(CHUNK) {
            if !link.send(r, LIGHT_FIELD, chunk.to_vec(), within) {
                return Err(link.lose(r, "took no light field".into()));
            }
        }
    }
    drop(resident);
    let lf = file::decode(&bytes).map_err(|e| cluster_err(format!("the light field sent: {e}")))?;
    let resident = lf.upload(ctx.clone())?;
    Ok((lf, resident))
}

/// A normal end: rank 0 tells every rank to stop, gathers and checks their reports, prints.
fn finish(
    link: &mut Link,
    run: &CaveRun,
    views: Vec<ViewTiming>,
    cluster: &ClusterConfig,
    adapter: String,
) -> Result<()> {
    let mine = link.rank_report(views, None);
    if !link.leader() {
        while !link.quit_seen {
            let within = link.leader_wait();
            match link.recv(&[STATE, LOST], Some(0), within) {
                None => {
                    let e = link_lost(link, 0, "sent no end of the run");
                    return fail(link, run, e, cluster, adapter);
                }
                Some(m) if m.tag == LOST => {
                    let e = link.lost_from(&m);
                    return fail(link, run, e, cluster, adapter);
                }
                Some(m) => {
                    link.quit_seen = bytemuck::pod_read_unaligned::<FrameState>(&m.bytes).is_quit()
                }
            }
        }
        link.send(
            0,
            REPORT,
            serde_json::to_vec(&mine).unwrap_or_default(),
            link.leader_wait(),
        );
        link.recv(&[DONE], Some(0), link.leader_wait());
        return Ok(());
    }
    let frame = link.current.map_or(0, |s| s.frame + 1);
    for r in link.alive_followers() {
        if !link.send(
            r,
            STATE,
            bytemuck::bytes_of(&FrameState::quit(frame)).to_vec(),
            link.timeout,
        ) {
            link.lose(r, "took no end of the run".into());
        }
    }
    let report = gather(link, mine, cluster, adapter, run);
    for r in link.alive_followers() {
        link.send(r, DONE, Vec::new(), link.timeout);
    }
    if !link.lost.is_empty() {
        abort(link, 1);
    }
    report.map(|_| ())
}

fn link_lost(link: &mut Link, rank: i32, what: &str) -> VlfError {
    let s = link.leader_wait().as_secs_f64();
    link.lose(rank, format!("{what} within {s} s"))
}

/// Rank 0: every surviving rank's report, checked, printed and written (--json).
fn gather(
    link: &mut Link,
    mine: RankReport,
    cluster: &ClusterConfig,
    adapter: String,
    run: &CaveRun,
) -> Result<ClusterReport> {
    let mut per_rank = vec![mine];
    let deadline = Instant::now() + link.timeout;
    let mut waiting = link.alive_followers();
    while !waiting.is_empty() {
        let left = deadline.saturating_duration_since(Instant::now());
        match link.recv(&[REPORT, FAIL], None, left) {
            None => {
                for r in waiting.clone() {
                    link.lose(r, "sent no report".into());
                }
                break;
            }
            Some(m) if m.tag == FAIL => {
                let reason = String::from_utf8_lossy(&m.bytes).to_string();
                link.lose(m.from, reason);
            }
            Some(m) => {
                if let Ok(r) = serde_json::from_slice::<RankReport>(&m.bytes) {
                    per_rank.push(r);
                }
                waiting.retain(|&r| r != m.from);
            }
        }
    }
    per_rank.sort_by_key(|r| r.rank);
    let display = link
        .watch
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .display
        .clone();
    let mut report = ClusterReport {
        display,
        adapter,
        mode: if run.headless { "headless" } else { "windows" }.into(),
        ranks: link.size as u32,
        timeout_s: cluster.timeout_s,
        same_frames_and_poses: false,
        check: String::new(),
        lost: link.lost.clone(),
        per_rank,
    };
    report.check_frames();
    print!("{}", report.table());
    let _ = std::io::stdout().flush();
    if let Some(path) = &run.json {
        let text = serde_json::to_string_pretty(&report).unwrap_or_default();
        std::fs::write(path, text).map_err(|e| VlfError::write(path, e))?;
    }
    Ok(report)
}

/// A failed run: print who was lost, rank 0 gathers what the others have and ends the job.
fn fail(
    link: &mut Link,
    run: &CaveRun,
    e: VlfError,
    cluster: &ClusterConfig,
    adapter: String,
) -> Result<()> {
    let host = link
        .watch
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .host
        .clone();
    let who = format!("vlf cluster rank {} ({host})", link.rank);
    let own = link.lost.is_empty();
    if own {
        eprintln!("{who}: failed: {e}");
    }
    for l in &link.lost {
        eprintln!("{who}: lost rank {}: {}", l.rank, l.reason);
    }
    let _ = std::io::stderr().flush();
    let mine = link.rank_report(Vec::new(), own.then(|| e.to_string()));
    link.watch.lock().unwrap_or_else(|e| e.into_inner()).ending = true;
    if link.leader() {
        if own {
            link.lost.push(LostRank {
                rank: 0,
                reason: format!("failed: {e}"),
            });
        }
        let lost = serde_json::to_vec(&link.lost).unwrap_or_default();
        for r in link.alive_followers() {
            link.send(r, LOST, lost.clone(), link.timeout);
        }
        let _ = gather(link, mine, cluster, adapter, run);
        abort(link, 1);
    }
    if link.leader_gone {
        std::process::exit(1);
    }
    if own {
        link.send(0, FAIL, e.to_string().into_bytes(), link.timeout);
    }
    link.send(
        0,
        REPORT,
        serde_json::to_vec(&mine).unwrap_or_default(),
        link.timeout,
    );
    link.recv(&[DONE], Some(0), link.leader_wait());
    std::process::exit(1);
}

fn abort(link: &Link, code: i32) -> ! {
    let _ = std::io::stdout().flush();
    let _ = std::io::stderr().flush();
    link.world.abort(code)
}

/// SIGTERM blocked in this thread and every thread started after it (MPI's, wgpu's): the
/// watcher takes it with sigwait.
fn block_sigterm() -> libc::sigset_t {
    // SAFETY: plain signal-mask calls on a local set
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, libc::SIGTERM);
        libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
        set
    }
}

/// Waits for SIGTERM (mpirun ending the job): prints which rank was lost, rank 0 its partial
/// report, and exits.
fn spawn_watcher(set: libc::sigset_t, watch: Arc<Mutex<Watch>>) {
    std::thread::spawn(move || {
        let mut signal = 0;
        // SAFETY: waits on the set blocked in every thread
        unsafe { libc::sigwait(&set, &mut signal) };
        let w = watch.lock().unwrap_or_else(|e| e.into_inner());
        if w.ending {
            // SAFETY: ends the process at once; what happened is printed already
            unsafe { libc::_exit(1) };
        }
        let gone: Vec<u32> = (w.peers.iter().enumerate())
            .filter(|(r, (host, pid))| *r as u32 != w.rank && *host == w.host && !alive(*pid))
            .map(|(r, _)| r as u32)
            .collect();
        let lost: Vec<LostRank> = if !gone.is_empty() {
            gone.iter()
                .map(|&rank| LostRank {
                    rank,
                    reason: format!("its process (pid {}) is gone", w.peers[rank as usize].1),
                })
                .collect()
        } else if !w.waiting.is_empty() {
            w.waiting
                .iter()
                .map(|&rank| LostRank {
                    rank,
                    reason: format!("had not reached the swap barrier of frame {}", w.frame),
                })
                .collect()
        } else {
            Vec::new()
        };
        let names: Vec<String> = lost
            .iter()
            .map(|l| format!("rank {} ({})", l.rank, l.reason))
            .collect();
        eprintln!(
            "vlf cluster rank {} ({}): mpirun is ending the job at frame {}: {}",
            w.rank,
            w.host,
            w.frame,
            if names.is_empty() {
                "no rank seen lost from here (interrupted, or a rank on another host ended: mpirun names it)".to_string()
            } else {
                format!("lost {}", names.join(", "))
            }
        );
        if w.rank == 0 {
            let mut report = ClusterReport {
                display: w.display.clone(),
                adapter: w.adapter.clone(),
                mode: "ended by mpirun: rank 0's part only".into(),
                ranks: w.size,
                timeout_s: w.timeout_s,
                same_frames_and_poses: false,
                check: String::new(),
                lost,
                per_rank: vec![RankReport {
                    rank: 0,
                    host: w.host.clone(),
                    pid: std::process::id(),
                    cpu_frame_ms: Stats::of(&w.cpu_ms),
                    swap_wait_ms: Stats::of(&w.swap_ms),
                    frame_ms: Stats::of(&w.frame_ms),
                    shown: w.shown.clone(),
                    gpu: w.gpu.clone(),
                    ..Default::default()
                }],
            };
            report.check_frames();
            print!("{}", report.table());
            if let Some(path) = &w.json {
                let _ = std::fs::write(
                    path,
                    serde_json::to_string_pretty(&report).unwrap_or_default(),
                );
            }
        }
        let _ = std::io::stdout().flush();
        let _ = std::io::stderr().flush();
        // SAFETY: ends the process at once, without running MPI's exit handlers
        unsafe { libc::_exit(1) };
    });
}

/// Whether process `pid` on this host is still running (not gone, not a zombie).
fn alive(pid: u32) -> bool {
    // SAFETY: signal 0 only checks that the process exists
    if unsafe { libc::kill(pid as i32, 0) } != 0 {
        return false;
    }
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    let state = stat
        .rsplit(')')
        .next()
        .unwrap_or("")
        .trim_start()
        .chars()
        .next();
    state != Some('Z')
}
