//! Display configurations and off-axis projection: shipped configs parse, the frustum is
//! symmetric on a wall's axis, points on a wall land on the expected pixel, lines stay
//! continuous across a seam, bad configs name the key, a headless CAVE run writes its views, and
//! with live tracking reports the latency from a pose's arrival to its frame.

use crate::common;
use common::*;
use glam::Vec3;
use std::path::Path;
use vlf::display::projection::{off_axis, project_to_pixel};
use vlf::display::DisplayConfig;
use vlf::progress::Silent;

fn config(rel: &str) -> std::path::PathBuf {
    repo_path("config/displays").join(rel)
}

#[test]
fn every_shipped_display_config_parses() {
    let mut n = 0;
    for entry in std::fs::read_dir(repo_path("config/displays")).unwrap() {
        DisplayConfig::load(&entry.unwrap().path()).unwrap_or_else(|e| panic!("{e}"));
        n += 1;
    }
    assert!(n >= 3);
    let cave = DisplayConfig::load(&config("cave-4wall.toml")).unwrap();
    assert_eq!(
        cave.walls
            .iter()
            .map(|w| w.name.as_str())
            .collect::<Vec<_>>(),
        ["front", "left", "right", "floor"]
    );
    assert_eq!(cave.walls.iter().map(|w| w.eyes().len()).sum::<usize>(), 8);
}

#[test]
fn a_viewer_on_the_axis_gets_a_symmetric_frustum() {
    let (ll, lr, ul) = (
        Vec3::new(-1.5, 0.0, -1.5),
        Vec3::new(1.5, 0.0, -1.5),
        Vec3::new(-1.5, 3.0, -1.5),
    );
    let p = off_axis(ll, lr, ul, Vec3::new(0.0, 1.5, 0.7), 0.1, 100.0);
    assert!(
        (p.left + p.right).abs() < 1e-6 && (p.bottom + p.top).abs() < 1e-6,
        "{p:?}"
    );
    let q = off_axis(ll, lr, ul, Vec3::new(0.5, 1.0, 0.0), 0.1, 100.0);
    assert!(
        (q.left + q.right).abs() > 0.01,
        "off axis must be asymmetric: {q:?}"
    );
}

#[test]
fn a_point_on_the_wall_projects_to_its_pixel() {
    let (ll, lr, ul) = (
        Vec3::new(-1.5, 0.0, -1.5),
        Vec3::new(1.5, 0.0, -1.5),
        Vec3::new(-1.5, 3.0, -1.5),
    );
    let pixels = [1920, 1200];
    for eye in [
        Vec3::new(0.0, 1.7, 0.0),
        Vec3::new(0.9, 1.2, 0.8),
        Vec3::new(-1.2, 0.4, -1.0),
    ] {
        let p = off_axis(ll, lr, ul, eye, 0.05, 100.0);
        for (u, v) in [(0.25f32, 0.5f32), (0.9, 0.1), (0.5, 0.95)] {
            let point = ll + (lr - ll) * u + (ul - ll) * v;
            let (x, y) = project_to_pixel(p.view_proj, point, pixels).unwrap();
            let (ex, ey) = (u * pixels[0] as f32, (1.0 - v) * pixels[1] as f32);
            assert!(
                (x - ex).abs() < 0.05 && (y - ey).abs() < 0.05,
                "eye {eye}: ({x}, {y}) vs ({ex}, {ey})"
            );
        }
    }
}

#[test]
fn a_line_across_two_walls_is_continuous_at_the_seam() {
    let cave = DisplayConfig::load(&config("cave-4wall.toml")).unwrap();
    let (front, left) = (&cave.walls[0], &cave.walls[1]);
    let eye = Vec3::new(0.3, 1.6, 0.2);
    let pf = off_axis(
        Vec3::from(front.lower_left),
        Vec3::from(front.lower_right),
        Vec3::from(front.upper_left),
        eye,
        0.05,
        100.0,
    );
    let pl = off_axis(
        Vec3::from(left.lower_left),
        Vec3::from(left.lower_right),
        Vec3::from(left.upper_left),
        eye,
        0.05,
        100.0,
    );
    // a straight vertical line along the seam: both walls put it at their shared edge, at
    // the same heights (within 1 pixel)
    for h in [0.3f32, 1.5, 2.7] {
        let seam = Vec3::new(-1.5, h, -1.5);
        let (xf, yf) = project_to_pixel(pf.view_proj, seam, front.pixels).unwrap();
        let (xl, yl) = project_to_pixel(pl.view_proj, seam, left.pixels).unwrap();
        assert!(
            xf.abs() < 0.5 && (xl - left.pixels[0] as f32).abs() < 0.5,
            "seam at x {xf} and {xl}"
        );
        assert!((yf - yl).abs() <= 1.0, "seam height {yf} vs {yl} px");
    }
}

fn bad(text_change: (&str, &str)) -> String {
    let text = std::fs::read_to_string(config("cave-4wall.toml"))
        .unwrap()
        .replacen(text_change.0, text_change.1, 1);
    DisplayConfig::parse(&text, Path::new("cave.toml"))
        .unwrap_err()
        .to_string()
}

#[test]
fn invalid_configs_name_the_key() {
    let e = bad((
        "upper_left = [-1.5, 3.0, -1.5]",
        "upper_left = [-1.0, 3.0, -1.5]",
    ));
    assert!(
        e.contains("cave.toml") && e.contains("wall[0]") && e.contains("right angle"),
        "{e}"
    );
    let e = bad((
        "lower_right = [1.5, 0.0, -1.5]",
        "lower_right = [-1.5, 0.0, -1.5]",
    ));
    assert!(e.contains("wall[0]") && e.contains("zero size"), "{e}");
    let e = bad(("name = \"left\"", "name = \"front\""));
    assert!(
        e.contains("wall[1]") && e.contains("duplicate wall name"),
        "{e}"
    );
    let e = bad(("eye_separation = 0.064", "eye_seperation = 0.064"));
    assert!(e.contains("eye_seperation"), "{e}");
    let cave = DisplayConfig::load(&config("cave-4wall.toml")).unwrap();
    let e = cave
        .check_outputs(&["DP-1".into(), "DP-2".into()])
        .unwrap_err();
    assert!(
        e.contains("wall[2]") && e.contains("output.monitor") && e.contains("DP-1"),
        "{e}"
    );
}

#[test]
fn headless_cave_renders_every_wall_and_eye() {
    let dir = tempfile::tempdir().unwrap();
    // the shipped CAVE at small pixels
    let text = std::fs::read_to_string(config("cave-4wall.toml"))
        .unwrap()
        .replace("pixels = [1920, 1200]", "pixels = [96, 60]");
    let path = dir.path().join("cave.toml");
    std::fs::write(&path, text).unwrap();
    let display = DisplayConfig::load(&path).unwrap();
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let params = common::draft_params();
    let (lf, resident, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    let out = dir.path().join("out");
    let report =
        vlf::display::headless::run(&lf, &resident, &display, &path, 3, &out, true).unwrap();
    assert_eq!(report.views_per_frame, 8);
    for wall in ["front", "left", "right", "floor"] {
        for eye in ["left", "right"] {
            assert!(
                out.join(format!("{wall}-{eye}.png")).exists()
                    && out.join(format!("{wall}-{eye}.exr")).exists()
            );
        }
    }
    let front = vlf::render::image_io::read_exr(&out.join("front-left.exr")).unwrap();
    assert_eq!((front.width, front.height), (96, 60));
    assert!(
        front.pixels.iter().map(|p| p[1]).sum::<f32>() > 1.0,
        "the front wall shows the box"
    );
    assert!(out.join("overview.png").exists());
    assert!(
        report.tracking_latency_ms.is_none(),
        "a static head has no tracking latency"
    );
}

/// Headless with live OSC tracking streaming head poses: the report (and its JSON) gives the
/// latency from a pose's arrival to the submission of the frame drawn from it.
#[test]
fn headless_cave_reports_the_live_tracking_latency() {
    let dir = tempfile::tempdir().unwrap();
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let text = format!(
        r#"name = "live"
[tracking]
source = "osc"
port = {port}
[[wall]]
name = "front"
lower_left = [-1.1, 0.0, 1.1]
lower_right = [1.1, 0.0, 1.1]
upper_left = [-1.1, 2.2, 1.1]
pixels = [64, 64]
output = {{ monitor = 0 }}
"#
    );
    let path = dir.path().join("live.toml");
    std::fs::write(&path, text).unwrap();
    let display = DisplayConfig::load(&path).unwrap();
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let params = common::draft_params();
    let (lf, resident, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    // the tracker streams head poses all through the run
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let stop_sender = stop.clone();
    let sender = std::thread::spawn(move || {
        let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        let packet = rosc::encoder::encode(&rosc::OscPacket::Message(rosc::OscMessage {
            addr: "/vlf/head".into(),
            args: [0.0f32, 1.0, 3.0]
                .into_iter()
                .map(rosc::OscType::Float)
                .collect(),
        }))
        .unwrap();
        while !stop_sender.load(std::sync::atomic::Ordering::Relaxed) {
            let _ = socket.send_to(&packet, ("127.0.0.1", port));
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    });
    let out = dir.path().join("out");
    let report = vlf::display::headless::run(&lf, &resident, &display, &path, 40, &out, false);
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    sender.join().unwrap();
    let report = report.unwrap();
    let latency = report
        .tracking_latency_ms
        .as_ref()
        .expect("a live source's latency in the report");
    println!("{}", report.table());
    assert!(
        latency.samples >= 5 && latency.median > 0.0 && latency.p99 < 1000.0,
        "{latency:?}"
    );
    assert!(report
        .table()
        .contains("tracking latency (pose received -> frame submitted)"));
    let json = serde_json::to_value(&report).unwrap();
    assert!(json["tracking_latency_ms"]["median"].as_f64().unwrap() > 0.0);
}

#[test]
fn live_osc_tracking_takes_the_latest_pose_and_holds_it_when_quiet() {
    use vlf::tracking::osc::{OscTracker, TrackingStatus, QUIET_AFTER};
    use vlf::tracking::source::Pose;
    let start = Pose::new(Vec3::new(0.0, 1.7, 0.0), Vec3::ZERO, 0.0);
    let mut tracker = OscTracker::listen("127.0.0.1:0", start).unwrap();
    assert_eq!(tracker.latest(), (start, TrackingStatus::Waiting));
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let send = |addr: &str, args: Vec<f32>| {
        let packet = rosc::OscPacket::Message(rosc::OscMessage {
            addr: addr.into(),
            args: args.into_iter().map(rosc::OscType::Float).collect(),
        });
        socket
            .send_to(
                &rosc::encoder::encode(&packet).unwrap(),
                ("127.0.0.1", tracker.port),
            )
            .unwrap();
    };
    for i in 0..5 {
        send("/vlf/head", vec![0.1 * i as f32, 1.6, 0.2]);
    }
    send("/vlf/room", vec![1.0, 0.0, 2.0, 30.0]);
    socket
        .send_to(b"not osc at all", ("127.0.0.1", tracker.port))
        .unwrap();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
    let pose = loop {
        let (p, status) = tracker.latest();
        if p.room_yaw_deg == 30.0 {
            assert_eq!(status, TrackingStatus::Live);
            break p;
        }
        assert!(std::time::Instant::now() < deadline, "no pose arrived");
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    // the latest of the five head poses won
    assert!(
        (pose.head - Vec3::new(0.4, 1.6, 0.2)).length() < 1e-6,
        "{pose:?}"
    );
    assert_eq!(pose.room_position, Vec3::new(1.0, 0.0, 2.0));
    std::thread::sleep(QUIET_AFTER + std::time::Duration::from_millis(100));
    let (held, status) = tracker.latest();
    assert_eq!(held, pose, "a quiet source keeps the last pose");
    assert!(matches!(status, TrackingStatus::Quiet(_)), "{status:?}");
}

/// `fit_frame_time`: the views probed from the configured antialiasing down until they fit
/// the refresh period with headroom; a period nothing fits gets the cheapest rung, and says so.
#[test]
fn fitting_the_frame_time_steps_down_until_the_views_fit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = vlf::scene::Scene::load(&repo_path("scenes/cornell/scene.toml")).unwrap();
    let params = common::draft_params();
    let (lf, resident, _) = vlf::propagate::propagate(gpu(), &scene, &params, &Silent).unwrap();
    let run = |hz: &str| {
        let text = std::fs::read_to_string(config("cave-4wall.toml"))
            .unwrap()
            .replace("pixels = [1920, 1200]", "pixels = [96, 60]")
            .replace(
                "refresh_hz = 120",
                &format!("refresh_hz = {hz}\nfit_frame_time = true"),
            );
        let path = dir.path().join(format!("cave-{hz}.toml"));
        std::fs::write(&path, text).unwrap();
        let display = DisplayConfig::load(&path).unwrap();
        let out = dir.path().join(format!("out-{hz}"));
        vlf::display::headless::run(&lf, &resident, &display, &path, 4, &out, false).unwrap()
    };
    // a second per frame: 1 eye ray per pixel fits, 4 are probed for the pacer, which then
    // gives the views more eye rays as their time stays under the target
    let slow = run("1");
    let fit = slow.fit.as_ref().expect("fitted");
    let tried: Vec<u32> = fit.probes.iter().map(|p| p.eye_rays_per_pixel).collect();
    assert!(fit.fits && tried == [1, 4], "{}", fit.summary());
    assert_eq!(
        (
            slow.quality.eye_rays_per_pixel,
            slow.quality.paced_eye_rays_per_pixel
        ),
        (1, 16)
    );
    assert!(
        slow.table().contains("frame time fit: budget 1000.00 ms"),
        "{}",
        slow.table()
    );
    let pacer = slow.pacer.as_ref().expect("paced");
    assert!(
        pacer.eye_rays_per_pixel.iter().all(|d| d.max > 1.0),
        "{}",
        pacer.line()
    );
    assert!(
        slow.table()
            .contains("frame pacing: views held at 750.00 ms"),
        "{}",
        slow.table()
    );
    // a million frames a second: not even 1 eye ray fits (Cornell has no mirror to drop)
    let fast = run("1000000");
    let fit = fast.fit.as_ref().expect("fitted");
    assert_eq!(fit.probes.len(), 1);
    assert!(!fit.fits && fast.pacer.is_none());
    assert_eq!(fast.quality.paced_eye_rays_per_pixel, 1);
    assert!(fast.table().contains("NOTHING FITS"), "{}", fast.table());
    assert!(fit.probes.iter().all(|p| p.frame_gpu_ms > 0.0));
    // a fit needs a refresh rate
    let e = bad(("refresh_hz = 120", "fit_frame_time = true"));
    assert!(
        e.contains("fit_frame_time") && e.contains("refresh_hz"),
        "{e}"
    );
}
