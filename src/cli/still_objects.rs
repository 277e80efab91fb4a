//! Moving objects in a still (`vlf render --objects`, `vlf export mitsuba --objects`): a file of
//! objects (`render::objects_file::ObjectsFile`) posed once, with the camera as the tracked head
//! and no hand tracked, so that a renderer sharing none of vlf's code can be given the very
//! geometry vlf drew.

use anyhow::Result;
use glam::{Mat4, Vec3};
use std::path::Path;
use vlf::dynamic::{Objects, Tracked};
use vlf::render::objects_file::ObjectsFile;
use vlf::scene::Camera;

/// The objects of one file at the pose a camera gives them.
pub struct StillObjects {
    pub file: ObjectsFile,
    pub objects: Objects,
    /// world metres from rest, per joint (`Objects::joint_matrices`)
    pub joints: Vec<Mat4>,
}

/// Load `path`'s objects and pose them with `camera` as the head.
pub fn still_objects(path: &Path, camera: &Camera) -> Result<StillObjects> {
    let file = ObjectsFile::load(path)?;
    let objects = Objects::load(&file.objects, path)?;
    let tracked = Tracked::looking(
        Vec3::from(camera.eye),
        Vec3::from(camera.target),
        Vec3::from(camera.up),
    );
    let joints = objects.joint_matrices(&tracked);
    Ok(StillObjects {
        file,
        objects,
        joints,
    })
}
