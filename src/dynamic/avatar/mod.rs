//! The participant's avatar (issue 28, "a body in the light field"), CPU side: a skinned glTF
//! body posed from the tracked head and hands, as skinning matrices for the GPU's linear blend
//! skinning and a CPU twin of that skinning for tests.
//!
//! - `skin.rs` reads the glTF (the first skin and the mesh that uses it);
//! - `skeleton.rs` holds the joint hierarchy and its forward kinematics;
//! - `names.rs` finds the joints the rig needs by name (vlf's, Mixamo's and other rigs');
//! - `ik.rs` is the analytic two-bone IK; `rig.rs` turns head and hands into joint transforms
//!   (its module documentation states the rig's conventions: the eyes' offset, the body's yaw,
//!   the elbow pole, the hand's grip frame).
//!
//! The shipped avatar is `assets/avatar/mannequin.glb`, written by `tools/make-avatar.py`.
//!
//! # What a glTF avatar needs
//! One skinned mesh (the first skin in the file and the first node with a mesh that uses it),
//! its triangle primitives with POSITION, JOINTS_0 and WEIGHTS_0 (NORMAL is computed when
//! missing; JOINTS_1/WEIGHTS_1 are not read; the weights are renormalised to sum 1). Model
//! space is the skinned node's world space in the file: +y up, metres, facing +z. Joints are
//! found by name (compared ignoring case, separators and a `mixamorig:`-style prefix):
//!
//! | joint | vlf's name | also accepted |
//! |---|---|---|
//! | head (required) | `head` | `mixamorig:Head` |
//! | left upper arm (required) | `upper_arm_l` | `mixamorig:LeftArm`, `upperarm_l`, `leftUpperArm`, `DEF-upper_arm.L` |
//! | left forearm (required) | `forearm_l` | `mixamorig:LeftForeArm`, `lowerarm_l`, `leftLowerArm` |
//! | left hand (required) | `hand_l` | `mixamorig:LeftHand`, `leftHand` |
//! | the right arm's (required) | `upper_arm_r`, `forearm_r`, `hand_r` | as the left, with Right/`_r`/`.R` |
//! | hips, neck (optional) | `hips`, `neck` | `Hips`, `pelvis`, `mixamorig:Neck` |
//!
//! The character's left is +x (it faces +z). The other joints (spine, shoulders, legs, fingers)
//! keep their bind pose relative to their parents.

use crate::error::{Result, VlfError};
use glam::{Affine3A, Mat4, Vec3};
use std::path::Path;

mod ik;
mod names;
mod rig;
mod skeleton;
mod skin;

pub use names::Role;

/// The avatar's triangles in the bind pose, with their skinning data.
#[derive(Clone, Debug)]
pub struct SkinnedMesh {
    /// bind pose, metres, the glTF's model space (+y up, facing +z as glTF's convention)
    pub positions: Vec<Vec3>,
    /// bind pose (computed if the file has none)
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// JOINTS_0 as indices into the skin's joint list
    pub joints: Vec<[u32; 4]>,
    /// WEIGHTS_0, renormalised to sum 1
    pub weights: Vec<[f32; 4]>,
    /// index into `materials`
    pub triangle_material: Vec<u32>,
    pub materials: Vec<AvatarMaterial>,
}

/// A material of the avatar: plain colours (textures are not read).
#[derive(Clone, Debug, PartialEq)]
pub struct AvatarMaterial {
    pub name: String,
    /// linear, the glTF's baseColorFactor
    pub base_color: [f32; 3],
    /// linear, emissiveFactor x KHR_materials_emissive_strength
    pub emission: [f32; 3],
}

/// A skinned body posed from tracking.
pub struct Avatar {
    pub mesh: SkinnedMesh,
    skeleton: skeleton::Skeleton,
    rig: rig::Rig,
}

impl Avatar {
    /// glTF/.glb with one skinned mesh (the first skin); a clear [`VlfError`] naming the file
    /// and what is missing (no skin, no JOINTS_0/WEIGHTS_0, joint names the rig needs not
    /// found, ...). Never panics on bad input.
    pub fn load(path: &Path) -> Result<Avatar> {
        let loaded = skin::read(path)?;
        let skeleton = skeleton::Skeleton::new(loaded.names, loaded.parents, loaded.bind);
        let rig = rig::Rig::new(&skeleton, &loaded.mesh).map_err(|message| VlfError::Mesh {
            path: path.to_path_buf(),
            message: format!("not a usable avatar: {message}"),
        })?;
        Ok(Avatar {
            mesh: loaded.mesh,
            skeleton,
            rig,
        })
    }

    pub fn joint_count(&self) -> usize {
        self.skeleton.len()
    }

    /// The skin's joint names, in the skin's order (the order of the skinning matrices).
    pub fn joint_names(&self) -> &[String] {
        &self.skeleton.names
    }

    /// The joint the rig uses for a role (None: an optional joint the skin does not have).
    pub fn joint(&self, role: Role) -> Option<usize> {
        self.rig.joint(role)
    }

    /// The avatar's height (top of head above the lowest bind-pose vertex), metres.
    pub fn height(&self) -> f32 {
        self.rig.top - self.rig.floor
    }

    /// The eyes' point above the lowest bind-pose vertex, metres: where a tracked head puts
    /// the eyes of an avatar standing on the floor.
    pub fn eye_height(&self) -> f32 {
        self.rig.eyes.y - self.rig.floor
    }

    /// The eyes' point (the tracked head's origin) in the bind pose, model space.
    pub fn eyes(&self) -> Vec3 {
        self.rig.eyes
    }

    /// Every joint's world transform for a participant whose tracked head (the point between
    /// the eyes, OpenXR convention: identity looks along -z, +y up) is at `head` in world
    /// metres, and whose hands are at `left_hand`/`right_hand` (None: that arm hangs at rest).
    pub fn pose_joints(
        &self,
        head: Affine3A,
        left_hand: Option<Affine3A>,
        right_hand: Option<Affine3A>,
    ) -> Vec<Affine3A> {
        self.rig.pose(&self.skeleton, head, [left_hand, right_hand])
    }

    /// The skinning matrices (joint's world transform * inverse bind matrix), one per joint,
    /// for a participant whose tracked head (the point between the eyes, OpenXR convention:
    /// identity looks along -z, +y up) is at `head` in world metres, and whose hands are at
    /// `left_hand`/`right_hand` (None: that arm hangs at rest). The inverse bind matrices are
    /// the model-space ones (relative to [`SkinnedMesh::positions`]).
    pub fn pose(
        &self,
        head: Affine3A,
        left_hand: Option<Affine3A>,
        right_hand: Option<Affine3A>,
    ) -> Vec<Mat4> {
        self.pose_joints(head, left_hand, right_hand)
            .iter()
            .zip(&self.skeleton.inverse_bind)
            .map(|(world, inverse_bind)| Mat4::from(*world * *inverse_bind))
            .collect()
    }

    /// The world positions of the joints for skinning matrices from [`Avatar::pose`].
    pub fn joint_positions(&self, matrices: &[Mat4]) -> Vec<Vec3> {
        (0..self.joint_count())
            .map(|j| {
                let m = matrices.get(j).copied().unwrap_or(Mat4::IDENTITY);
                m.transform_point3(self.skeleton.bind_position(j))
            })
            .collect()
    }

    /// CPU twin of GPU linear blend skinning: each bind-pose position transformed by
    /// sum_j w_j M_j. Computed as `p + sum_j w_j (M_j p - p)`, the same when the weights sum
    /// to 1, and exact for identity matrices. A missing matrix counts as the identity.
    pub fn skin(&self, matrices: &[Mat4]) -> Vec<Vec3> {
        let mesh = &self.mesh;
        mesh.positions
            .iter()
            .zip(mesh.joints.iter().zip(&mesh.weights))
            .map(|(&p, (js, ws))| {
                let mut moved = Vec3::ZERO;
                for (&j, &w) in js.iter().zip(ws) {
                    if w != 0.0 {
                        let m = matrices.get(j as usize).copied().unwrap_or(Mat4::IDENTITY);
                        moved += w * (m.transform_point3(p) - p);
                    }
                }
                p + moved
            })
            .collect()
    }
}
