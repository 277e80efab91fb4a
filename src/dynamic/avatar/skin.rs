//! Reading a skinned glTF (`.gltf` or `.glb`): the first skin, the mesh of the first node that
//! uses it (every triangle primitive: POSITION, NORMAL or computed normals, JOINTS_0,
//! WEIGHTS_0, indices, material), the skin's joints with their names, parent joints and
//! model-space bind transforms. Accessors go through the scene importer's checked readers
//! (`crate::scene::gltf`), so bad input is an error naming the file and the problem.
//!
//! Model space is the skinned mesh node's world space in the file (its node transform and its
//! ancestors' applied), which for a glTF exporter's avatar is +y up, metres, facing +z. A
//! joint's model-space bind transform is `mesh node world * inverseBindMatrix^-1` (the node's
//! world transform when the skin has no inverse bind matrices), so the joints' own node
//! transforms in the file need not be at the bind pose.

use super::{AvatarMaterial, SkinnedMesh};
use crate::error::{Result, VlfError};
use crate::scene::gltf as reader;
use ::gltf::mesh::Mode;
use glam::{Affine3A, Mat3, Mat4, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Node hierarchies deeper than this are refused (a cycle, or not an avatar).
const MAX_DEPTH: usize = 256;

/// What the file holds: the mesh in model space and the skeleton's raw parts.
pub(super) struct Loaded {
    pub mesh: SkinnedMesh,
    pub names: Vec<String>,
    pub parents: Vec<Option<usize>>,
    pub bind: Vec<Affine3A>,
}

pub(super) fn read(path: &Path) -> Result<Loaded> {
    let err = |message: String| VlfError::Mesh {
        path: path.to_path_buf(),
        message: format!("not a usable avatar: {message}"),
    };
    let bytes = std::fs::read(path).map_err(|e| VlfError::io(path, e))?;
    let gltf = reader::parse(&bytes).map_err(err)?;
    let doc = &gltf.document;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut sources = Vec::new();
    let buffers =
        reader::load_buffers(doc, gltf.blob.as_deref(), dir, &mut sources).map_err(err)?;
    let skin = doc.skins().next().ok_or_else(|| {
        err(
            "the file has no skin (an avatar is a mesh skinned to a skeleton: a glTF skin, \
             and JOINTS_0/WEIGHTS_0 on the mesh)"
                .to_string(),
        )
    })?;
    let node = doc
        .nodes()
        .find(|n| n.mesh().is_some() && n.skin().map(|s| s.index()) == Some(skin.index()))
        .ok_or_else(|| err(format!("no node has a mesh with skin {}", skin.index())))?;
    let (parents, world) = node_worlds(doc).map_err(err)?;
    let model = world[node.index()];
    let joints: Vec<::gltf::Node> = skin.joints().collect();
    let bind = bind_transforms(&skin, &joints, &world, model, &buffers).map_err(err)?;
    let joint_of: HashMap<usize, usize> = joints
        .iter()
        .enumerate()
        .map(|(j, n)| (n.index(), j))
        .collect();
    let joint_parents = joints
        .iter()
        .map(|n| {
            let mut at = parents[n.index()];
            for _ in 0..MAX_DEPTH {
                match at {
                    Some(p) if joint_of.contains_key(&p) => return joint_of.get(&p).copied(),
                    Some(p) => at = parents[p],
                    None => return None,
                }
            }
            None
        })
        .collect();
    let names = joints
        .iter()
        .enumerate()
        .map(|(j, n)| {
            n.name()
                .map_or_else(|| format!("joint {j}"), str::to_string)
        })
        .collect();
    let Some(mesh) = node.mesh() else {
        return Err(err("the skinned node has no mesh".to_string()));
    };
    let skinned = read_mesh(doc, &mesh, model, &buffers, joints.len()).map_err(err)?;
    Ok(Loaded {
        mesh: skinned,
        names,
        parents: joint_parents,
        bind,
    })
}

/// Every node's parent and world transform (the file's scene space).
fn node_worlds(
    doc: &::gltf::Document,
) -> std::result::Result<(Vec<Option<usize>>, Vec<Mat4>), String> {
    let n = doc.nodes().len();
    let mut parents = vec![None; n];
    for node in doc.nodes() {
        for child in node.children() {
            parents[child.index()] = Some(node.index());
        }
    }
    let locals: Vec<Mat4> = doc
        .nodes()
        .map(|node| Mat4::from_cols_array_2d(&node.transform().matrix()))
        .collect();
    let mut world = Vec::with_capacity(n);
    for i in 0..n {
        let (mut m, mut at) = (locals[i], parents[i]);
        let mut depth = 0;
        while let Some(p) = at {
            depth += 1;
            if depth > MAX_DEPTH {
                return Err(format!(
                    "node {i}'s ancestors are more than {MAX_DEPTH} deep (a cycle?)"
                ));
            }
            m = locals[p] * m;
            at = parents[p];
        }
        if !m.is_finite() {
            return Err(format!("node {i}'s transform is not finite"));
        }
        world.push(m);
    }
    Ok((parents, world))
}

/// The joints' model-space bind transforms, each checked to be invertible.
fn bind_transforms(
    skin: &::gltf::Skin,
    joints: &[::gltf::Node],
    world: &[Mat4],
    model: Mat4,
    buffers: &[Vec<u8>],
) -> std::result::Result<Vec<Affine3A>, String> {
    if joints.is_empty() {
        return Err(format!("skin {} has no joints", skin.index()));
    }
    let inverse: Option<Vec<f32>> = match skin.inverse_bind_matrices() {
        Some(a) => Some(
            reader::read_accessor(&a, buffers, 16)
                .map_err(|m| format!("skin {} inverseBindMatrices {m}", skin.index()))?,
        ),
        None => None,
    };
    if let Some(values) = &inverse {
        if values.len() / 16 < joints.len() {
            return Err(format!(
                "skin {} has {} joints but {} inverse bind matrices",
                skin.index(),
                joints.len(),
                values.len() / 16
            ));
        }
    }
    let mut bind = Vec::with_capacity(joints.len());
    for (j, node) in joints.iter().enumerate() {
        let g = match &inverse {
            Some(values) => {
                let ibm = Mat4::from_cols_slice(&values[16 * j..16 * j + 16]);
                model * ibm.inverse()
            }
            None => world[node.index()],
        };
        let det = Mat3::from_mat4(g).determinant();
        if !g.is_finite() || !det.is_finite() || det.abs() < 1e-12 {
            return Err(format!(
                "skin {}: joint {j} ({}) has an inverse bind matrix that cannot be inverted",
                skin.index(),
                node.name().unwrap_or("unnamed")
            ));
        }
        bind.push(Affine3A::from_mat4(g));
    }
    Ok(bind)
}

/// The skinned mesh's triangle primitives, in model space.
fn read_mesh(
    doc: &::gltf::Document,
    mesh: &::gltf::Mesh,
    model: Mat4,
    buffers: &[Vec<u8>],
    joint_count: usize,
) -> std::result::Result<SkinnedMesh, String> {
    let mut materials: Vec<AvatarMaterial> = doc.materials().map(|m| material(&m)).collect();
    let default_material = materials.len() as u32;
    let mut out = SkinnedMesh {
        positions: Vec::new(),
        normals: Vec::new(),
        triangles: Vec::new(),
        joints: Vec::new(),
        weights: Vec::new(),
        triangle_material: Vec::new(),
        materials: Vec::new(),
    };
    let normal_matrix = Mat3::from_mat4(model).inverse().transpose();
    let flip = Mat3::from_mat4(model).determinant() < 0.0;
    for prim in mesh.primitives() {
        let at = format!("mesh {} primitive {}", mesh.index(), prim.index());
        if !matches!(
            prim.mode(),
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            continue;
        }
        let part = read_primitive(&prim, buffers, joint_count).map_err(|m| format!("{at}: {m}"))?;
        let base = out.positions.len() as u32;
        let material = prim
            .material()
            .index()
            .map_or(default_material, |i| i as u32);
        out.positions
            .extend(part.positions.iter().map(|&p| model.transform_point3(p)));
        out.normals.extend(
            part.normals
                .iter()
                .map(|&n| (normal_matrix * n).try_normalize().unwrap_or(Vec3::Y)),
        );
        out.joints.extend(part.joints);
        out.weights.extend(part.weights);
        for t in part.triangles {
            let t = if flip { [t[0], t[2], t[1]] } else { t };
            out.triangles.push(t.map(|i| base + i));
            out.triangle_material.push(material);
        }
    }
    if out.triangles.is_empty() {
        return Err(format!(
            "mesh {} has no triangles (an avatar needs a triangle mesh)",
            mesh.index()
        ));
    }
    if out.triangle_material.contains(&default_material) {
        materials.push(AvatarMaterial {
            name: "default".to_string(),
            base_color: [0.5; 3],
            emission: [0.0; 3],
        });
    }
    out.materials = materials;
    Ok(out)
}

fn material(m: &::gltf::Material) -> AvatarMaterial {
    let [r, g, b, _] = m.pbr_metallic_roughness().base_color_factor();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let clean = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
    AvatarMaterial {
        name: m.name().map_or_else(
            || format!("material {}", m.index().unwrap_or(0)),
            str::to_string,
        ),
        base_color: [r, g, b].map(clean),
        emission: m.emissive_factor().map(|e| clean(e * strength)),
    }
}

/// One primitive's vertices and triangles, in the mesh's own space.
struct Part {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    joints: Vec<[u32; 4]>,
    weights: Vec<[f32; 4]>,
    triangles: Vec<[u32; 3]>,
}

fn read_primitive(
    prim: &::gltf::Primitive,
    buffers: &[Vec<u8>],
    joint_count: usize,
) -> std::result::Result<Part, String> {
    let attribute = |semantic: ::gltf::Semantic, dims: usize, name: &str| match prim.get(&semantic)
    {
        Some(a) => reader::read_accessor(&a, buffers, dims)
            .map(Some)
            .map_err(|m| format!("{name} {m}")),
        None => Ok(None),
    };
    let points = attribute(::gltf::Semantic::Positions, 3, "POSITION")?
        .ok_or("has no POSITION attribute")?;
    let count = points.len() / 3;
    let positions: Vec<Vec3> = points.chunks_exact(3).map(Vec3::from_slice).collect();
    let joints = attribute(::gltf::Semantic::Joints(0), 4, "JOINTS_0")?.ok_or(
        "has no JOINTS_0 attribute (every vertex of an avatar must name the joints that move it)",
    )?;
    let weights = attribute(::gltf::Semantic::Weights(0), 4, "WEIGHTS_0")?.ok_or(
        "has no WEIGHTS_0 attribute (every vertex of an avatar must weigh the joints that move it)",
    )?;
    if joints.len() / 4 != count || weights.len() / 4 != count {
        return Err(format!(
            "JOINTS_0 has {} elements and WEIGHTS_0 {}, POSITION {count}",
            joints.len() / 4,
            weights.len() / 4
        ));
    }
    let mut vertex_joints = Vec::with_capacity(count);
    for (v, js) in joints.chunks_exact(4).enumerate() {
        let mut ids = [0u32; 4];
        for (k, &j) in js.iter().enumerate() {
            if j < 0.0 || j.fract() != 0.0 || j as usize >= joint_count {
                return Err(format!(
                    "JOINTS_0 of vertex {v} names joint {j}, but the skin has {joint_count} joints"
                ));
            }
            ids[k] = j as u32;
        }
        vertex_joints.push(ids);
    }
    let vertex_weights = weights.chunks_exact(4).map(renormalise).collect();
    let indices: Vec<u32> = match prim.indices() {
        Some(a) => reader::read_indices(&a, buffers, count).map_err(|m| format!("indices {m}"))?,
        None => (0..count as u32).collect(),
    };
    let triangles = reader::assemble(prim.mode(), &indices);
    let normals = match attribute(::gltf::Semantic::Normals, 3, "NORMAL")? {
        Some(n) if n.len() / 3 == count => n.chunks_exact(3).map(Vec3::from_slice).collect(),
        Some(n) => {
            return Err(format!(
                "NORMAL has {} elements, POSITION {count}",
                n.len() / 3
            ))
        }
        // a primitive without NORMAL: area-weighted vertex normals
        None => crate::dynamic::mesh::smooth_normals(&positions, &triangles),
    };
    Ok(Part {
        positions,
        normals,
        joints: vertex_joints,
        weights: vertex_weights,
        triangles,
    })
}

/// Weights made non-negative and summing to 1 (all zero: the first joint takes it all).
fn renormalise(w: &[f32]) -> [f32; 4] {
    let w = [w[0], w[1], w[2], w[3]].map(|x| x.max(0.0));
    let sum: f32 = w.iter().sum();
    if sum > 0.0 {
        w.map(|x| x / sum)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    }
}
