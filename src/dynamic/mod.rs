//! Dynamic objects: moving things drawn into the static light field, each frame where the
//! participant or the script puts them. A display config lists them (`[[object]]`, `config.rs`):
//! rigid meshes that follow the tracked head, wand, left hand or a declared tracked target
//! (`[[tracking.target]]`) or move by keyframes in the world
//! (`motion.rs`), and the participant's skinned avatar (`avatar/`). Here they become one mesh in
//! its rest pose (`mesh.rs`) and, frame by frame, the joint matrices that pose it; the renderer
//! skins, refits and shades them on the GPU (`render::moving`, `render::probes`). Nothing here
//! touches the GPU.

pub mod avatar;
pub mod config;
pub mod mesh;
pub mod motion;

pub use config::{check_objects, target_indices, Follow, ObjectConfig, ObjectKind};
pub use mesh::{MovingMaterial, MovingMesh, RestVertex, RigidMesh};

use crate::error::{Result, VlfError};
use crate::tracking::pose::head_rotation_from_angles;
use crate::tracking::{HeldPoses, Pose, WandPose, MAX_TARGETS};
use avatar::Avatar;
use glam::{Affine3A, Mat4, Quat, Vec3};
use std::path::Path;

/// Where the tracked things are in one frame, in the world (metres), and the time that moves
/// keyframed objects (seconds from the start of the run).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracked {
    pub time: f64,
    /// world from head: the point between the eyes' tracked frame (looks along -z)
    pub head: Affine3A,
    /// world from wand (points along -z), where one is tracked: the right hand (the headset's
    /// right controller's grip)
    pub wand: Option<Affine3A>,
    /// world from the left hand (the CAVE's tracked left hand, the headset's left controller's
    /// grip: -z along the hand, as the wand), where one is tracked
    pub left_hand: Option<Affine3A>,
    /// world from each declared target (`[[tracking.target]]`, by index), where one has been
    /// seen (the headset has none)
    pub targets: [Option<Affine3A>; MAX_TARGETS],
}

impl Tracked {
    /// The tracked head, wand, left hand and targets of `pose` and `held` (room) moved into the
    /// world by the pose's navigation.
    pub fn from_pose(pose: &Pose, held: &HeldPoses, time: f64) -> Tracked {
        let room = Quat::from_rotation_y(pose.room_yaw_deg.to_radians());
        let head = Affine3A::from_rotation_translation(
            room * pose.head_rotation,
            pose.room_to_world(pose.head),
        );
        let in_world = |h: &WandPose| {
            Affine3A::from_rotation_translation(room * h.rotation, pose.room_to_world(h.position))
        };
        Tracked {
            time,
            head,
            wand: held.wand.as_ref().map(in_world),
            left_hand: held.left_hand.as_ref().map(in_world),
            targets: held.targets.map(|t| t.as_ref().map(in_world)),
        }
    }

    /// A still: the head at `eye` looking at `target` (a camera's placement), no hand tracked,
    /// keyframes at time 0 (`vlf render --objects`, `vlf export mitsuba --objects`).
    pub fn looking(eye: Vec3, target: Vec3, up: Vec3) -> Tracked {
        let view = Affine3A::look_at_rh(eye, target, up);
        Tracked {
            time: 0.0,
            head: view.inverse(),
            wand: None,
            left_hand: None,
            targets: [None; MAX_TARGETS],
        }
    }
}

/// The loaded objects: their configs, one rest-pose mesh of them all, which are shown.
pub struct Objects {
    configs: Vec<ObjectConfig>,
    /// each object's first joint matrix in `joint_matrices`
    first_joint: Vec<u32>,
    /// each `follow = "target"` object's target index (`target_indices`)
    targets: Vec<Option<usize>>,
    visible: Vec<bool>,
    mesh: MovingMesh,
    /// the participant's body, where one is configured (one at most: `check_objects`)
    avatar: Option<Avatar>,
}

impl Objects {
    /// Load every object's mesh (paths relative to `config_path`'s folder) where nothing but the
    /// head and the hands is tracked (the headset, `vlf xr --objects`; a still, `vlf render
    /// --objects`): a `follow = "target"` object is refused, naming it. An error names the file,
    /// the object and the problem.
    pub fn load(configs: &[ObjectConfig], config_path: &Path) -> Result<Objects> {
        if let Some(o) = configs.iter().find(|o| o.follow == Follow::Target) {
            return Err(VlfError::Config {
                path: config_path.to_path_buf(),
                message: format!(
                    "[[object]] \"{}\": follow = \"target\": tracked targets ([[tracking.target]]) come from a CAVE's tracking system, declared in its display config; the headset and stills track only the head and the hands: follow \"head\", \"wand\" or \"left_hand\" here",
                    o.name
                ),
            });
        }
        Objects::load_tracked(configs, &[], config_path)
    }

    /// `load` for a display whose tracking declares `targets` (the `[[tracking.target]]` names,
    /// in order) that `follow = "target"` objects name.
    pub fn load_tracked(
        configs: &[ObjectConfig],
        targets: &[String],
        config_path: &Path,
    ) -> Result<Objects> {
        let config_error = |message: String| VlfError::Config {
            path: config_path.to_path_buf(),
            message,
        };
        check_objects(configs).map_err(config_error)?;
        let target_of = target_indices(configs, targets).map_err(config_error)?;
        let dir = config_path.parent().unwrap_or(Path::new("."));
        let mut mesh = MovingMesh::default();
        let mut first_joint = Vec::new();
        let mut avatar = None;
        for (i, o) in configs.iter().enumerate() {
            let path = dir.join(&o.mesh);
            let joint = mesh.joint_count;
            first_joint.push(joint);
            match o.kind {
                ObjectKind::Rigid => {
                    let part = RigidMesh::load(&path).map_err(|e| {
                        config_error(format!(
                            "[[object]] \"{}\": mesh {}: {e}",
                            o.name,
                            path.display()
                        ))
                    })?;
                    mesh.push_rigid(&part, i as u32, joint);
                }
                ObjectKind::Avatar => {
                    let body = Avatar::load(&path).map_err(|e| {
                        config_error(format!("[[object]] \"{}\": avatar: {e}", o.name))
                    })?;
                    push_skinned(
                        &mut mesh,
                        &body.mesh,
                        i as u32,
                        (joint, body.joint_count() as u32),
                    );
                    avatar = Some(body);
                }
            }
        }
        Ok(Objects {
            visible: configs.iter().map(|o| o.visible).collect(),
            configs: configs.to_vec(),
            first_joint,
            targets: target_of,
            mesh,
            avatar,
        })
    }

    pub fn mesh(&self) -> &MovingMesh {
        &self.mesh
    }

    pub fn configs(&self) -> &[ObjectConfig] {
        &self.configs
    }

    /// The avatar's left and right hand joints in the world as `tracked` poses them (its
    /// `scale` included), where an avatar is configured and shown.
    pub fn avatar_hands(&self, tracked: &Tracked) -> Option<[Vec3; 2]> {
        let body = self.avatar.as_ref()?;
        let i = (self.configs.iter()).position(|o| o.kind == ObjectKind::Avatar)?;
        if !self.visible[i] {
            return None;
        }
        let matrices = self.joint_matrices(tracked);
        let joints = body.joint_positions(&matrices[self.first_joint[i] as usize..]);
        let hand = |role| body.joint(role).map(|j| joints[j]);
        Some([
            hand(avatar::Role::HandLeft)?,
            hand(avatar::Role::HandRight)?,
        ])
    }

    /// Show or hide the object called `name`; an error lists the names there are.
    pub fn set_visible(&mut self, name: &str, visible: bool) -> std::result::Result<(), String> {
        match self.configs.iter().position(|o| o.name == name) {
            Some(i) => {
                self.visible[i] = visible;
                Ok(())
            }
            None => Err(format!(
                "no object called \"{name}\" (there are: {})",
                (self.configs.iter())
                    .map(|o| format!("\"{}\"", o.name))
                    .collect::<Vec<_>>()
                    .join(", ")
            )),
        }
    }

    /// Whether each object is shown, in config order.
    pub fn visible(&self) -> &[bool] {
        &self.visible
    }

    /// Every joint matrix for this frame (world metres from each object's rest pose); a hidden
    /// object's are zero, which the GPU reads as "not there".
    pub fn joint_matrices(&self, tracked: &Tracked) -> Vec<Mat4> {
        let mut matrices = vec![Mat4::ZERO; self.mesh.joint_count as usize];
        for (i, o) in self.configs.iter().enumerate() {
            if !self.visible[i] {
                continue;
            }
            let first = self.first_joint[i] as usize;
            match o.kind {
                ObjectKind::Rigid => {
                    // a target not seen yet: hidden (zero), not at the head as a hand's prop
                    let target = self.targets[i].map(|k| tracked.targets[k]);
                    if let Some(placed) = rigid_placement(o, target, tracked) {
                        matrices[first] = Mat4::from(placed);
                    }
                }
                ObjectKind::Avatar => {
                    if let Some(body) = &self.avatar {
                        // `scale` shrinks or grows the body about the tracked head (the eyes
                        // stay where they are tracked); the arms reach for the hands as far
                        // from the head unscaled, so that once scaled the hands are on them
                        let head = Vec3::from(tracked.head.translation);
                        let about_head = Mat4::from_translation(head)
                            * Mat4::from_scale(Vec3::splat(o.scale))
                            * Mat4::from_translation(-head);
                        let unscaled = |mut hand: Affine3A| {
                            let from_head = Vec3::from(hand.translation) - head;
                            hand.translation = (head + from_head / o.scale).into();
                            hand
                        };
                        let pose = body.pose(
                            tracked.head,
                            tracked.left_hand.map(unscaled),
                            tracked.wand.map(unscaled),
                        );
                        for (slot, m) in matrices[first..].iter_mut().zip(pose) {
                            *slot = about_head * m;
                        }
                    }
                }
            }
        }
        matrices
    }
}

/// A rigid object's world placement: what it follows, then its own offset, angles and scale;
/// `target`, a `follow = "target"` object's target this frame (`Objects::load` resolves its
/// name). None where it follows a target not seen yet: it is not drawn.
pub fn rigid_placement(
    o: &ObjectConfig,
    target: Option<Option<Affine3A>>,
    tracked: &Tracked,
) -> Option<Affine3A> {
    let base = match o.follow {
        Follow::World if o.keyframes.is_empty() => Affine3A::IDENTITY,
        Follow::World => motion::keyframed(&o.keyframes, tracked.time, o.repeat),
        Follow::Head => tracked.head,
        // no hand tracked this frame: the prop waits at the head
        Follow::Wand => tracked.wand.unwrap_or(tracked.head),
        Follow::LeftHand => tracked.left_hand.unwrap_or(tracked.head),
        // a chair at the head would be a lie: hidden until its target is first seen (live
        // sources then hold it where it was last seen)
        Follow::Target => target.flatten()?,
    };
    let local = Affine3A::from_scale_rotation_translation(
        Vec3::splat(o.scale),
        head_rotation_from_angles(o.yaw_deg, o.pitch_deg, o.roll_deg),
        Vec3::from(o.position),
    );
    Some(base * local)
}

/// Append a skinned mesh (`avatar::SkinnedMesh`) to `mesh` as object `object`, its joints
/// numbered from `first_joint` (`joint_count` of them).
fn push_skinned(
    mesh: &mut MovingMesh,
    part: &avatar::SkinnedMesh,
    object: u32,
    (first_joint, joint_count): (u32, u32),
) {
    let vertices = (part.positions.iter().enumerate()).map(|(i, p)| RestVertex {
        position: *p,
        normal: part.normals.get(i).copied().unwrap_or(Vec3::Y),
        joints: part.joints[i].map(|j| j + first_joint),
        weights: part.weights[i],
    });
    let materials = (part.materials.iter()).map(|m| MovingMaterial {
        albedo: m.base_color,
        emission: m.emission,
    });
    let triangles = (&part.triangles[..], &part.triangle_material[..]);
    mesh.push_part(vertices, triangles, object, materials);
    mesh.joint_count = mesh.joint_count.max(first_joint + joint_count);
}
