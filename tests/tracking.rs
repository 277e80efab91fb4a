//! Tracking: the head in 6 degrees of freedom (the stereo disparity of points behind and on
//! the CAVE's walls matches the geometry, computed here independently by intersecting each
//! eye's line of sight with the wall; orientations from static, scripted and OSC sources), the
//! room-from-tracker calibration, the live sources (DTrack2 ASCII and OSC on loopback UDP, VRPN
//! over loopback TCP; latest wins, quiet holds), the left hand from each of them and from static
//! and scripted heads (onto the avatar's left hand and a left-hand prop), `vlf track`, and wand
//! navigation.

use crate::common;
use common::*;
use glam::{Quat, Vec3};
use std::path::Path;
use vlf::display::projection::project_to_pixel;
use vlf::display::{wall_view, DisplayConfig, Wall};
use vlf::prepare::Normalisation;
use vlf::tracking::source::{head_rotation_from_angles, Pose, PoseSource};

/// Two unit quaternions are the same rotation (to float precision).
fn same(a: Quat, b: Quat) -> bool {
    a.dot(b).abs() > 1.0 - 1e-6
}

fn cave() -> DisplayConfig {
    DisplayConfig::load(&repo_path("config/displays/cave-4wall.toml")).unwrap()
}

/// Where the line from `eye` to `point` (room metres) crosses the wall's plane, in pixels from
/// the top-left of the wall's image: the geometry, without the renderer's matrices.
fn expected_pixel(wall: &Wall, eye: Vec3, point: Vec3) -> (f32, f32) {
    let [ll, lr, ul] = wall.corners();
    let n = (lr - ll).cross(ul - ll).normalize();
    let t = (ll - eye).dot(n) / (point - eye).dot(n);
    let hit = eye + (point - eye) * t;
    let u = (hit - ll).dot(lr - ll) / (lr - ll).length_squared();
    let v = (hit - ll).dot(ul - ll) / (ul - ll).length_squared();
    let [w, h] = wall.eye_pixels();
    (u * w as f32, (1.0 - v) * h as f32)
}

/// The wall's normal pointing into the room (towards the CAVE's centre).
fn inward_normal(wall: &Wall) -> Vec3 {
    let [ll, lr, ul] = wall.corners();
    let n = (lr - ll).cross(ul - ll).normalize();
    let centre = ll + (lr - ll) * 0.5 + (ul - ll) * 0.5;
    if (Vec3::new(0.0, 1.5, 0.0) - centre).dot(n) > 0.0 {
        n
    } else {
        -n
    }
}

/// Left- and right-eye pixels of a room point on a wall, through `wall_view` and the
/// renderer's projection (in the light field's normalised space).
fn rendered_pixels(
    config: &DisplayConfig,
    wall: &Wall,
    pose: &Pose,
    norm: &Normalisation,
    point: Vec3,
) -> [(f32, f32); 2] {
    [-1.0, 1.0].map(|side| {
        let (view_proj, _) = wall_view(config, wall, side, pose, norm);
        let p = norm.to_unit(pose.room_to_world(point).into()).as_vec3();
        project_to_pixel(view_proj, p, wall.eye_pixels()).expect("the point is in front of the eye")
    })
}

struct Case {
    name: &'static str,
    yaw: f32,
    pitch: f32,
}

const CASES: [Case; 4] = [
    Case {
        name: "yaw 0",
        yaw: 0.0,
        pitch: 0.0,
    },
    Case {
        name: "yaw +90",
        yaw: 90.0,
        pitch: 0.0,
    },
    Case {
        name: "yaw -90",
        yaw: -90.0,
        pitch: 0.0,
    },
    Case {
        name: "pitch -60 (the floor)",
        yaw: 0.0,
        pitch: -60.0,
    },
];

#[test]
fn stereo_disparity_follows_the_head_orientation() {
    let mut config = cave();
    // the tracked target sits above and behind the eyes
    config.eye_offset = [0.0, -0.05, 0.07];
    let ipd = config.eye_separation;
    // the room placed somewhere in the scene, which is normalised: neither may change pixels
    let norm = Normalisation {
        center: [0.3, 1.1, -0.4],
        scale: 0.37,
    };
    let mut front_disparity = std::collections::HashMap::new();
    for case in &CASES {
        let rotation = head_rotation_from_angles(case.yaw, case.pitch, 0.0);
        let pose = Pose {
            head: Vec3::new(0.2, 1.55, 0.1),
            head_rotation: rotation,
            room_position: Vec3::new(0.5, 0.0, 2.2),
            room_yaw_deg: 20.0,
        };
        // the eyes as the geometry puts them: +-IPD/2 along the head's right axis
        let centre = pose.head + rotation * Vec3::from(config.eye_offset);
        let right_axis = rotation * Vec3::X;
        let eyes = [
            centre - right_axis * ipd * 0.5,
            centre + right_axis * ipd * 0.5,
        ];
        for wall in &config.walls {
            let [ll, lr, ul] = wall.corners();
            let on_wall = ll + (lr - ll) * 0.4 + (ul - ll) * 0.55;
            let n = inward_normal(wall);
            let behind = on_wall - n;
            let [left, right] = rendered_pixels(&config, wall, &pose, &norm, behind);
            let expected = eyes.map(|e| expected_pixel(wall, e, behind));
            for (got, want, eye) in [(left, expected[0], "left"), (right, expected[1], "right")] {
                assert!(
                    (got.0 - want.0).abs() < 0.5 && (got.1 - want.1).abs() < 0.5,
                    "{}, wall {}, {eye} eye: rendered at {got:?}, the geometry says {want:?}",
                    case.name,
                    wall.name
                );
            }
            let disparity = (right.0 - left.0, right.1 - left.1);
            let want = (expected[1].0 - expected[0].0, expected[1].1 - expected[0].1);
            assert!(
                (disparity.0 - want.0).abs() < 0.5 && (disparity.1 - want.1).abs() < 0.5,
                "{}, wall {}: disparity {disparity:?} px, the geometry says {want:?}",
                case.name,
                wall.name
            );
            // direction and sign: where the eyes' baseline lies along the wall, a point behind
            // the wall is seen uncrossed, displaced along the baseline's projection on the wall
            let (vr, vu) = ((lr - ll).normalize(), (ul - ll).normalize());
            let along = Vec3::new(right_axis.dot(vr), right_axis.dot(vu), 0.0);
            let [w, h] = wall.eye_pixels();
            let metres = Vec3::new(
                disparity.0 * (lr - ll).length() / w as f32,
                -disparity.1 * (ul - ll).length() / h as f32,
                0.0,
            );
            if along.length() > 0.5 {
                let cos = metres.normalize().dot(along.normalize());
                assert!(
                    cos > 0.99,
                    "{}, wall {}: disparity {metres} m points away from the head's right axis on the wall {along} (cos {cos})",
                    case.name,
                    wall.name
                );
                // size: the baseline times the point's depth behind the wall over its depth from
                // the eyes (1 m behind the wall), within the eyes' depth difference
                let depth = (centre - on_wall).dot(n) + 1.0;
                let size = ipd * along.length() / depth;
                assert!(
                    (metres.length() - size).abs() < 0.1 * size,
                    "{}, wall {}: disparity {} m, expected about {size} m",
                    case.name,
                    wall.name,
                    metres.length()
                );
            }
            println!(
                "{:<22} {:<6} disparity rendered ({:7.3}, {:7.3}) px, geometry ({:7.3}, {:7.3}) px",
                case.name, wall.name, disparity.0, disparity.1, want.0, want.1
            );
            if wall.name == "front" {
                front_disparity.insert(case.name, metres.length());
            }
            // a point on the wall is where it is drawn, for both eyes: no disparity
            let [l, r] = rendered_pixels(&config, wall, &pose, &norm, on_wall);
            assert!(
                (r.0 - l.0).abs() < 0.5 && (r.1 - l.1).abs() < 0.5,
                "{}, wall {}: a point on the wall has disparity ({}, {}) px",
                case.name,
                wall.name,
                r.0 - l.0,
                r.1 - l.1
            );
        }
    }
    // turned to face a side wall, the eyes' baseline points at the front wall: almost no
    // horizontal disparity there (eyes on the room's x axis gave the full one)
    for turned in ["yaw +90", "yaw -90"] {
        assert!(
            front_disparity[turned] < 0.25 * front_disparity["yaw 0"],
            "{turned}: front-wall disparity {} m vs {} m facing it",
            front_disparity[turned],
            front_disparity["yaw 0"]
        );
    }
}

#[test]
fn eyes_sit_on_the_head_axis_with_the_offset() {
    let pose = Pose {
        head: Vec3::new(0.0, 1.7, 0.0),
        head_rotation: head_rotation_from_angles(90.0, 0.0, 0.0),
        room_position: Vec3::ZERO,
        room_yaw_deg: 0.0,
    };
    // facing -x (turned left): the right eye is towards -z, the offset's -z (ahead) is -x
    let right = pose.eye(Vec3::new(0.0, -0.1, -0.08), 0.064, 1.0);
    assert!(
        (right - Vec3::new(-0.08, 1.6, -0.032)).length() < 1e-5,
        "{right}"
    );
    // looking down 60 degrees: "ahead" points mostly at the floor, "right" stays +x
    let down = Pose {
        head_rotation: head_rotation_from_angles(0.0, -60.0, 0.0),
        ..pose
    };
    let ahead = down.eye(Vec3::new(0.0, 0.0, -1.0), 0.0, 0.0) - down.head;
    assert!(
        (ahead
            - Vec3::new(
                0.0,
                -(60f32.to_radians().sin()),
                -(60f32.to_radians().cos())
            ))
        .length()
            < 1e-5,
        "{ahead}"
    );
    assert!((down.right() - Vec3::X).length() < 1e-5);
    // roll: positive tilts the head to the left, the right eye goes up
    let tilted = Pose {
        head_rotation: head_rotation_from_angles(0.0, 0.0, 30.0),
        ..pose
    };
    assert!(tilted.eye(Vec3::ZERO, 0.064, 1.0).y > tilted.eye(Vec3::ZERO, 0.064, -1.0).y);
}

fn with_tracking(tracking: &str) -> Result<DisplayConfig, String> {
    let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall.toml")).unwrap();
    let text = text.replace(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]",
        tracking,
    );
    assert!(
        text.contains(tracking),
        "the shipped CAVE's [tracking] table changed"
    );
    DisplayConfig::parse(&text, Path::new("cave.toml")).map_err(|e| e.to_string())
}

#[test]
fn static_and_scripted_heads_take_an_orientation() {
    let config = with_tracking("[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\nhead_yaw_deg = 90.0\nhead_pitch_deg = -60.0").unwrap();
    let PoseSource::Static(pose) = config.pose_source(Path::new("cave.toml")).unwrap() else {
        panic!("static source")
    };
    assert!(
        same(
            pose.head_rotation,
            head_rotation_from_angles(90.0, -60.0, 0.0)
        ),
        "{:?}",
        pose.head_rotation
    );
    let q = Quat::from_rotation_y(0.5);
    let config = with_tracking(&format!(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\nhead_orientation = {:?}",
        (q * 2.0).to_array()
    ))
    .unwrap();
    let PoseSource::Static(pose) = config.pose_source(Path::new("cave.toml")).unwrap() else {
        panic!("static source")
    };
    assert!(same(pose.head_rotation, q) && (pose.head_rotation.length() - 1.0).abs() < 1e-5);
    // errors name the key
    let e = with_tracking("[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\nhead_orientation = [0.0, 0.0, 0.0, 0.0]").unwrap_err();
    assert!(e.contains("tracking.head_orientation"), "{e}");
    let e = with_tracking("[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\nhead_orientation = [0.0, 0.0, 0.0, 1.0]\nhead_yaw_deg = 3.0").unwrap_err();
    assert!(
        e.contains("tracking.head_orientation") && e.contains("not both"),
        "{e}"
    );
    let e =
        with_tracking("[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\nhead_yaw = 3.0")
            .unwrap_err();
    assert!(e.contains("head_yaw"), "{e}");
    let e =
        with_tracking("[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]").map(|mut c| {
            c.eye_offset = [0.0, 0.0, 0.9];
            c.validate().unwrap_err()
        });
    assert!(e.unwrap().contains("eye_offset"));

    // scripted: the shipped walk has no orientations (looks ahead); an oriented path slerps
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("path.toml");
    std::fs::write(
        &path,
        "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.6, 0.0]\nposition = [0.0, 0.0, 0.0]\n\n\
         [[keyframe]]\nt = 2.0\nhead = [0.0, 1.6, 0.0]\nhead_yaw_deg = 90.0\nposition = [0.0, 0.0, 0.0]\n\n\
         [[keyframe]]\nt = 3.0\nhead = [0.0, 1.6, 0.0]\nhead_orientation = [0.0, 0.0, 0.0, 1.0]\nposition = [0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    let p = vlf::tracking::source::ScriptedPath::load(&path).unwrap();
    assert!(same(
        p.at(1.0).head_rotation,
        head_rotation_from_angles(45.0, 0.0, 0.0)
    ));
    assert!(same(p.at(0.0).head_rotation, Quat::IDENTITY));
    assert!(same(
        p.at(2.5).head_rotation,
        head_rotation_from_angles(45.0, 0.0, 0.0)
    ));
    let walk =
        vlf::tracking::source::ScriptedPath::load(&repo_path("config/paths/cornell-walk.toml"))
            .unwrap();
    assert_eq!(walk.at(1.0).head_rotation, Quat::IDENTITY);
    std::fs::write(&path, "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.6, 0.0]\nhead_pitch_deg = inf\nposition = [0.0, 0.0, 0.0]\n").unwrap();
    let e = vlf::tracking::source::ScriptedPath::load(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("keyframe[0].head_pitch_deg"), "{e}");
}

#[test]
fn osc_head_takes_a_quaternion_and_keeps_the_three_number_form() {
    use vlf::tracking::osc::OscTracker;
    let mut tracker = OscTracker::listen(
        "127.0.0.1:0",
        Pose::new(Vec3::new(0.0, 1.7, 0.0), Vec3::ZERO, 0.0),
    )
    .unwrap();
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let port = tracker.port;
    let send = |args: Vec<f32>| {
        let packet = rosc::OscPacket::Message(rosc::OscMessage {
            addr: "/vlf/head".into(),
            args: args.into_iter().map(rosc::OscType::Float).collect(),
        });
        socket
            .send_to(
                &rosc::encoder::encode(&packet).unwrap(),
                ("127.0.0.1", port),
            )
            .unwrap();
    };
    let wait_for = |tracker: &mut OscTracker, done: &dyn Fn(&Pose) -> bool| {
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
        loop {
            let (p, _) = tracker.latest();
            if done(&p) {
                return p;
            }
            assert!(
                std::time::Instant::now() < deadline,
                "no pose arrived: {p:?}"
            );
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    };
    let q = Quat::from_rotation_y(1.0) * Quat::from_rotation_x(-0.3);
    send(vec![
        0.1,
        1.5,
        0.2,
        q.x * 3.0,
        q.y * 3.0,
        q.z * 3.0,
        q.w * 3.0,
    ]);
    let p = wait_for(&mut tracker, &|p| p.head.x == 0.1);
    assert!(same(p.head_rotation, q), "{p:?}");
    // three numbers move the head and keep its orientation
    send(vec![0.3, 1.4, 0.0]);
    let p = wait_for(&mut tracker, &|p| p.head.x == 0.3);
    assert!(
        same(p.head_rotation, q) && p.head == Vec3::new(0.3, 1.4, 0.0),
        "{p:?}"
    );
    // a zero quaternion is refused, the pose kept
    send(vec![0.5, 1.4, 0.0, 0.0, 0.0, 0.0, 0.0]);
    send(vec![0.6, 1.4, 0.0]);
    let p = wait_for(&mut tracker, &|p| p.head.x == 0.6);
    assert!(same(p.head_rotation, q), "{p:?}");
}

// ---- calibration: room from tracker ----

fn calibrated(source: &str, calibration: &str) -> Result<DisplayConfig, String> {
    with_tracking(&format!(
        "[tracking]\nsource = \"{source}\"\nport = 0\n\n[tracking.calibration]\n{calibration}"
    ))
}

#[test]
fn a_z_up_millimetre_tracker_maps_to_the_room() {
    let config = calibrated("osc", "translation = [0.5, 0.0, -0.2]\nyaw_deg = 90.0\nunit_scale = 0.001\naxes = \"z_up\"\nhead_id = 2\nwand_id = 3").unwrap();
    let source = config.tracking.live().unwrap();
    let c = source.calibration.unwrap();
    assert_eq!((source.protocol, c.head_id, c.wand_id), ("OSC", 2, 3));
    // 100 mm right, 2 m ahead, 1.7 m up in the tracker: (0.1, 1.7, -2.0) in y-up metres; the
    // tracker is turned 90 degrees left in the room, so ahead is -x: (-2.0, 1.7, -0.1); then
    // moved by the translation
    let p = c.position(Vec3::new(100.0, 2000.0, 1700.0));
    assert!((p - Vec3::new(-1.5, 1.7, -0.3)).length() < 1e-5, "{p}");
    // a body turned 30 degrees left about the tracker's up (z) axis and tilted 60 degrees down
    // is a head turned 90 + 30 degrees left and looking 60 degrees down in the room
    let body =
        Quat::from_rotation_z(30f32.to_radians()) * Quat::from_rotation_x(-60f32.to_radians());
    let head = c.orientation(body);
    assert!(
        same(head, head_rotation_from_angles(120.0, -60.0, 0.0)),
        "{head:?}"
    );
    // a body aligned with the tracker looks along the tracker's forward axis (+y, z up): the
    // calibration's rotation of the room's -z
    assert!(((c.orientation(Quat::IDENTITY) * Vec3::NEG_Z) - c.rotation * Vec3::Y).length() < 1e-5);

    // end to end: the same pose over OSC comes out in the room
    let PoseSource::Live(tracker) = config.pose_source(Path::new("cave.toml")).unwrap() else {
        panic!("a live source")
    };
    let mut tracker = tracker.into_inner().unwrap();
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let packet = rosc::OscPacket::Message(rosc::OscMessage {
        addr: "/vlf/head".into(),
        args: [100.0, 2000.0, 1700.0, body.x, body.y, body.z, body.w]
            .into_iter()
            .map(rosc::OscType::Float)
            .collect(),
    });
    socket
        .send_to(
            &rosc::encoder::encode(&packet).unwrap(),
            ("127.0.0.1", tracker.port),
        )
        .unwrap();
    let sample = tracker
        .next(std::time::Duration::from_secs(5))
        .expect("the pose arrived");
    assert!(
        (sample.state.pose.head - Vec3::new(-1.5, 1.7, -0.3)).length() < 1e-4,
        "{:?}",
        sample.state.pose
    );
    assert!(same(
        sample.state.pose.head_rotation,
        head_rotation_from_angles(120.0, -60.0, 0.0)
    ));
}

#[test]
fn calibration_errors_name_the_key() {
    let e = calibrated("osc", "unit_scael = 0.001").unwrap_err();
    assert!(e.contains("unit_scael") && e.contains("cave.toml"), "{e}");
    let e = calibrated("osc", "unit_scale = -1.0").unwrap_err();
    assert!(e.contains("tracking.calibration.unit_scale"), "{e}");
    let e = calibrated("osc", "axes = \"x_up\"").unwrap_err();
    assert!(e.contains("x_up") && e.contains("z_up"), "{e}");
    let e = calibrated("osc", "rotation = [0.0, 0.0, 0.0, 1.0]\nyaw_deg = 10.0").unwrap_err();
    assert!(
        e.contains("tracking.calibration.rotation") && e.contains("not both"),
        "{e}"
    );
    let e = calibrated("osc", "translation = [0.0, nan, 0.0]").unwrap_err();
    assert!(e.contains("tracking.calibration.translation"), "{e}");
    let e = calibrated("osc", "head_id = -1").unwrap_err();
    assert!(e.contains("head_id") || e.contains("-1"), "{e}");
    // the default is the identity: OSC poses are room metres
    let config = with_tracking("[tracking]\nsource = \"osc\"\nport = 0").unwrap();
    let c = config.tracking.live().unwrap().calibration.unwrap();
    assert_eq!(
        c.position(Vec3::new(0.1, 1.7, -0.2)),
        Vec3::new(0.1, 1.7, -0.2)
    );
}

// ---- live sources: DTrack2 ASCII and OSC, on loopback UDP ----

/// A rotation matrix as DTrack prints it: column by column.
fn dtrack_matrix(q: Quat) -> String {
    glam::Mat3::from_quat(q)
        .to_cols_array()
        .iter()
        .map(|v| format!("{v:.6}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn wait_state(
    tracker: &mut vlf::tracking::live::LiveTracker,
    what: &str,
    done: impl Fn(&vlf::tracking::live::LiveState) -> bool,
) -> vlf::tracking::live::LiveState {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
    loop {
        let (state, _) = tracker.latest_state();
        if done(&state) {
            return state;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "{what}: never arrived; last state {state:?}"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// The live tracker of a display configuration with a live source.
fn live_tracker(config: &DisplayConfig) -> vlf::tracking::live::LiveTracker {
    let PoseSource::Live(tracker) = config.pose_source(Path::new("cave.toml")).unwrap() else {
        panic!("a live source")
    };
    tracker.into_inner().unwrap()
}

/// Sends a text packet to a UDP port on this machine.
fn udp_sender(port: u16) -> impl Fn(&str) {
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    move |text: &str| {
        socket
            .send_to(text.as_bytes(), ("127.0.0.1", port))
            .unwrap();
    }
}

#[test]
fn dtrack_bodies_and_flysticks_reach_the_room() {
    use vlf::tracking::live::TrackingStatus;
    let config = calibrated("dtrack", "axes = \"z_up\"\nhead_id = 1\nwand_id = 1").unwrap();
    let mut tracker = live_tracker(&config);
    assert_eq!(tracker.latest_state().1, TrackingStatus::Waiting);
    let send = udp_sender(tracker.port);
    let head_body =
        Quat::from_rotation_z(30f32.to_radians()) * Quat::from_rotation_x(-60f32.to_radians());
    let wand_body = Quat::from_rotation_z(-45f32.to_radians());
    let identity = dtrack_matrix(Quat::IDENTITY);
    let frame = |head_x_mm: f32| {
        format!(
            "fr 1234\r\nts 39599.967\r\n6dcal 4\r\n\
             6d 2 [0 1.000][326.848 -187.216 109.503 -160.4704 -3.6963 -5.0913][{identity}] [1 0.950][{head_x_mm} 2000.0 1700.0 30.0 0.0 0.0][{}]\r\n\
             6df2 2 2 [0 1.000 6 2][0 0 0][{identity}][0 0.0 0.0] [1 0.900 6 2][200.0 1500.0 1200.0][{}][33 0.25 -1.0]\r\n\
             3d 1 [12 1.000][1 2 3]\r\n",
            dtrack_matrix(head_body),
            dtrack_matrix(wand_body)
        )
    };
    send(&frame(100.0));
    let state = wait_state(&mut tracker, "the first frame", |s| s.wand.is_some());
    // body 1 is the head: millimetres, z up -> room metres, y up
    assert!(
        (state.pose.head - Vec3::new(0.1, 1.7, -2.0)).length() < 1e-5,
        "{:?}",
        state.pose
    );
    assert!(
        same(
            state.pose.head_rotation,
            head_rotation_from_angles(30.0, -60.0, 0.0)
        ),
        "{:?}",
        state.pose.head_rotation
    );
    // Flystick 1 is the wand: turned 45 degrees right, it points along (+x, -z)
    let wand = state.wand.unwrap();
    assert!(
        (wand.position - Vec3::new(0.2, 1.2, -1.5)).length() < 1e-5,
        "{wand:?}"
    );
    assert!(
        (wand.rotation * Vec3::NEG_Z - Vec3::new(1.0, 0.0, -1.0).normalize()).length() < 1e-5,
        "{wand:?}"
    );
    // buttons 33 = trigger (0) and joystick press (5); joystick x, y
    assert_eq!(state.buttons, 0b10_0001);
    assert_eq!(state.joystick, [0.25, -1.0]);
    assert_eq!(tracker.status(), TrackingStatus::Live);

    // the latest of several frames wins
    for i in 0..5 {
        send(&frame(100.0 * i as f32));
    }
    wait_state(&mut tracker, "the fifth frame", |s| {
        (s.pose.head.x - 0.4).abs() < 1e-6
    });

    // a damaged frame and one whose head is not tracked leave the head where it is
    send("6d 1 [1 1.000][1 2 3][1 0 0]\r\n");
    send(&format!("fr 1\r\n6d 1 [1 -1.000][900 0 0][{identity}]\r\n"));
    // the older Flystick format: 8 button bits, the hat as joystick
    send(&format!(
        "fr 2\r\n6df 1 [1 1.000 33][0 0 0 0 0 0][{identity}]\r\n"
    ));
    // (the damaged and the untracked frame said nothing: the next state is the 6df one)
    let s = tracker
        .next(std::time::Duration::from_secs(5))
        .expect("the 6df frame");
    assert_eq!(
        (s.state.buttons, s.state.joystick),
        (1, [-1.0, 0.0]),
        "6df bits 0x21: button 0 and the hat to the left"
    );
    assert!(
        (s.state.pose.head.x - 0.4).abs() < 1e-6,
        "a damaged or untracked frame moved the head: {:?}",
        s.state.pose
    );

    // quiet: the last state is held, and the status says so
    std::thread::sleep(vlf::tracking::live::QUIET_AFTER + std::time::Duration::from_millis(100));
    let (held, status) = tracker.latest_state();
    assert_eq!(held, s.state);
    assert!(
        matches!(status, TrackingStatus::Quiet(d) if d > vlf::tracking::live::QUIET_AFTER),
        "{status:?}"
    );
}

#[test]
fn dtrack_parser_refuses_damaged_lines() {
    let ids = vlf::tracking::calibration::RoomFromTracker::default();
    let mut out = Vec::new();
    let identity = dtrack_matrix(Quat::IDENTITY);
    for bad in [
        "6d 2 [0 1.000][1 2 3][1 0 0 0 1 0 0 0 1]".to_string(),
        "6d 1 [0 1.000][1 2 3][1 0 0 0 1 0 0 0 1".to_string(),
        "6d x".to_string(),
        format!("6df2 1 1 [1 1.000 6 2][0 0 0][{identity}][1 0.5]"),
        format!("6d 1 [0 1.000][1 2 3][{identity}] junk"),
    ] {
        out.clear();
        let e = vlf::tracking::dtrack::parse(bad.as_bytes(), &ids, &mut out);
        assert!(e.is_err(), "{bad:?} was accepted: {out:?}");
    }
    out.clear();
    vlf::tracking::dtrack::parse(
        b"fr 5\r\n6dmt 0\r\nfuture 1 [2]\r\n6df2 1 0\r\n",
        &ids,
        &mut out,
    )
    .unwrap();
    assert!(out.is_empty(), "{out:?}");
}

#[test]
fn osc_wand_buttons_and_joystick() {
    use vlf::tracking::osc::OscTracker;
    let mut tracker = OscTracker::listen(
        "127.0.0.1:0",
        Pose::new(Vec3::new(0.0, 1.7, 0.0), Vec3::ZERO, 0.0),
    )
    .unwrap();
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let message = |addr: &str, args: Vec<rosc::OscType>| {
        rosc::OscPacket::Message(rosc::OscMessage {
            addr: addr.into(),
            args,
        })
    };
    let q = Quat::from_rotation_y(0.4);
    let bundle = rosc::OscPacket::Bundle(rosc::OscBundle {
        timetag: rosc::OscTime {
            seconds: 0,
            fractional: 1,
        },
        content: vec![
            message(
                "/vlf/wand",
                [0.3, 1.1, -0.4, q.x, q.y, q.z, q.w]
                    .into_iter()
                    .map(rosc::OscType::Float)
                    .collect(),
            ),
            message(
                "/vlf/button",
                vec![rosc::OscType::Int(3), rosc::OscType::Int(1)],
            ),
            message(
                "/vlf/joystick",
                vec![rosc::OscType::Float(0.2), rosc::OscType::Float(0.9)],
            ),
        ],
    });
    socket
        .send_to(
            &rosc::encoder::encode(&bundle).unwrap(),
            ("127.0.0.1", tracker.port),
        )
        .unwrap();
    let state = wait_state(&mut tracker, "the bundle", |s| s.wand.is_some());
    let wand = state.wand.unwrap();
    assert!(
        (wand.position - Vec3::new(0.3, 1.1, -0.4)).length() < 1e-6 && same(wand.rotation, q),
        "{wand:?}"
    );
    assert_eq!((state.buttons, state.joystick), (1 << 3, [0.2, 0.9]));
    let release = message(
        "/vlf/button",
        vec![rosc::OscType::Float(3.0), rosc::OscType::Bool(false)],
    );
    socket
        .send_to(
            &rosc::encoder::encode(&release).unwrap(),
            ("127.0.0.1", tracker.port),
        )
        .unwrap();
    wait_state(&mut tracker, "the release", |s| s.buttons == 0);
}

#[test]
fn vlf_track_prints_poses_and_buttons_as_they_arrive() {
    let dir = tempfile::tempdir().unwrap();
    // a free port for the tracker (taken back just before vlf listens on it)
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall-dtrack.toml"))
        .unwrap()
        .replace("port = 5000", &format!("port = {port}"))
        .replace("# left_hand_id = 2", "left_hand_id = 2");
    let path = dir.path().join("cave.toml");
    std::fs::write(&path, text).unwrap();
    let started = std::time::Instant::now();
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_vlf"))
        .args(["track", path.to_str().unwrap(), "--seconds", "2.5"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let identity = dtrack_matrix(Quat::IDENTITY);
    // stream for a second (the listener may start after the first packets), then go quiet
    while started.elapsed() < std::time::Duration::from_secs(1) {
        let packet = format!("fr 7\r\n6d 2 [0 1.000][100.0 2000.0 1700.0][{identity}] [2 1.000][-200.0 2000.0 1200.0][{identity}]\r\n6df2 1 1 [0 1.000 6 2][0 0 1000.0][{identity}][2 0.00 1.00]\r\n");
        socket
            .send_to(packet.as_bytes(), ("127.0.0.1", port))
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let output = child.wait_with_output().unwrap();
    let elapsed = started.elapsed();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "vlf track failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        elapsed < std::time::Duration::from_secs(10),
        "--seconds 2.5 ran {elapsed:?}"
    );
    assert!(stdout.contains("listening for DTrack on UDP"), "{stdout}");
    // millimetres, z up -> room metres, y up; the Flystick 1 m up with button 1 and the stick forward
    let poses = stdout
        .lines()
        .filter(|l| l.contains("head (  0.100,   1.700,  -2.000)"))
        .count();
    assert!(
        poses >= 5,
        "expected the streamed poses, one a line:\n{stdout}"
    );
    assert!(
        stdout.contains("wand (  0.000,   1.000,   0.000)")
            && stdout.contains("buttons [1]  joystick ( 0.00,  1.00)")
            && stdout.contains("left_hand ( -0.200,   1.200,  -2.000)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("quiet for"),
        "the source went quiet and vlf track did not say so:\n{stdout}"
    );
}

// ---- wand navigation ----

#[test]
fn the_wand_flies_where_it_points_and_turns_about_the_head() {
    use vlf::tracking::live::WandPose;
    use vlf::tracking::wand::{pressed, step};
    let nav = vlf::tracking::Navigation {
        walk_speed: 1.4,
        turn_speed_deg: 60.0,
        fly: false,
        wand_reset_button: 1,
    };
    let pose = Pose {
        head: Vec3::new(0.3, 1.6, 0.2),
        head_rotation: head_rotation_from_angles(10.0, 0.0, 0.0),
        room_position: Vec3::new(1.0, 0.0, 2.0),
        room_yaw_deg: 30.0,
    };
    // the wand points 45 degrees right of the room's -z and 20 degrees up
    let wand = WandPose {
        position: Vec3::new(0.2, 1.2, -0.3),
        rotation: head_rotation_from_angles(-45.0, 20.0, 0.0),
    };
    let pointing = Quat::from_rotation_y(30f32.to_radians()) * (wand.rotation * Vec3::NEG_Z);
    let dt = 0.5;

    // fly: full forward moves walk_speed * dt along the pointing direction, no turn
    let (position, yaw) = step(&pose, &wand, [0.0, 1.0], &nav, true, dt);
    assert!(
        (position - pose.room_position - pointing * 0.7).length() < 1e-5,
        "{position}"
    );
    assert_eq!(yaw, 30.0);
    assert!(position.y > 0.2, "flying up along the wand: {position}");
    // walk: the same distance, levelled: the head keeps its height; half back moves half back
    let (position, _) = step(&pose, &wand, [0.0, 1.0], &nav, false, dt);
    let moved = position - pose.room_position;
    assert!(
        moved.y.abs() < 1e-6 && (moved.length() - 0.7).abs() < 1e-5,
        "{moved}"
    );
    assert!(
        moved
            .normalize()
            .dot(Vec3::new(pointing.x, 0.0, pointing.z).normalize())
            > 1.0 - 1e-5
    );
    let (back, _) = step(&pose, &wand, [0.0, -0.5], &nav, false, dt);
    assert!(
        (back - pose.room_position + moved * 0.5).length() < 1e-5,
        "{back}"
    );
    // a wand pointing straight up does not walk
    let up = WandPose {
        rotation: head_rotation_from_angles(0.0, 90.0, 0.0),
        ..wand
    };
    assert!((step(&pose, &up, [0.0, 1.0], &nav, false, dt).0 - pose.room_position).length() < 1e-5);

    // sideways turns (right: yaw decreases) about the head: its place in the world stays
    let (position, yaw) = step(&pose, &wand, [0.5, 0.0], &nav, false, dt);
    assert!((yaw - (30.0 - 0.5 * 60.0 * dt)).abs() < 1e-5, "{yaw}");
    let turned = Pose {
        room_position: position,
        room_yaw_deg: yaw,
        ..pose
    };
    assert!((turned.room_to_world(pose.head) - pose.room_to_world(pose.head)).length() < 1e-5);
    assert!(
        (position - pose.room_position).length() > 0.01,
        "turning about the head (not the room's origin) moves the room"
    );
    // a resting stick (inside the dead zone) does nothing
    assert_eq!(
        step(&pose, &wand, [0.05, -0.08], &nav, true, dt),
        (pose.room_position, pose.room_yaw_deg)
    );

    // the reset button counts when it goes down, once
    assert!(pressed(0b01, 0b11, 1));
    assert!(!pressed(0b11, 0b11, 1) && !pressed(0b10, 0b00, 1) && !pressed(0, 0b01, 1));
    assert!(pressed(0, 1 << 63, 63) && !pressed(0, u64::MAX, 64));
}

// ---- VRPN over TCP ----

/// A VRPN message as a server writes it: header (length, time, sender, type, sequence), payload
/// padded to 8 bytes.
fn vrpn_message(sender: i32, kind: i32, payload: &[u8]) -> Vec<u8> {
    let mut m = Vec::new();
    for v in [
        24 + payload.len() as i32,
        1_700_000_000,
        250_000,
        sender,
        kind,
        0,
    ] {
        m.extend_from_slice(&v.to_be_bytes());
    }
    m.extend_from_slice(payload);
    m.resize(24 + payload.len().div_ceil(8) * 8, 0);
    m
}

fn vrpn_name(id: i32, kind: i32, name: &str) -> Vec<u8> {
    let mut p = ((name.len() + 1) as i32).to_be_bytes().to_vec();
    p.extend_from_slice(name.as_bytes());
    p.push(0);
    vrpn_message(id, kind, &p)
}

fn vrpn_pose(sender: i32, sensor: i32, position: [f64; 3], q: Quat) -> Vec<u8> {
    let mut p = sensor.to_be_bytes().to_vec();
    p.extend_from_slice(&sensor.to_be_bytes());
    for v in position
        .into_iter()
        .chain([q.x, q.y, q.z, q.w].map(f64::from))
    {
        p.extend_from_slice(&v.to_be_bytes());
    }
    vrpn_message(sender, 3, &p)
}

#[test]
fn vrpn_tracker_buttons_and_analogs_over_tcp() {
    let server = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    let config = with_tracking(&format!(
        "[tracking]\nsource = \"vrpn\"\nserver = \"127.0.0.1:{port}\"\ndevice = \"Wand\"\n\n[tracking.calibration]\nhead_id = 0\nwand_id = 1"
    ))
    .unwrap();
    let PoseSource::Live(tracker) = config.pose_source(Path::new("cave.toml")).unwrap() else {
        panic!("a live source")
    };
    let mut tracker = tracker.into_inner().unwrap();
    assert!(
        tracker.name.contains("VRPN Wand@127.0.0.1"),
        "{}",
        tracker.name
    );
    let (mut stream, _) = server.accept().unwrap();
    use std::io::{Read, Write};
    let mut cookie = b"vrpn: ver. 07.38  0".to_vec();
    cookie.resize(24, 0);
    stream.write_all(&cookie).unwrap();
    let mut reply = [0u8; 24];
    stream.read_exact(&mut reply).unwrap();
    assert_eq!(&reply[..19], b"vrpn: ver. 07.38  0", "the client's cookie");
    let head = Quat::from_rotation_y(30f32.to_radians());
    let mut stream_bytes = Vec::new();
    for m in [
        vrpn_name(0, -1, "Other"),
        vrpn_name(1, -1, "Wand"),
        vrpn_name(3, -2, "vrpn_Tracker Pos_Quat"),
        vrpn_name(5, -2, "vrpn_Button Change"),
        vrpn_name(7, -2, "vrpn_Analog Channel"),
        // another device's sensor 0 is not the head
        vrpn_pose(0, 0, [9.0, 9.0, 9.0], Quat::IDENTITY),
        vrpn_pose(1, 0, [0.1, 1.7, -2.0], head),
        vrpn_pose(1, 1, [0.2, 1.2, -0.5], Quat::IDENTITY),
        vrpn_message(1, 5, &[1i32.to_be_bytes(), 1i32.to_be_bytes()].concat()),
        vrpn_message(
            1,
            7,
            &[
                2f64.to_be_bytes(),
                0.25f64.to_be_bytes(),
                1f64.to_be_bytes(),
            ]
            .concat(),
        ),
    ] {
        stream_bytes.extend(m);
    }
    // in two pieces, split inside a message: the reader waits for the rest
    let (a, b) = stream_bytes.split_at(stream_bytes.len() - 30);
    stream.write_all(a).unwrap();
    stream.flush().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(150));
    stream.write_all(b).unwrap();
    let state = wait_state(&mut tracker, "the VRPN reports", |s| {
        s.joystick == [0.25, 1.0]
    });
    assert!(
        (state.pose.head - Vec3::new(0.1, 1.7, -2.0)).length() < 1e-6
            && same(state.pose.head_rotation, head),
        "{:?}",
        state.pose
    );
    assert_eq!(
        state.wand.map(|w| w.position),
        Some(Vec3::new(0.2, 1.2, -0.5))
    );
    assert_eq!(state.buttons, 1 << 1);
    // a dropped connection is retried: the next server gets a new cookie exchange
    drop(stream);
    let (mut again, _) = server.accept().unwrap();
    again.write_all(&cookie).unwrap();
    again.read_exact(&mut reply).unwrap();
    assert_eq!(&reply[..14], b"vrpn: ver. 07.");
    let e =
        with_tracking("[tracking]\nsource = \"vrpn\"\nserver = \"host:port\"\ndevice = \"Wand\"")
            .unwrap_err();
    assert!(e.contains("tracking.server"), "{e}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 256, ..Default::default() })]

    /// A damaged DTrack frame or VRPN stream is refused or read, never a panic.
    #[test]
    fn damaged_tracker_input_never_panics(at in 0usize..400, byte in proptest::prelude::any::<u8>(), cut in 0usize..400) {
        let identity = dtrack_matrix(Quat::IDENTITY);
        let mut frame = format!("fr 9\r\n6d 1 [0 1.000][1 2 3 0 0 0][{identity}]\r\n6df2 1 1 [0 1.000 6 2][0 0 0][{identity}][33 0.5 -0.5]\r\n6df 1 [0 1.000 3][0 0 0][{identity}]\r\n").into_bytes();
        let at = at % frame.len();
        frame[at] = byte;
        frame.truncate(cut.max(1).min(frame.len()));
        let ids = vlf::tracking::calibration::RoomFromTracker { head_id: 0, wand_id: 0, ..Default::default() };
        let _ = vlf::tracking::dtrack::parse(&frame, &ids, &mut Vec::new());
        let mut stream = [vrpn_name(1, -1, "Wand"), vrpn_pose(1, 0, [0.1, 1.7, -2.0], Quat::IDENTITY)].concat();
        let at = at % stream.len();
        stream[at] = byte;
        stream.truncate(cut.max(1).min(stream.len()));
        if let Ok(Some(m)) = vlf::tracking::vrpn::message(&stream) {
            for kind in ["vrpn_Tracker Pos_Quat", "vrpn_Button Change", "vrpn_Button States", "vrpn_Analog Channel"] {
                let _ = vlf::tracking::vrpn::decode(kind, m.payload, &ids, &mut Vec::new());
            }
        }
    }
}

/// A CAVE on DTrack with a left hand (body 3) and the participant's body: the shipped mannequin
/// and a prop that follows the left hand, at `path` (the meshes by absolute path).
fn dtrack_cave_with_a_left_hand(calibration: &str) -> Result<DisplayConfig, String> {
    let objects = format!(
        "\n[[object]]\nname = \"body\"\nkind = \"avatar\"\nmesh = {:?}\n\n\
         [[object]]\nname = \"cup\"\nmesh = {:?}\nfollow = \"left_hand\"\nposition = [0.0, 0.05, 0.0]\n",
        repo_path("assets/avatar/mannequin.glb").display().to_string(),
        repo_path("assets/wand/ray.obj").display().to_string(),
    );
    let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall.toml")).unwrap();
    let tracking = format!(
        "[tracking]\nsource = \"dtrack\"\nport = 0\n\n[tracking.calibration]\n{calibration}\n"
    );
    let text = text.replace(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]",
        &tracking,
    ) + &objects;
    DisplayConfig::parse(&text, Path::new("cave.toml")).map_err(|e| e.to_string())
}

/// DTrack body 3 as the left hand (`left_hand_id = 3`, z up, millimetres): calibrated into the
/// room like the wand, held while out of view, and the avatar's left hand (posed on the CPU)
/// and a `follow = "left_hand"` prop land on it in the world within 1 mm, as do they from the
/// frame state a cluster's rank 0 broadcasts.
#[test]
fn a_dtrack_left_hand_moves_the_avatars_left_hand_and_its_props() {
    use vlf::dynamic::{rigid_placement, Objects, Tracked};
    use vlf::framelock::FrameState;
    use vlf::tracking::HeldPoses;
    let config =
        dtrack_cave_with_a_left_hand("axes = \"z_up\"\nhead_id = 1\nwand_id = 1\nleft_hand_id = 3")
            .unwrap();
    let path = Path::new("cave.toml");
    let mut tracker = live_tracker(&config);
    let send = udp_sender(tracker.port);
    // the head turned 20 degrees left, the left hand pitched 30 degrees up (in the tracker's
    // z-up frame: about its z and x axes)
    let head_body = Quat::from_rotation_z(20f32.to_radians());
    let hand_body = Quat::from_rotation_x(30f32.to_radians());
    let identity = dtrack_matrix(Quat::IDENTITY);
    let frame = |hand_quality: f32, hand_mm: [f32; 3]| {
        let [x, y, z] = hand_mm;
        format!(
            "fr 7\r\n6d 2 [1 1.000][100.0 2000.0 1700.0 0 0 0][{}] [3 {hand_quality}][{x} {y} {z} 0 0 0][{}]\r\n\
             6df2 1 1 [1 1.000 6 2][250.0 2200.0 1200.0][{identity}][0 0.0 0.0]\r\n",
            dtrack_matrix(head_body),
            dtrack_matrix(hand_body)
        )
    };
    send(&frame(1.0, [-150.0, 2250.0, 1300.0]));
    let state = wait_state(&mut tracker, "the left hand", |s| s.left_hand.is_some());
    let hand = state.left_hand.unwrap();
    // tracker (x, y, z) mm, z up -> room (x, z, -y) metres
    assert!(
        (hand.position - Vec3::new(-0.15, 1.3, -2.25)).length() < 1e-5,
        "{hand:?}"
    );
    assert!(
        same(hand.rotation, Quat::from_rotation_x(30f32.to_radians())),
        "{hand:?}"
    );
    assert!(state.wand.is_some(), "the Flystick is still the wand");

    // out of view (quality -1) elsewhere: the hand stays where it was last tracked
    send(&frame(-1.0, [900.0, 900.0, 900.0]));
    let s = tracker
        .next(std::time::Duration::from_secs(5))
        .expect("the frame without the hand");
    assert_eq!(s.state.left_hand, Some(hand));

    let objects = Objects::load(&config.objects, path).unwrap();
    let held = state.held();
    // the room navigated: the hand goes with it
    let pose = Pose {
        room_position: Vec3::new(0.5, 0.0, 2.2),
        room_yaw_deg: 35.0,
        ..state.pose
    };
    let in_world = pose.room_to_world(hand.position);
    // what a cluster's every rank draws from: rank 0's state, as bytes
    let shared: FrameState =
        bytemuck::pod_read_unaligned(bytemuck::bytes_of(&FrameState::new(3, &pose, held, 1.0)));
    for (what, tracked) in [
        ("rank 0", Tracked::from_pose(&pose, &held, 0.0)),
        (
            "the shared state",
            Tracked::from_pose(&shared.pose(), &shared.held(), 0.0),
        ),
    ] {
        let left = Vec3::from(tracked.left_hand.expect("a left hand").translation);
        assert!(left.distance(in_world) < 1e-5, "{what}: {left}");
        let [avatar_left, avatar_right] = objects.avatar_hands(&tracked).unwrap();
        assert!(
            avatar_left.distance(in_world) < 1e-3,
            "{what}: the avatar's left hand at {avatar_left}, the tracked one at {in_world}"
        );
        let wand = Vec3::from(tracked.wand.unwrap().translation);
        assert!(avatar_right.distance(wand) < 1e-3, "{what}: {avatar_right}");
        // the cup sits 5 cm along the hand's own up
        let cup = rigid_placement(&config.objects[1], None, &tracked).unwrap();
        let expect = tracked
            .left_hand
            .unwrap()
            .transform_point3(Vec3::new(0.0, 0.05, 0.0));
        assert!(
            Vec3::from(cup.translation).distance(expect) < 1e-5,
            "{what}: {cup:?}"
        );
    }
    // without a left hand the arm hangs and the cup waits at the head
    let no_hand = Tracked::from_pose(
        &pose,
        &HeldPoses {
            left_hand: None,
            ..held
        },
        0.0,
    );
    let [hanging, _] = objects.avatar_hands(&no_hand).unwrap();
    assert!(hanging.distance(in_world) > 0.1, "{hanging}");
    let cup = rigid_placement(&config.objects[1], None, &no_hand).unwrap();
    let at_head = no_hand.head.transform_point3(Vec3::new(0.0, 0.05, 0.0));
    assert!(Vec3::from(cup.translation).distance(at_head) < 1e-5);
}

#[test]
fn left_hand_ids_and_names_are_checked_at_load() {
    // the head's body cannot be the left hand too
    let e = dtrack_cave_with_a_left_hand("head_id = 2\nleft_hand_id = 2").unwrap_err();
    assert!(
        e.contains("tracking.calibration.left_hand_id") && e.contains("head_id"),
        "{e}"
    );
    // a VRPN sensor is one thing: the wand's (1 by default) is not the left hand
    let e = with_tracking(
        "[tracking]\nsource = \"vrpn\"\nserver = \"localhost\"\ndevice = \"DTrack\"\n\n[tracking.calibration]\nleft_hand_id = 1",
    )
    .unwrap_err();
    assert!(
        e.contains("tracking.calibration.left_hand_id") && e.contains("wand_id"),
        "{e}"
    );
    // a DTrack Flystick is numbered apart from the bodies: body 1 may be the left hand
    dtrack_cave_with_a_left_hand("head_id = 0\nwand_id = 1\nleft_hand_id = 1").unwrap();
    // an object following a target nobody tracks: the key, and the targets there are
    let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall.toml")).unwrap()
        + "\n[[object]]\nname = \"prop\"\nmesh = \"prop.obj\"\nfollow = \"right_foot\"\n";
    let e = DisplayConfig::parse(&text, Path::new("cave.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("follow") && e.contains("right_foot") && e.contains("`left_hand`"),
        "{e}"
    );
    // a static left hand: the keys the wand has, checked alike
    let e = with_tracking(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\nleft_hand_yaw_deg = 10.0",
    )
    .unwrap_err();
    assert!(e.contains("tracking.left_hand_position"), "{e}");
    let config = with_tracking(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\nleft_hand_position = [-0.2, 1.0, 0.0]\nleft_hand_pitch_deg = 90.0",
    )
    .unwrap();
    let hand = config.tracking.static_left_hand().unwrap().unwrap();
    assert!((hand.rotation * Vec3::NEG_Z - Vec3::Y).length() < 1e-6);
    let held = config
        .pose_source(Path::new("cave.toml"))
        .unwrap()
        .held_at(&config.tracking, 0.0);
    assert_eq!((held.wand, held.left_hand), (None, Some(hand)));
}

/// The left hand over OSC (`/vlf/left_hand`), VRPN (sensor `left_hand_id`) and a scripted path
/// (keyframes' `left_hand_position`, interpolated like the wand's).
#[test]
fn osc_vrpn_and_scripted_paths_give_the_left_hand() {
    use vlf::tracking::calibration::RoomFromTracker;
    use vlf::tracking::live::Measurement;
    let q = Quat::from_rotation_y(0.3);
    let message = rosc::OscPacket::Message(rosc::OscMessage {
        addr: "/vlf/left_hand".into(),
        args: [-0.3, 1.1, -0.4, q.x, q.y, q.z, q.w]
            .into_iter()
            .map(rosc::OscType::Float)
            .collect(),
    });
    let mut out = Vec::new();
    let ids = RoomFromTracker::default();
    vlf::tracking::osc::parse(&rosc::encoder::encode(&message).unwrap(), &ids, &mut out).unwrap();
    assert_eq!(
        out,
        [Measurement::LeftHand {
            position: Vec3::new(-0.3, 1.1, -0.4),
            rotation: q
        }]
    );
    // VRPN: sensor 2 only once it is configured as the left hand
    let payload = &vrpn_pose(1, 2, [-0.3, 1.1, -0.4], q)[24..];
    out.clear();
    vlf::tracking::vrpn::decode("vrpn_Tracker Pos_Quat", payload, &ids, &mut out).unwrap();
    assert!(out.is_empty(), "{out:?}");
    let ids = RoomFromTracker {
        left_hand_id: Some(2),
        ..ids
    };
    vlf::tracking::vrpn::decode("vrpn_Tracker Pos_Quat", payload, &ids, &mut out).unwrap();
    assert!(
        matches!(out[..], [Measurement::LeftHand { position, rotation }]
            if (position - Vec3::new(-0.3, 1.1, -0.4)).length() < 1e-6 && same(rotation, q)),
        "{out:?}"
    );
    // a scripted path: the left hand moves between keyframes that give it
    let dir = tempfile::tempdir().unwrap();
    let walk = dir.path().join("walk.toml");
    std::fs::write(
        &walk,
        "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\nleft_hand_position = [-0.2, 1.0, 0.0]\n\n\
         [[keyframe]]\nt = 2.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\nleft_hand_position = [-0.2, 1.4, 0.0]\nleft_hand_yaw_deg = 90.0\n",
    )
    .unwrap();
    let path = vlf::tracking::source::ScriptedPath::load(&walk).unwrap();
    let half = path.left_hand_at(1.0).unwrap();
    assert!((half.position - Vec3::new(-0.2, 1.2, 0.0)).length() < 1e-6);
    assert!(same(
        half.rotation,
        Quat::from_rotation_y(45f32.to_radians())
    ));
    assert_eq!(path.wand_at(1.0), None);
    std::fs::write(
        &walk,
        "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\nleft_hand_orientation = [0.0, 0.0, 0.0, 1.0]\n",
    )
    .unwrap();
    let e = vlf::tracking::source::ScriptedPath::load(&walk)
        .unwrap_err()
        .to_string();
    assert!(e.contains("keyframe[0].left_hand_position"), "{e}");
}

// ---- tracked targets ([[tracking.target]]) ----

/// A CAVE on DTrack (z up, millimetres) declaring `targets` (TOML of `[[tracking.target]]`
/// tables) and a stool that follows the target "chair", 5 cm in front of it and turned 90
/// degrees.
fn dtrack_cave_with_targets(calibration: &str, targets: &str) -> Result<DisplayConfig, String> {
    let objects = format!(
        "\n[[object]]\nname = \"stool\"\nmesh = {:?}\nfollow = \"target\"\ntarget = \"chair\"\nposition = [0.0, 0.0, -0.05]\nyaw_deg = 90.0\n",
        repo_path("assets/props/stool.obj").display().to_string(),
    );
    let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall.toml")).unwrap();
    let tracking = format!(
        "[tracking]\nsource = \"dtrack\"\nport = 0\n\n[tracking.calibration]\n{calibration}\n\n{targets}\n"
    );
    let text = text.replace(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]",
        &tracking,
    ) + &objects;
    DisplayConfig::parse(&text, Path::new("cave.toml")).map_err(|e| e.to_string())
}

/// DTrack body 7 declared as the target "chair": calibrated into the room like the left hand,
/// the stool that follows it hidden until it is first seen, then placed on it in the world
/// within 1 mm (directly and from the frame state a cluster's rank 0 broadcasts), and held where
/// it was last seen while out of view.
#[test]
fn a_dtrack_target_moves_the_objects_that_follow_it() {
    use vlf::dynamic::{Objects, Tracked};
    use vlf::framelock::FrameState;
    let config = dtrack_cave_with_targets(
        "axes = \"z_up\"\nhead_id = 1\nwand_id = 1\nleft_hand_id = 3",
        "[[tracking.target]]\nname = \"box\"\nid = 4\n\n[[tracking.target]]\nname = \"chair\"\nid = 7",
    )
    .unwrap();
    assert_eq!(config.tracking.target_names(), ["box", "chair"]);
    let path = Path::new("cave.toml");
    let objects =
        Objects::load_tracked(&config.objects, &config.tracking.target_names(), path).unwrap();
    let mut tracker = live_tracker(&config);
    let send = udp_sender(tracker.port);
    // the chair turned 30 degrees about the tracker's up (z)
    let chair_body = Quat::from_rotation_z(30f32.to_radians());
    let identity = dtrack_matrix(Quat::IDENTITY);
    let frame = |chair_quality: f32, chair_mm: [f32; 3]| {
        let [x, y, z] = chair_mm;
        format!(
            "fr 9\r\n6d 2 [1 1.000][100.0 2000.0 1700.0 0 0 0][{identity}] [7 {chair_quality}][{x} {y} {z} 0 0 0][{}]\r\n",
            dtrack_matrix(chair_body)
        )
    };
    // the head alone: the chair is not seen yet, and its stool is not drawn (zero matrix)
    send(&format!(
        "fr 8\r\n6d 1 [1 1.000][100.0 2000.0 1700.0 0 0 0][{identity}]\r\n"
    ));
    let state = wait_state(&mut tracker, "the head", |s| {
        s.pose.head != Vec3::new(0.0, 1.7, 0.0)
    });
    assert_eq!(state.targets, [None; vlf::tracking::MAX_TARGETS]);
    let unseen = Tracked::from_pose(&state.pose, &state.held(), 0.0);
    assert_eq!(objects.joint_matrices(&unseen)[0], glam::Mat4::ZERO);

    send(&frame(1.0, [400.0, 1500.0, 0.0]));
    let state = wait_state(&mut tracker, "the chair", |s| s.targets[1].is_some());
    let chair = state.targets[1].unwrap();
    assert_eq!(state.targets[0], None, "body 4 was never sent");
    // tracker (x, y, z) mm, z up -> room (x, z, -y) metres; a turn about the tracker's z is one
    // about the room's y
    assert!(
        (chair.position - Vec3::new(0.4, 0.0, -1.5)).length() < 1e-5,
        "{chair:?}"
    );
    assert!(
        same(chair.rotation, Quat::from_rotation_y(30f32.to_radians())),
        "{chair:?}"
    );
    let raw = state.raw.targets[1].unwrap();
    assert!((raw.position - Vec3::new(400.0, 1500.0, 0.0)).length() < 1e-3);
    assert_eq!(state.left_hand, None, "body 7 is not the left hand");

    // out of view (quality -1) elsewhere: the chair stays where it was last tracked
    send(&frame(-1.0, [900.0, 900.0, 900.0]));
    let s = tracker
        .next(std::time::Duration::from_secs(5))
        .expect("the frame without the chair");
    assert_eq!(s.state.targets[1], Some(chair));

    // the room navigated: the chair goes with it
    let pose = Pose {
        room_position: Vec3::new(0.5, 0.0, 2.2),
        room_yaw_deg: 35.0,
        ..state.pose
    };
    let held = state.held();
    let room_turn = Quat::from_rotation_y(35f32.to_radians());
    let chair_in_world = glam::Affine3A::from_rotation_translation(
        room_turn * chair.rotation,
        pose.room_to_world(chair.position),
    );
    // the stool: 5 cm ahead of the chair's body, turned 90 degrees about its up
    let expect = chair_in_world
        * glam::Affine3A::from_rotation_translation(
            Quat::from_rotation_y(90f32.to_radians()),
            Vec3::new(0.0, 0.0, -0.05),
        );
    let shared: FrameState =
        bytemuck::pod_read_unaligned(bytemuck::bytes_of(&FrameState::new(3, &pose, held, 1.0)));
    assert_eq!(shared.held(), held);
    for (what, tracked) in [
        ("rank 0", Tracked::from_pose(&pose, &held, 0.0)),
        (
            "the shared state",
            Tracked::from_pose(&shared.pose(), &shared.held(), 0.0),
        ),
    ] {
        let stool = objects.joint_matrices(&tracked)[0];
        let (_, rotation, at) = stool.to_scale_rotation_translation();
        let want = Vec3::from(expect.translation);
        assert!(
            at.distance(want) < 1e-3,
            "{what}: the stool at {at}, expected {want}"
        );
        assert!(
            same(rotation, Quat::from_mat3a(&expect.matrix3)),
            "{what}: {rotation:?}"
        );
        // the hidden seat's corner too: within 1 mm where the target's frame says
        let corner = Vec3::new(0.2, 0.47, 0.2);
        let drawn = stool.transform_point3(corner);
        assert!(
            drawn.distance(expect.transform_point3(corner)) < 1e-3,
            "{what}"
        );
    }
}

/// Targets' declarations are checked when the configuration loads, each error naming its key:
/// an id that is the head's or the left hand's, two targets of one name or one body, an object
/// naming a target not declared, `target` without `follow = "target"`, more than 8 targets.
#[test]
fn target_declarations_are_checked_at_load_naming_the_key() {
    let chair = "[[tracking.target]]\nname = \"chair\"\nid = 7";
    dtrack_cave_with_targets("head_id = 1", chair).unwrap();
    let e = dtrack_cave_with_targets("head_id = 7", chair).unwrap_err();
    assert!(
        e.contains("cave.toml")
            && e.contains("tracking.target[0] (\"chair\").id")
            && e.contains("head_id"),
        "{e}"
    );
    let e = dtrack_cave_with_targets("head_id = 1\nleft_hand_id = 7", chair).unwrap_err();
    assert!(
        e.contains("tracking.target[0] (\"chair\").id") && e.contains("left_hand_id"),
        "{e}"
    );
    // a DTrack Flystick is numbered apart from the bodies: body 0 may be a target
    dtrack_cave_with_targets(
        "head_id = 1\nwand_id = 0",
        "[[tracking.target]]\nname = \"chair\"\nid = 0",
    )
    .unwrap();
    let e = dtrack_cave_with_targets(
        "head_id = 1",
        &format!("{chair}\n[[tracking.target]]\nname = \"chair\"\nid = 8"),
    )
    .unwrap_err();
    assert!(e.contains("tracking.target[1] (\"chair\").name"), "{e}");
    let e = dtrack_cave_with_targets(
        "head_id = 1",
        &format!("{chair}\n[[tracking.target]]\nname = \"table\"\nid = 7"),
    )
    .unwrap_err();
    assert!(e.contains("tracking.target[1] (\"table\").id"), "{e}");
    // the stool follows "chair", which is not declared
    let e = dtrack_cave_with_targets(
        "head_id = 1",
        "[[tracking.target]]\nname = \"table\"\nid = 7",
    )
    .unwrap_err();
    assert!(
        e.contains("[[object]] \"stool\"")
            && e.contains("target = \"chair\"")
            && e.contains("table"),
        "{e}"
    );
    let e = dtrack_cave_with_targets("head_id = 1", "").unwrap_err();
    assert!(
        e.contains("target = \"chair\"") && e.contains("declares none"),
        "{e}"
    );
    let e = dtrack_cave_with_targets("head_id = 1", "[[tracking.target]]\nname = \"chair\"")
        .unwrap_err();
    assert!(
        e.contains("tracking.target[0] (\"chair\").id") && e.contains("6d body"),
        "{e}"
    );
    let many: String = (0..9)
        .map(|k| {
            format!(
                "[[tracking.target]]\nname = \"chair{}\"\nid = {}\n",
                if k == 0 { String::new() } else { k.to_string() },
                10 + k
            )
        })
        .collect();
    let e = dtrack_cave_with_targets("head_id = 1", &many).unwrap_err();
    assert!(
        e.contains("tracking.target:") && e.contains("at most 8"),
        "{e}"
    );
    // an unknown key of a target is named
    let e = dtrack_cave_with_targets("head_id = 1", &format!("{chair}\nbody = 3")).unwrap_err();
    assert!(e.contains("body"), "{e}");
    // follow = "target" without a target, and a target on another follow
    let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall.toml")).unwrap();
    for (object, key) in [
        ("follow = \"target\"", "target = \"<name>\""),
        (
            "follow = \"wand\"\ntarget = \"chair\"",
            "target = \"chair\"",
        ),
    ] {
        let text = format!("{text}\n[[object]]\nname = \"prop\"\nmesh = \"prop.obj\"\n{object}\n");
        let e = DisplayConfig::parse(&text, Path::new("cave.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("[[object]] \"prop\"") && e.contains(key), "{e}");
    }
    // the headset and stills track no targets: such an object is refused, saying so
    let objects: Vec<vlf::dynamic::ObjectConfig> = vec![toml::from_str(
        "name = \"stool\"\nmesh = \"stool.obj\"\nfollow = \"target\"\ntarget = \"chair\"",
    )
    .unwrap()];
    let e = vlf::dynamic::Objects::load(&objects, Path::new("body.toml"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("body.toml") && e.contains("\"stool\"") && e.contains("headset"),
        "{e}"
    );
}

/// Targets over OSC (`/vlf/target/<name>`), VRPN (a declared sensor; the wand's is refused), a
/// static source (a target's `position`) and a scripted path (`[[keyframe.target]]`,
/// interpolated like the left hand).
#[test]
fn osc_vrpn_static_and_scripted_sources_give_targets() {
    use vlf::tracking::calibration::{RoomFromTracker, TargetId};
    use vlf::tracking::live::Measurement;
    let q = Quat::from_rotation_y(0.3);
    let ids = RoomFromTracker {
        targets: vec![
            TargetId {
                name: "box".into(),
                id: Some(4),
            },
            TargetId {
                name: "chair".into(),
                id: Some(7),
            },
        ],
        ..RoomFromTracker::default()
    };
    let osc = |addr: &str| {
        let message = rosc::OscPacket::Message(rosc::OscMessage {
            addr: addr.into(),
            args: [0.4, 0.5, -1.5, q.x, q.y, q.z, q.w]
                .into_iter()
                .map(rosc::OscType::Float)
                .collect(),
        });
        let mut out = Vec::new();
        vlf::tracking::osc::parse(&rosc::encoder::encode(&message).unwrap(), &ids, &mut out)
            .unwrap();
        out
    };
    assert_eq!(
        osc("/vlf/target/chair"),
        [Measurement::Target {
            index: 1,
            position: Vec3::new(0.4, 0.5, -1.5),
            rotation: q
        }]
    );
    assert!(
        osc("/vlf/target/table").is_empty(),
        "a target not declared is ignored"
    );
    // VRPN: sensor 7 is the chair
    let payload = &vrpn_pose(1, 7, [0.4, 0.5, -1.5], q)[24..];
    let mut out = Vec::new();
    vlf::tracking::vrpn::decode("vrpn_Tracker Pos_Quat", payload, &ids, &mut out).unwrap();
    assert!(
        matches!(out[..], [Measurement::Target { index: 1, position, rotation }]
            if (position - Vec3::new(0.4, 0.5, -1.5)).length() < 1e-6 && same(rotation, q)),
        "{out:?}"
    );
    // a measurement reaches the live state through the calibration, raw beside it
    let mut state = vlf::tracking::live::LiveState::new(Pose::new(Vec3::ZERO, Vec3::ZERO, 0.0));
    let shifted = RoomFromTracker {
        translation: Vec3::new(1.0, 0.0, 0.0),
        ..ids.clone()
    };
    state.apply(out[0], &shifted);
    let calibrated = state.targets[1].unwrap().position;
    assert!(
        calibrated.distance(Vec3::new(1.4, 0.5, -1.5)) < 1e-6,
        "{calibrated}"
    );
    assert_eq!(
        state.raw.targets[1].unwrap().position,
        Vec3::new(0.4, 0.5, -1.5)
    );
    // a VRPN sensor is one thing: the wand's (1 by default) is not a target
    let with_tracking = |tracking: &str| {
        let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall.toml"))
            .unwrap()
            .replace(
                "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]",
                tracking,
            );
        DisplayConfig::parse(&text, Path::new("cave.toml")).map_err(|e| e.to_string())
    };
    let e = with_tracking(
        "[tracking]\nsource = \"vrpn\"\nserver = \"localhost\"\ndevice = \"DTrack\"\n\n[[tracking.target]]\nname = \"chair\"\nid = 1",
    )
    .unwrap_err();
    assert!(
        e.contains("tracking.target[0] (\"chair\").id") && e.contains("wand_id"),
        "{e}"
    );
    // OSC names a target by its address: an id is refused
    let e = with_tracking(
        "[tracking]\nsource = \"osc\"\nport = 0\n\n[[tracking.target]]\nname = \"chair\"\nid = 7",
    )
    .unwrap_err();
    assert!(
        e.contains("(\"chair\").id") && e.contains("/vlf/target/chair"),
        "{e}"
    );
    // a static target: held at its position, the wand's keys
    let config = with_tracking(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\n\n[[tracking.target]]\nname = \"chair\"\nposition = [0.4, 0.0, -1.5]\nyaw_deg = 90.0\n\n[[tracking.target]]\nname = \"box\"",
    )
    .unwrap();
    let held = (config.pose_source(Path::new("cave.toml")).unwrap()).held_at(&config.tracking, 0.0);
    let chair = held.targets[0].unwrap();
    assert_eq!(chair.position, Vec3::new(0.4, 0.0, -1.5));
    assert!((chair.rotation * Vec3::NEG_Z - Vec3::NEG_X).length() < 1e-6);
    assert_eq!(
        held.targets[1], None,
        "a static target without a position is never seen"
    );
    let e = with_tracking(
        "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]\n\n[[tracking.target]]\nname = \"chair\"\nyaw_deg = 90.0",
    )
    .unwrap_err();
    assert!(e.contains("tracking.target[0] (\"chair\").position"), "{e}");
    // a scripted path: the chair moves between keyframes that give it
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("walk.toml"),
        "[[keyframe]]\nt = 0.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\n[[keyframe.target]]\nname = \"chair\"\nposition = [0.4, 0.0, -1.0]\n\n\
         [[keyframe]]\nt = 2.0\nhead = [0.0, 1.7, 0.0]\nposition = [0.0, 0.0, 0.0]\n[[keyframe.target]]\nname = \"chair\"\nposition = [0.4, 0.0, -2.0]\nyaw_deg = 90.0\n",
    )
    .unwrap();
    let display = dir.path().join("cave.toml");
    let scripted = |targets: &str| {
        let text = std::fs::read_to_string(repo_path("config/displays/cave-4wall.toml"))
            .unwrap()
            .replace(
                "[tracking]\nsource = \"static\"\nhead = [0.0, 1.2, 0.3]",
                &format!("[tracking]\nsource = \"scripted\"\npath = \"walk.toml\"\n\n{targets}"),
            );
        let config = DisplayConfig::parse(&text, &display).unwrap();
        config.pose_source(&display).map(|source| (config, source))
    };
    let (config, source) =
        scripted("[[tracking.target]]\nname = \"box\"\n\n[[tracking.target]]\nname = \"chair\"")
            .unwrap();
    let half = source.held_at(&config.tracking, 1.0).targets[1].unwrap();
    assert!(
        (half.position - Vec3::new(0.4, 0.0, -1.5)).length() < 1e-6,
        "{half:?}"
    );
    assert!(same(
        half.rotation,
        Quat::from_rotation_y(45f32.to_radians())
    ));
    assert_eq!(source.held_at(&config.tracking, 1.0).targets[0], None);
    let e = scripted("[[tracking.target]]\nname = \"box\"")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("walk.toml") && e.contains("keyframe[0].target[0].name") && e.contains("box"),
        "{e}"
    );
}
