//! The avatar's CPU side (src/dynamic/avatar/): the shipped mannequin and its generator, the
//! rig (body under the head, yaw following the head, two-bone IK arms), the CPU skinning twin
//! and the loader's errors on bad input. No GPU.

use glam::{Affine3A, Mat4, Quat, Vec3};
use std::path::{Path, PathBuf};
use vlf::dynamic::avatar::{Avatar, Role};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn mannequin() -> Avatar {
    Avatar::load(&repo("assets/avatar/mannequin.glb")).expect("the shipped mannequin loads")
}

fn joint(avatar: &Avatar, name: &str) -> usize {
    avatar
        .joint_names()
        .iter()
        .position(|n| n == name)
        .unwrap_or_else(|| panic!("no joint {name}"))
}

/// The vertices that `joint` moves most.
fn vertices_of(avatar: &Avatar, joint: usize) -> Vec<usize> {
    let m = &avatar.mesh;
    (0..m.positions.len())
        .filter(|&v| {
            let w = m.weights[v];
            let main = (0..4).fold(0, |b, k| if w[k] > w[b] { k } else { b });
            m.joints[v][main] as usize == joint
        })
        .collect()
}

/// Standing on the floor (y = 0) at `x`, looking along -z.
fn standing(avatar: &Avatar, x: f32) -> Affine3A {
    Affine3A::from_translation(Vec3::new(x, avatar.eye_height(), 0.0))
}

fn angle_deg(a: Vec3, b: Vec3) -> f32 {
    a.normalize()
        .dot(b.normalize())
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// The .glb with its JSON chunk edited.
fn edit_glb(bytes: &[u8], edit: impl Fn(String) -> String) -> Vec<u8> {
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = String::from_utf8(bytes[20..20 + json_len].to_vec()).unwrap();
    let mut new_json = edit(json).into_bytes();
    while !new_json.len().is_multiple_of(4) {
        new_json.push(b' ');
    }
    let bin = &bytes[20 + json_len..];
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((20 + new_json.len() + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(new_json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&new_json);
    out.extend_from_slice(bin);
    out
}

#[test]
fn the_shipped_mannequin_loads_with_one_skin_and_its_height() {
    let path = repo("assets/avatar/mannequin.glb");
    let gltf = gltf::Gltf::open(&path).unwrap();
    assert_eq!(gltf.document.skins().count(), 1);
    let avatar = mannequin();
    assert_eq!(avatar.joint_count(), 19);
    assert_eq!(gltf.document.skins().next().unwrap().joints().count(), 19);
    let h = avatar.height();
    assert!((1.70..=1.80).contains(&h), "height {h}");
    let m = &avatar.mesh;
    assert!(m.triangles.len() > 2000, "{} triangles", m.triangles.len());
    assert_eq!(m.materials.len(), 3);
    assert_eq!(m.triangle_material.len(), m.triangles.len());
    assert_eq!(m.normals.len(), m.positions.len());
    let eye = avatar.eye_height();
    assert!((1.55..1.70).contains(&eye), "eye height {eye}");
    for role in Role::ALL {
        assert!(avatar.joint(role).is_some(), "{role:?}");
    }
}

#[test]
fn make_avatar_regenerates_the_shipped_file_byte_identically() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mannequin.glb");
    let status = std::process::Command::new("python3")
        .arg(repo("tools/make-avatar.py"))
        .arg(&out)
        .status()
        .expect("python3 runs tools/make-avatar.py");
    assert!(status.success());
    let fresh = std::fs::read(&out).unwrap();
    let shipped = std::fs::read(repo("assets/avatar/mannequin.glb")).unwrap();
    assert!(
        fresh == shipped,
        "assets/avatar/mannequin.glb is not what tools/make-avatar.py writes: regenerate it"
    );
}

#[test]
fn at_rest_the_feet_are_on_the_floor_under_the_head_and_follow_it() {
    let avatar = mannequin();
    let rest = avatar.skin(&avatar.pose(standing(&avatar, 0.0), None, None));
    let feet: Vec<usize> = ["foot_l", "foot_r"]
        .iter()
        .flat_map(|f| vertices_of(&avatar, joint(&avatar, f)))
        .collect();
    let head = vertices_of(&avatar, joint(&avatar, "head"));
    assert!(!feet.is_empty() && !head.is_empty());
    let lowest = feet
        .iter()
        .map(|&v| rest[v].y)
        .fold(f32::INFINITY, f32::min);
    assert!(
        lowest.abs() < 0.01,
        "the feet's lowest point is at {lowest} m"
    );
    for &v in &feet {
        let p = rest[v];
        assert!(p.x.abs() < 0.3 && p.z.abs() < 0.3, "a foot vertex at {p}");
    }
    let top = head.iter().map(|&v| rest[v].y).fold(f32::MIN, f32::max);
    assert!((top - avatar.height()).abs() < 0.01, "top of head {top}");
    // the untracked arms hang
    let joints = avatar.joint_positions(&avatar.pose(standing(&avatar, 0.0), None, None));
    for side in ["l", "r"] {
        let shoulder = joints[joint(&avatar, &format!("upper_arm_{side}"))];
        let hand = joints[joint(&avatar, &format!("hand_{side}"))];
        assert!(
            hand.y < shoulder.y - 0.45,
            "{side}: hand {hand}, shoulder {shoulder}"
        );
    }
    // a metre to the right: everything moves a metre
    let moved = avatar.skin(&avatar.pose(standing(&avatar, 1.0), None, None));
    for v in feet.iter().chain(&head) {
        let d = moved[*v] - rest[*v];
        assert!((d - Vec3::X).length() < 1e-4, "vertex {v} moved {d}");
    }
}

#[test]
fn the_torso_turns_with_the_heads_yaw_but_not_its_pitch() {
    let avatar = mannequin();
    let chest = joint(&avatar, "chest");
    let hips = avatar.joint(Role::Hips).unwrap();
    let at = standing(&avatar, 0.0);
    let rest = avatar.pose(at, None, None);
    // the model faces +z; the tracked head looks along -z
    let forward = |m: &[Mat4], j: usize| m[j].transform_vector3(Vec3::Z);
    assert!(angle_deg(forward(&rest, hips), Vec3::NEG_Z) < 0.1);
    let yawed = avatar.pose(
        at * Affine3A::from_quat(Quat::from_rotation_y(90f32.to_radians())),
        None,
        None,
    );
    for j in [hips, chest] {
        let a = angle_deg(forward(&rest, j), forward(&yawed, j));
        assert!((a - 90.0).abs() < 0.1, "joint {j} turned {a} degrees");
        assert!(angle_deg(forward(&yawed, j), Vec3::NEG_X) < 0.1);
    }
    let pitch = Quat::from_rotation_x(30f32.to_radians());
    let pitched = avatar.pose(at * Affine3A::from_quat(pitch), None, None);
    for j in [hips, chest] {
        let up = pitched[j].transform_vector3(Vec3::Y);
        assert!(angle_deg(up, Vec3::Y) < 0.01, "joint {j}'s up is {up}");
        assert!(angle_deg(forward(&pitched, j), Vec3::NEG_Z) < 0.01);
    }
    // the head's vertices turn about the eyes' point by the pitch
    let (a, b) = (avatar.skin(&rest), avatar.skin(&pitched));
    let eye = Vec3::from(at.translation);
    let head_joint = joint(&avatar, "head");
    let head: Vec<usize> = vertices_of(&avatar, head_joint)
        .into_iter()
        .filter(|&v| avatar.mesh.weights[v][0] == 1.0)
        .collect();
    assert!(head.len() > 100);
    for &v in &head {
        let expected = eye + pitch * (a[v] - eye);
        assert!((b[v] - expected).length() < 1e-4, "head vertex {v}");
    }
    let moved = head
        .iter()
        .map(|&v| (b[v] - a[v]).length())
        .fold(0.0, f32::max);
    assert!(moved > 0.03, "the head barely moved ({moved} m)");
}

#[test]
fn the_arms_reach_a_reachable_hand_with_their_bone_lengths_kept() {
    let avatar = mannequin();
    let at = standing(&avatar, 0.3);
    let bind = avatar.joint_positions(&vec![Mat4::IDENTITY; avatar.joint_count()]);
    let rest = avatar.joint_positions(&avatar.pose(at, None, None));
    for (side, sign) in [("l", -1.0f32), ("r", 1.0)] {
        let [upper, fore, hand] =
            ["upper_arm", "forearm", "hand"].map(|n| joint(&avatar, &format!("{n}_{side}")));
        let shoulder = rest[upper];
        // the body faces -z: its left (+x in the model) is at -x in the world
        let target = shoulder + Vec3::new(0.15 * sign, -0.2, -0.3);
        let grip = Affine3A::from_rotation_translation(Quat::from_rotation_x(0.3), target);
        let (l, r) = if side == "l" {
            (Some(grip), None)
        } else {
            (None, Some(grip))
        };
        let posed = avatar.joint_positions(&avatar.pose(at, l, r));
        let miss = (posed[hand] - target).length();
        assert!(miss < 1e-3, "{side}: the hand misses by {miss} m");
        for (a, b) in [(upper, fore), (fore, hand)] {
            let (was, is) = ((bind[b] - bind[a]).length(), (posed[b] - posed[a]).length());
            assert!(
                (was - is).abs() < 1e-4,
                "{side}: a bone of {was} m is now {is} m"
            );
        }
        assert!(
            (posed[upper] - shoulder).length() < 1e-5,
            "the shoulder stays"
        );
        assert!(
            posed[fore].y < posed[upper].y,
            "{side}: the elbow is not below the shoulder"
        );
    }
}

#[test]
fn an_unreachable_hand_gets_a_straight_arm_pointing_at_it() {
    let avatar = mannequin();
    let at = standing(&avatar, 0.0);
    let rest = avatar.joint_positions(&avatar.pose(at, None, None));
    let [upper, fore, hand] = ["upper_arm_r", "forearm_r", "hand_r"].map(|n| joint(&avatar, n));
    let target = rest[upper] + 2.0 * Vec3::new(0.3, 0.4, -1.0).normalize();
    let posed =
        avatar.joint_positions(&avatar.pose(at, None, Some(Affine3A::from_translation(target))));
    let (s, e, w) = (posed[upper], posed[fore], posed[hand]);
    assert!(
        angle_deg(w - s, target - s) < 1.0,
        "the arm points {} degrees off",
        angle_deg(w - s, target - s)
    );
    assert!(
        angle_deg(e - s, w - e) < 1.0,
        "the arm is bent {} degrees",
        angle_deg(e - s, w - e)
    );
}

#[test]
fn the_hand_joint_turns_with_the_tracked_hand() {
    let avatar = mannequin();
    let at = standing(&avatar, 0.0);
    let hand = joint(&avatar, "hand_l");
    let target = Vec3::new(-0.25, 1.2, -0.35);
    let turn = Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.4);
    let a = Affine3A::from_translation(target);
    let b = Affine3A::from_rotation_translation(turn, target);
    let ja = avatar.pose_joints(at, Some(a), None)[hand];
    let jb = avatar.pose_joints(at, Some(b), None)[hand];
    let (ra, rb) = (
        ja.to_scale_rotation_translation().1,
        jb.to_scale_rotation_translation().1,
    );
    assert!((rb * ra.inverse()).angle_between(turn) < 1e-3);
    // an identity wand points along -z: so do the fingers (the forearm -> hand direction)
    let fingers = ja.matrix3 * Vec3::X; // the mannequin's left hand points along +x at bind
    assert!(
        angle_deg(fingers, Vec3::NEG_Z) < 0.5,
        "the hand points along {fingers}"
    );
}

#[test]
fn the_skinning_twin_keeps_the_bind_pose_for_identity_matrices() {
    let avatar = mannequin();
    for (v, w) in avatar.mesh.weights.iter().enumerate() {
        let sum: f32 = w.iter().sum();
        assert!(
            (sum - 1.0).abs() < 1e-6,
            "vertex {v}'s weights sum to {sum}"
        );
        assert!(w.iter().all(|&x| x >= 0.0));
    }
    let identity = vec![Mat4::IDENTITY; avatar.joint_count()];
    assert_eq!(avatar.skin(&identity), avatar.mesh.positions);
    let shifted = vec![Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)); avatar.joint_count()];
    for (p, q) in avatar.skin(&shifted).iter().zip(&avatar.mesh.positions) {
        assert!((*p - *q - Vec3::new(0.0, 0.0, 2.0)).length() < 1e-5);
    }
}

#[test]
fn mixamo_joint_names_pose_like_vlfs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mixamo.glb");
    let status = std::process::Command::new("python3")
        .arg(repo("tools/make-avatar.py"))
        .arg(&out)
        .args(["--names", "mixamo"])
        .status()
        .unwrap();
    assert!(status.success());
    let mixamo = Avatar::load(&out).unwrap();
    assert!(mixamo
        .joint_names()
        .iter()
        .any(|n| n == "mixamorig:LeftForeArm"));
    let ours = mannequin();
    let at = standing(&ours, 0.0) * Affine3A::from_quat(Quat::from_rotation_y(0.5));
    let hand = Some(Affine3A::from_translation(Vec3::new(0.2, 1.1, -0.4)));
    assert_eq!(mixamo.pose(at, hand, None), ours.pose(at, hand, None));
}

fn load_error(path: &Path) -> String {
    match Avatar::load(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_input_is_an_error_naming_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    // a glTF with a triangle and no skin
    let unskinned = dir.path().join("unskinned.gltf");
    let triangle: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let b64 = base64(&triangle);
    std::fs::write(
        &unskinned,
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}}],
            "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{b64}"}}]}}"#
        ),
    )
    .unwrap();
    let e = load_error(&unskinned);
    assert!(e.contains("unskinned.gltf") && e.contains("no skin"), "{e}");

    let junk = dir.path().join("junk.glb");
    std::fs::write(&junk, b"this is not a glTF file at all").unwrap();
    let e = load_error(&junk);
    assert!(e.contains("junk.glb") && e.contains("glTF"), "{e}");

    let missing = dir.path().join("missing.glb");
    let e = load_error(&missing);
    assert!(
        e.contains("missing.glb") && e.contains("cannot read"),
        "{e}"
    );

    let shipped = std::fs::read(repo("assets/avatar/mannequin.glb")).unwrap();
    type Edit = fn(String) -> String;
    let cases: [(&str, Edit, &[&str]); 3] = [
        (
            "noweights.glb",
            |j| j.replace(r#","WEIGHTS_0":3"#, ""),
            &["WEIGHTS_0"],
        ),
        (
            "nojoints.glb",
            |j| j.replace(r#","JOINTS_0":2"#, ""),
            &["JOINTS_0"],
        ),
        (
            "nohead.glb",
            |j| j.replace(r#""name":"head""#, r#""name":"noggin""#),
            &["head", "noggin"],
        ),
    ];
    for (name, edit, words) in cases {
        let path = dir.path().join(name);
        let edited = edit_glb(&shipped, edit);
        assert_ne!(edited, shipped, "{name}: the edit changed nothing");
        std::fs::write(&path, edited).unwrap();
        let e = load_error(&path);
        assert!(e.contains(name), "{e}");
        for w in words {
            assert!(e.contains(w), "{name}: {e}");
        }
    }
    // truncated: every prefix of the file is an error, never a panic
    for len in [0, 11, 20, 100, 1000, shipped.len() / 2, shipped.len() - 1] {
        let path = dir.path().join("truncated.glb");
        std::fs::write(&path, &shipped[..len]).unwrap();
        let e = load_error(&path);
        assert!(e.contains("truncated.glb"), "{e}");
    }
}

fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                out.push(ABC[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
