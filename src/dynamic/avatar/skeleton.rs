//! The avatar's joint hierarchy: each joint's parent joint, its bind-pose transform in model
//! space and its bind-local transform (relative to its parent joint), and forward kinematics
//! (local transforms -> model-space transforms, parents first) with some joints' model-space
//! rotations overridden by the rig.
//!
//! The bind transforms come from the skin's inverse bind matrices (see `skin.rs`), so nodes
//! between joints, the armature's own transform and the mesh node's transform are all folded
//! in: a joint's local transform is `bind[parent]^-1 * bind[joint]`.

use glam::{Affine3A, Quat, Vec3};

pub(super) struct Skeleton {
    /// the skin's joint names, in the skin's order (unnamed joints: "joint N")
    pub names: Vec<String>,
    /// each joint's nearest ancestor that is a joint of the skin
    pub parents: Vec<Option<usize>>,
    /// model-space bind transforms
    pub bind: Vec<Affine3A>,
    /// their inverses (the model-space inverse bind matrices)
    pub inverse_bind: Vec<Affine3A>,
    /// bind transforms relative to the parent joint (roots: the model-space bind transform)
    local: Vec<Affine3A>,
    /// the bind transforms' scales (kept when a rotation is overridden)
    scale: Vec<Vec3>,
    /// joints in an order where every parent comes before its children
    order: Vec<usize>,
}

impl Skeleton {
    /// `parents` must be acyclic (it comes from a node tree that was walked with a depth limit);
    /// `bind` transforms must be invertible (checked by the loader).
    pub fn new(names: Vec<String>, parents: Vec<Option<usize>>, bind: Vec<Affine3A>) -> Skeleton {
        let n = bind.len();
        let inverse_bind: Vec<Affine3A> = bind.iter().map(|b| b.inverse()).collect();
        let local = (0..n)
            .map(|j| match parents[j] {
                Some(p) => inverse_bind[p] * bind[j],
                None => bind[j],
            })
            .collect();
        let scale = bind
            .iter()
            .map(|b| b.to_scale_rotation_translation().0)
            .collect();
        let depth = |mut j: usize| {
            let mut d = 0;
            while let Some(p) = parents[j] {
                j = p;
                d += 1;
                if d > n {
                    break;
                }
            }
            d
        };
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by_key(|&j| (depth(j), j));
        Skeleton {
            names,
            parents,
            bind,
            inverse_bind,
            local,
            scale,
            order,
        }
    }

    pub fn len(&self) -> usize {
        self.bind.len()
    }

    /// The bind-pose model-space rotation of a joint (its scale taken out).
    pub fn bind_rotation(&self, j: usize) -> Quat {
        self.bind[j].to_scale_rotation_translation().1
    }

    /// The bind-pose model-space position of a joint.
    pub fn bind_position(&self, j: usize) -> Vec3 {
        self.bind[j].translation.into()
    }

    /// Whether `joint` is `ancestor` or lies below it.
    pub fn descends(&self, mut joint: usize, ancestor: usize) -> bool {
        for _ in 0..=self.len() {
            if joint == ancestor {
                return true;
            }
            match self.parents[joint] {
                Some(p) => joint = p,
                None => return false,
            }
        }
        false
    }

    /// Model-space transforms: every joint at its bind-local transform below its posed parent,
    /// except that a joint with an override takes that model-space rotation (its position
    /// still follows its parent; its bind scale is kept).
    pub fn forward(&self, overrides: &[Option<Quat>]) -> Vec<Affine3A> {
        let mut out = self.bind.clone();
        for &j in &self.order {
            let fk = match self.parents[j] {
                Some(p) => out[p] * self.local[j],
                None => self.local[j],
            };
            out[j] = match overrides.get(j).copied().flatten() {
                Some(q) => Affine3A::from_scale_rotation_translation(
                    self.scale[j],
                    q,
                    fk.translation.into(),
                ),
                None => fk,
            };
        }
        out
    }
}
