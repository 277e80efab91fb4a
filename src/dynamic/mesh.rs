//! The moving objects' triangles as one mesh in its rest pose, the form the GPU skins every frame
//! (`render::moving`): each vertex with up to four joints and weights (a rigid object's vertices
//! all hang on its one joint), each triangle with its object and material.

use crate::error::Result;
use crate::scene::Scene;
use glam::{Mat4, Vec3};
use std::path::Path;

/// A vertex at rest: object space (metres), the joints whose matrices move it and their weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestVertex {
    pub position: Vec3,
    pub normal: Vec3,
    pub joints: [u32; 4],
    pub weights: [f32; 4],
}

/// What a moving surface is made of: diffuse albedo and emitted radiance (linear).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MovingMaterial {
    pub albedo: [f32; 3],
    pub emission: [f32; 3],
}

/// Every moving object's rest pose in one mesh.
#[derive(Clone, Debug, Default)]
pub struct MovingMesh {
    pub vertices: Vec<RestVertex>,
    pub triangles: Vec<[u32; 3]>,
    /// per triangle: its object (index into the config's objects) and its material
    pub triangle_object: Vec<u32>,
    pub triangle_material: Vec<u32>,
    pub materials: Vec<MovingMaterial>,
    /// joint matrices the mesh reads
    pub joint_count: u32,
}

impl MovingMesh {
    /// Append a rigid mesh hanging on joint `joint`, as object `object`.
    pub fn push_rigid(&mut self, part: &RigidMesh, object: u32, joint: u32) {
        let vertices = (part.positions.iter().zip(&part.normals)).map(|(p, n)| RestVertex {
            position: *p,
            normal: *n,
            joints: [joint, 0, 0, 0],
            weights: [1.0, 0.0, 0.0, 0.0],
        });
        let part_triangles = (&part.triangles[..], &part.triangle_material[..]);
        self.push_part(
            vertices,
            part_triangles,
            object,
            part.materials.iter().copied(),
        );
        self.joint_count = self.joint_count.max(joint + 1);
    }

    /// Append one object's part: its vertices, its triangles (indices into those vertices) with
    /// their materials (indices into `materials`), all as object `object`.
    pub fn push_part(
        &mut self,
        vertices: impl IntoIterator<Item = RestVertex>,
        (triangles, triangle_material): (&[[u32; 3]], &[u32]),
        object: u32,
        materials: impl IntoIterator<Item = MovingMaterial>,
    ) {
        let first = self.vertices.len() as u32;
        let material_base = self.materials.len() as u32;
        self.vertices.extend(vertices);
        self.triangles
            .extend(triangles.iter().map(|t| t.map(|i| i + first)));
        self.triangle_object
            .extend(std::iter::repeat_n(object, triangles.len()));
        self.triangle_material
            .extend(triangle_material.iter().map(|m| m + material_base));
        self.materials.extend(materials);
    }

    /// The rest pose's corners of every triangle (for the tree built once over it).
    pub fn corners(&self) -> Vec<[Vec3; 3]> {
        (self.triangles.iter())
            .map(|t| t.map(|i| self.vertices[i as usize].position))
            .collect()
    }
}

/// A rigid mesh: positions and smooth normals (metres, its own frame), triangles, materials.
#[derive(Clone, Debug, Default)]
pub struct RigidMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub triangle_material: Vec<u32>,
    pub materials: Vec<MovingMaterial>,
}

impl RigidMesh {
    /// A glTF/.glb or OBJ model as a rigid mesh: its materials' diffuse colour (a texture's mean
    /// where it has one) and emission; normals smoothed over the faces that share a vertex.
    pub fn load(path: &Path) -> Result<RigidMesh> {
        let scene = Scene::load_model(path)?;
        let positions: Vec<Vec3> = scene.positions.iter().map(|p| Vec3::from(*p)).collect();
        let triangles: Vec<[u32; 3]> = scene.triangles.iter().map(|t| t.vertices).collect();
        let materials = (scene.materials.iter())
            .map(|m| {
                let tint = m
                    .diffuse_texture
                    .and_then(|t| scene.textures.get(t as usize))
                    .map_or([1.0; 3], mean_colour);
                MovingMaterial {
                    albedo: [0, 1, 2].map(|c| (m.diffuse[c] + m.mirror[c]) * tint[c]),
                    emission: m.emission,
                }
            })
            .collect();
        Ok(RigidMesh {
            normals: smooth_normals(&positions, &triangles),
            triangle_material: scene.triangles.iter().map(|t| t.material).collect(),
            positions,
            triangles,
            materials,
        })
    }
}

/// A texture's mean colour (linear).
fn mean_colour(texture: &crate::scene::Texture) -> [f32; 3] {
    let mut sum = [0.0f64; 3];
    for t in &texture.texels {
        for k in 0..3 {
            sum[k] += t[k] as f64;
        }
    }
    let n = texture.texels.len().max(1) as f64;
    sum.map(|s| (s / n) as f32)
}

/// Area-weighted vertex normals (a vertex no triangle uses gets +y).
pub fn smooth_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for i in t {
            normals[*i as usize] += n;
        }
    }
    normals
        .into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Y))
        .collect()
}

impl MovingMesh {
    /// Every vertex where `joints` (world metres from rest, one per joint: `Objects::
    /// joint_matrices`) put it, as the GPU skins it (`shaders/moving.wgsl`).
    pub fn posed_positions(&self, joints: &[Mat4]) -> Vec<Vec3> {
        (self.vertices.iter())
            .map(|v| {
                let mut p = Vec3::ZERO;
                for (&j, &w) in v.joints.iter().zip(&v.weights) {
                    if w != 0.0 {
                        let m = joints.get(j as usize).copied().unwrap_or(Mat4::ZERO);
                        p += w * m.transform_point3(v.position);
                    }
                }
                p
            })
            .collect()
    }

    /// The mesh at the pose `joints` give, as OBJ and MTL text (world metres; one MTL material
    /// per moving material, `Kd` its albedo and `Ke` its emission; `mtl_file` is what the OBJ's
    /// `mtllib` names). Triangles of hidden objects (`visible` false) are left out: a frozen pose
    /// for a reference renderer (`vlf export mitsuba --objects`).
    pub fn posed_obj(&self, joints: &[Mat4], visible: &[bool], mtl_file: &str) -> (String, String) {
        use std::fmt::Write;
        let positions = self.posed_positions(joints);
        let mut obj =
            format!("# moving objects at a frozen pose, written by vlf\nmtllib {mtl_file}\n");
        for p in &positions {
            let _ = writeln!(obj, "v {} {} {}", p.x, p.y, p.z);
        }
        let mut current = u32::MAX;
        for (t, tri) in self.triangles.iter().enumerate() {
            let object = self.triangle_object[t] as usize;
            if !visible.get(object).copied().unwrap_or(true) {
                continue;
            }
            if self.triangle_material[t] != current {
                current = self.triangle_material[t];
                let _ = writeln!(obj, "usemtl moving{current}");
            }
            let _ = writeln!(obj, "f {} {} {}", tri[0] + 1, tri[1] + 1, tri[2] + 1);
        }
        let mut mtl = String::new();
        for (i, m) in self.materials.iter().enumerate() {
            let [r, g, b] = m.albedo;
            let [er, eg, eb] = m.emission;
            let _ = writeln!(
                mtl,
                "newmtl moving{i}\nKd {r} {g} {b}\nKe {er} {eg} {eb}\nKs 0 0 0\n"
            );
        }
        (obj, mtl)
    }
}
