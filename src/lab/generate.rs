//! `vlf generate`: procedural scenes that scale from about a thousand to a million triangles,
//! written as scene.toml + OBJ + MTL (the same contract as hand-made scenes), for the benchmark
//! suite and for anyone who wants a big scene to try.
//! - classroom: rows of desks and chairs under ceiling lights, a row of windows open to the sky,
//!   a blackboard; the mirror variant hangs a mirror over the back wall. It grows in triangles
//!   (more desks, then finer tessellation of every box side) while its faces stay boxes' sides.
//! - gallery: a hall of pedestals carrying geodesic-sphere sculptures (every triangle its own
//!   face: it grows in faces), lit from the ceiling; the mirror variant lines both long walls
//!   with mirrors.

use crate::error::{Result, VlfError};
use glam::DVec3;

mod gltf;

/// How `vlf generate` writes the mesh: OBJ + MTL, or glTF 2.0 (.gltf + .bin).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum MeshFormat {
    #[default]
    Obj,
    Gltf,
}
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum SceneKind {
    Classroom,
    Gallery,
}

#[derive(Clone, Debug)]
pub struct GenerateOptions {
    pub kind: SceneKind,
    /// about this many triangles (classroom) or faces (gallery)
    pub size: u64,
    pub mirrors: bool,
    /// glossy floors and metal (`glossy_variant`)
    pub glossy: bool,
}

/// The `--glossy` variant's scene.toml overrides: a varnished floor (diffuse plus a GGX lobe of
/// alpha 0.05, as a plastic's coat) ...
const GLOSSY_FLOOR: &str = "\n[materials.floor]\ndiffuse = [0.36, 0.26, 0.17]\nmirror = [0.12, 0.12, 0.12]\nroughness = 0.05\n";
/// ... and the classroom's glossy metal (alpha 0.2).
const GLOSSY_METAL: &str = "\n[materials.metal]\ndiffuse = [0.0, 0.0, 0.0]\nmirror = [0.62, 0.62, 0.64]\nroughness = 0.2\n";

/// The `--glossy` variant of a generated scene.toml: its name marked, the overrides appended.
fn glossy_variant(toml: String, kind: SceneKind) -> String {
    let mut out = String::new();
    for line in toml.lines() {
        match line
            .strip_prefix("name = \"")
            .and_then(|n| n.strip_suffix('"'))
        {
            Some(name) => out.push_str(&format!("name = \"{name}-glossy\"\n")),
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    out.push_str(GLOSSY_FLOOR);
    if kind == SceneKind::Classroom {
        out.push_str(GLOSSY_METAL);
    }
    out
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Generated {
    pub scene: PathBuf,
    pub triangles: u64,
    /// planar pieces as written (box sides, sphere triangles, wall panels)
    pub faces: u64,
    pub description: String,
}

/// An OBJ under construction: vertices, and quads or triangles grouped by material.
#[derive(Default)]
struct Mesh {
    obj: String,
    vertices: u64,
    triangles: u64,
    faces: u64,
    material: String,
}

impl Mesh {
    fn use_material(&mut self, m: &str) {
        if self.material != m {
            let _ = writeln!(self.obj, "usemtl {m}");
            self.material = m.to_string();
        }
    }

    fn vertex(&mut self, p: DVec3) -> u64 {
        let _ = writeln!(self.obj, "v {:.5} {:.5} {:.5}", p.x, p.y, p.z);
        self.vertices += 1;
        self.vertices
    }

    /// A rectangle from corner `o` along `a` and `b` (front = a x b), cut into t x t quads.
    fn panel(&mut self, m: &str, o: DVec3, a: DVec3, b: DVec3, t: u32) {
        self.use_material(m);
        let first = self.vertices + 1;
        for j in 0..=t {
            for i in 0..=t {
                self.vertex(o + a * (i as f64 / t as f64) + b * (j as f64 / t as f64));
            }
        }
        let at = |i: u32, j: u32| first + (j * (t + 1) + i) as u64;
        for j in 0..t {
            for i in 0..t {
                let _ = writeln!(
                    self.obj,
                    "f {} {} {} {}",
                    at(i, j),
                    at(i + 1, j),
                    at(i + 1, j + 1),
                    at(i, j + 1)
                );
            }
        }
        self.triangles += 2 * (t * t) as u64;
        self.faces += 1;
    }

    /// An axis-aligned box from `lo` to `hi`, faces outward, each side cut into t x t quads.
    fn cuboid(&mut self, m: &str, lo: DVec3, hi: DVec3, t: u32) {
        let d = hi - lo;
        let (x, y, z) = (DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z);
        self.panel(m, lo, z, y, t); // -x
        self.panel(m, lo + x, y, z, t); // +x
        self.panel(m, lo, x, z, t); // -y
        self.panel(m, lo + y, z, x, t); // +y
        self.panel(m, lo, y, x, t); // -z
        self.panel(m, lo + z, x, y, t); // +z
    }

    fn triangle(&mut self, m: &str, a: DVec3, b: DVec3, c: DVec3) {
        self.use_material(m);
        let i = self.vertex(a);
        self.vertex(b);
        self.vertex(c);
        let _ = writeln!(self.obj, "f {} {} {}", i, i + 1, i + 2);
        self.triangles += 1;
        self.faces += 1;
    }

    /// A geodesic sphere: the icosahedron's faces split `level` times, pushed onto the sphere.
    fn sphere(&mut self, m: &str, centre: DVec3, radius: f64, level: u32) {
        let g = (1.0 + 5f64.sqrt()) / 2.0;
        let v: Vec<DVec3> = [
            (-1.0, g, 0.0),
            (1.0, g, 0.0),
            (-1.0, -g, 0.0),
            (1.0, -g, 0.0),
            (0.0, -1.0, g),
            (0.0, 1.0, g),
            (0.0, -1.0, -g),
            (0.0, 1.0, -g),
            (g, 0.0, -1.0),
            (g, 0.0, 1.0),
            (-g, 0.0, -1.0),
            (-g, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
        .collect();
        let faces = [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        let mut tris: Vec<[DVec3; 3]> = faces.iter().map(|f| [v[f[0]], v[f[1]], v[f[2]]]).collect();
        for _ in 0..level {
            tris = tris
                .iter()
                .flat_map(|&[a, b, c]| {
                    let (ab, bc, ca) = (
                        (a + b).normalize(),
                        (b + c).normalize(),
                        (c + a).normalize(),
                    );
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
                })
                .collect();
        }
        for [a, b, c] in tris {
            self.triangle(
                m,
                centre + a * radius,
                centre + b * radius,
                centre + c * radius,
            );
        }
    }
}

const MTL: &str = "newmtl wall\nKd 0.72 0.70 0.66\n\nnewmtl floor\nKd 0.45 0.33 0.22\n\nnewmtl ceiling\nKd 0.80 0.80 0.80\n\nnewmtl wood\nKd 0.55 0.40 0.25\n\nnewmtl metal\nKd 0.30 0.30 0.32\n\nnewmtl board\nKd 0.08 0.20 0.12\n\nnewmtl light\nKd 0 0 0\nKe 12 11.5 10.5\n\nnewmtl marble\nKd 0.80 0.78 0.74\n\nnewmtl plinth\nKd 0.35 0.35 0.38\n\nnewmtl panel\nKd 0.50 0.52 0.55\n\nnewmtl mirror\nKd 0 0 0\n";

/// Write the scene into `dir` (created), refusing to overwrite a different scene's files.
pub fn generate(options: &GenerateOptions, dir: &Path) -> Result<Generated> {
    generate_as(options, dir, MeshFormat::Obj)
}

/// [`generate`], the mesh written in `format`.
pub fn generate_as(options: &GenerateOptions, dir: &Path, format: MeshFormat) -> Result<Generated> {
    if options.size == 0 {
        return Err(VlfError::Parameter {
            name: "size",
            message: "must be at least 1".into(),
        });
    }
    std::fs::create_dir_all(dir).map_err(|e| VlfError::io(dir, e))?;
    let (mesh, mut toml, mut description) = match options.kind {
        SceneKind::Classroom => classroom(options.size, options.mirrors),
        SceneKind::Gallery => gallery(options.size, options.mirrors),
    };
    if options.glossy {
        toml = glossy_variant(toml, options.kind);
        description.push_str(", glossy floor");
        if options.kind == SceneKind::Classroom {
            description.push_str(" and metal");
        }
    }
    let write = |name: &str, text: &str| {
        crate::lightfield::file::write_atomic(&dir.join(name), text.as_bytes())
    };
    match format {
        MeshFormat::Obj => {
            write("scene.obj", &mesh.obj)?;
            write("scene.mtl", MTL)?;
            write("scene.toml", &toml)?;
        }
        MeshFormat::Gltf => {
            let (json, bin) = gltf::from_obj(&mesh.obj, MTL, "scene.bin")?;
            crate::lightfield::file::write_atomic(&dir.join("scene.bin"), &bin)?;
            write("scene.gltf", &json)?;
            write(
                "scene.toml",
                &toml.replace("mesh = \"scene.obj\"", "mesh = \"scene.gltf\""),
            )?;
        }
    }
    Ok(Generated {
        scene: dir.join("scene.toml"),
        triangles: mesh.triangles,
        faces: mesh.faces,
        description,
    })
}

fn header(mesh: &mut Mesh) {
    mesh.obj
        .push_str("# generated by `vlf generate`\nmtllib scene.mtl\n");
}

/// Walls, floor and ceiling facing in; `windows` cuts that many openings into the -x wall.
fn room(mesh: &mut Mesh, size: DVec3, windows: u32) {
    let (w, h, d) = (size.x, size.y, size.z);
    mesh.panel(
        "floor",
        DVec3::new(-w / 2.0, 0.0, -d / 2.0),
        DVec3::Z * d,
        DVec3::X * w,
        1,
    );
    mesh.panel(
        "ceiling",
        DVec3::new(-w / 2.0, h, -d / 2.0),
        DVec3::X * w,
        DVec3::Z * d,
        1,
    );
    mesh.panel(
        "wall",
        DVec3::new(-w / 2.0, 0.0, -d / 2.0),
        DVec3::X * w,
        DVec3::Y * h,
        1,
    ); // back (z-), faces +z
    mesh.panel(
        "wall",
        DVec3::new(w / 2.0, 0.0, d / 2.0),
        -DVec3::X * w,
        DVec3::Y * h,
        1,
    ); // front (z+), faces -z
    mesh.panel(
        "wall",
        DVec3::new(w / 2.0, 0.0, -d / 2.0),
        DVec3::Z * d,
        DVec3::Y * h,
        1,
    ); // +x wall, faces -x
       // the -x wall, facing +x, with window openings between 1.0 m and 2.4 m
    let x = -w / 2.0;
    let (sill, top) = (1.0, 2.4f64.min(h - 0.2));
    let wall = |mesh: &mut Mesh, z0: f64, z1: f64, y0: f64, y1: f64| {
        if z1 > z0 && y1 > y0 {
            mesh.panel(
                "wall",
                DVec3::new(x, y0, z1),
                -DVec3::Z * (z1 - z0),
                DVec3::Y * (y1 - y0),
                1,
            );
        }
    };
    wall(mesh, -d / 2.0, d / 2.0, 0.0, sill);
    wall(mesh, -d / 2.0, d / 2.0, top, h);
    let pitch = d / windows.max(1) as f64;
    let opening = (pitch * 0.6).min(1.6);
    for i in 0..windows.max(1) {
        let z0 = -d / 2.0 + pitch * i as f64;
        let c = z0 + pitch / 2.0;
        let (a, b) = if windows == 0 {
            (c, c)
        } else {
            (c - opening / 2.0, c + opening / 2.0)
        };
        wall(mesh, z0, a, sill, top);
        wall(mesh, b, z0 + pitch, sill, top);
    }
}

fn camera(name: &str, eye: DVec3, target: DVec3, fov: f64) -> String {
    format!(
        "\n[[camera]]\nname = \"{name}\"\neye = [{:.3}, {:.3}, {:.3}]\ntarget = [{:.3}, {:.3}, {:.3}]\nup = [0.0, 1.0, 0.0]\nfov_y_deg = {fov}\nsize = [1024, 768]\n",
        eye.x, eye.y, eye.z, target.x, target.y, target.z
    )
}

/// Where the classroom's desks go: `sets` desk-and-chair sets in `rows` x `columns`, every box
/// side cut `t` x `t`, in a room of `size`.
struct Classroom {
    sets: u64,
    columns: u64,
    rows: u64,
    /// desk spacing along x and z
    pitch: (f64, f64),
    size: DVec3,
    t: u32,
}

impl Classroom {
    fn for_triangles(target_triangles: u64) -> Classroom {
        const PER_SET: u64 = 11 * 6 * 2; // desk 5 boxes + chair 6 boxes, 6 sides of 2 triangles
                                         // up to 256 desks at 1x1, then finer cuts, then as many desks as the target needs
        let tessellation = ((target_triangles as f64 / (PER_SET * 256) as f64)
            .sqrt()
            .round() as u32)
            .max(1);
        let sets = ((target_triangles as f64
            / (PER_SET as f64 * (tessellation * tessellation) as f64))
            .round() as u64)
            .clamp(4, 1024);
        let columns = (sets as f64).sqrt().ceil() as u64;
        let rows = sets.div_ceil(columns);
        let pitch = (1.3, 1.6);
        let size = DVec3::new(
            columns as f64 * pitch.0 + 2.5,
            3.2,
            rows as f64 * pitch.1 + 4.0,
        );
        Classroom {
            sets,
            columns,
            rows,
            pitch,
            size,
            t: tessellation,
        }
    }

    /// The desks with their chairs, row by row.
    fn furnish(&self, mesh: &mut Mesh) {
        let places = (0..self.rows).flat_map(|r| (0..self.columns).map(move |c| (r, c)));
        for (r, c) in places.take(self.sets as usize) {
            let x = (c as f64 - (self.columns - 1) as f64 / 2.0) * self.pitch.0;
            let z = -self.size.z / 2.0 + 3.0 + r as f64 * self.pitch.1;
            desk_and_chair(mesh, x, z, self.t);
        }
    }

    /// Ceiling lights, one per two rows and columns, facing down.
    fn light(&self, mesh: &mut Mesh) {
        for r in (0..self.rows).step_by(2) {
            for c in (0..self.columns).step_by(2) {
                let x = (c as f64 + 0.5 - self.columns as f64 / 2.0) * self.pitch.0;
                let z = -self.size.z / 2.0 + 3.5 + r as f64 * self.pitch.1;
                mesh.panel(
                    "light",
                    DVec3::new(x - 0.3, self.size.y - 0.01, z - 0.3),
                    DVec3::X * 0.6,
                    DVec3::Z * 0.6,
                    1,
                );
            }
        }
    }

    /// The blackboard on the back wall, and the mirror variant's mirror on the front wall.
    fn hang(&self, mesh: &mut Mesh, mirrors: bool) {
        let size = self.size;
        mesh.panel(
            "board",
            DVec3::new(-1.5, 0.9, -size.z / 2.0 + 0.01),
            DVec3::X * 3.0,
            DVec3::Y * 1.3,
            1,
        );
        if mirrors {
            mesh.panel(
                "mirror",
                DVec3::new(size.x / 2.0 - 0.5, 0.5, size.z / 2.0 - 0.01),
                -DVec3::X * (size.x - 1.0),
                DVec3::Y * 2.2,
                1,
            );
        }
    }
}

/// A desk (top and four legs) at (x, z) and its chair behind it (seat, back, four legs).
fn desk_and_chair(mesh: &mut Mesh, x: f64, z: f64, t: u32) {
    mesh.cuboid(
        "wood",
        DVec3::new(x - 0.5, 0.72, z - 0.3),
        DVec3::new(x + 0.5, 0.76, z + 0.3),
        t,
    );
    for (lx, lz) in [(-0.46, -0.26), (0.42, -0.26), (-0.46, 0.22), (0.42, 0.22)] {
        mesh.cuboid(
            "metal",
            DVec3::new(x + lx, 0.0, z + lz),
            DVec3::new(x + lx + 0.04, 0.72, z + lz + 0.04),
            t,
        );
    }
    let zc = z + 0.65;
    mesh.cuboid(
        "wood",
        DVec3::new(x - 0.22, 0.44, zc - 0.22),
        DVec3::new(x + 0.22, 0.48, zc + 0.22),
        t,
    );
    mesh.cuboid(
        "wood",
        DVec3::new(x - 0.22, 0.48, zc + 0.18),
        DVec3::new(x + 0.22, 0.9, zc + 0.22),
        t,
    );
    for (lx, lz) in [(-0.21, -0.21), (0.18, -0.21), (-0.21, 0.18), (0.18, 0.18)] {
        mesh.cuboid(
            "metal",
            DVec3::new(x + lx, 0.0, zc + lz),
            DVec3::new(x + lx + 0.03, 0.44, zc + lz + 0.03),
            t,
        );
    }
}

fn classroom(target_triangles: u64, mirrors: bool) -> (Mesh, String, String) {
    let room_plan = Classroom::for_triangles(target_triangles);
    let Classroom { sets, t, size, .. } = room_plan;
    let mut mesh = Mesh::default();
    header(&mut mesh);
    room(&mut mesh, size, (room_plan.rows as u32 / 2).max(2));
    room_plan.furnish(&mut mesh);
    room_plan.light(&mut mesh);
    room_plan.hang(&mut mesh, mirrors);
    let mut toml = format!(
        "# Generated by `vlf generate classroom --size {target_triangles}{}`: {sets} desks with chairs, box sides cut {t}x{t}.\nname = \"classroom-{target_triangles}{}\"\nmesh = \"scene.obj\"\n\n[sky]\nradiance = [1.2, 1.25, 1.4]\n",
        if mirrors { " --mirrors" } else { "" },
        if mirrors { "-mirror" } else { "" }
    );
    if mirrors {
        toml.push_str(
            "\n[materials.mirror]\nmirror = [0.85, 0.85, 0.85]\ndiffuse = [0.0, 0.0, 0.0]\n",
        );
    }
    toml.push_str(&camera(
        "front",
        DVec3::new(size.x * 0.3, 1.6, size.z / 2.0 - 0.6),
        DVec3::new(-size.x * 0.1, 1.0, -size.z / 2.0),
        60.0,
    ));
    if mirrors {
        // facing the mirror from the aisle: what stands in the room shows in it
        toml.push_str(&camera(
            "mirror",
            DVec3::new(size.x * 0.1, 1.6, size.z / 2.0 - 4.5),
            DVec3::new(0.0, 1.3, size.z / 2.0),
            60.0,
        ));
    }
    let description = format!(
        "classroom: {sets} desks and chairs, box sides cut {t}x{t}, {}",
        if mirrors {
            "a mirror on the front wall"
        } else {
            "diffuse only"
        }
    );
    (mesh, toml, description)
}

fn gallery(target_faces: u64, mirrors: bool) -> (Mesh, String, String) {
    const SCULPTURES: u64 = 8;
    // 20 * 4^level faces per sculpture
    let per = (target_faces / SCULPTURES).max(20);
    let level = ((per as f64 / 20.0).ln() / 4f64.ln())
        .round()
        .clamp(0.0, 7.0) as u32;
    let size = DVec3::new(8.0, 4.0, 20.0);
    let mut mesh = Mesh::default();
    header(&mut mesh);
    room(&mut mesh, size, 0);
    for i in 0..SCULPTURES {
        let side = if i % 2 == 0 { -1.6 } else { 1.6 };
        let z = -size.z / 2.0 + 2.5 + (i / 2) as f64 * 4.5;
        mesh.cuboid(
            "plinth",
            DVec3::new(side - 0.4, 0.0, z - 0.4),
            DVec3::new(side + 0.4, 1.0, z + 0.4),
            1,
        );
        mesh.sphere("marble", DVec3::new(side, 1.55, z), 0.5, level);
    }
    for k in 0..4 {
        let z = -size.z / 2.0 + 2.5 + k as f64 * 5.0;
        mesh.panel(
            "light",
            DVec3::new(-0.8, size.y - 0.01, z - 0.8),
            DVec3::X * 1.6,
            DVec3::Z * 1.6,
            1,
        );
    }
    // panels along both long walls: mirrors in the mirror variant, grey otherwise
    let panel = if mirrors { "mirror" } else { "panel" };
    for k in 0..3 {
        let z0 = -size.z / 2.0 + 2.0 + k as f64 * 6.0;
        mesh.panel(
            panel,
            DVec3::new(size.x / 2.0 - 0.01, 0.8, z0),
            DVec3::Z * 3.0,
            DVec3::Y * 2.0,
            1,
        );
        mesh.panel(
            panel,
            DVec3::new(-size.x / 2.0 + 0.01, 0.8, z0 + 3.0),
            -DVec3::Z * 3.0,
            DVec3::Y * 2.0,
            1,
        );
    }
    let mut toml = format!(
        "# Generated by `vlf generate gallery --size {target_faces}{}`: {SCULPTURES} geodesic sculptures of {} faces.\nname = \"gallery-{target_faces}{}\"\nmesh = \"scene.obj\"\n",
        if mirrors { " --mirrors" } else { "" },
        20 * 4u64.pow(level),
        if mirrors { "-mirror" } else { "" }
    );
    if mirrors {
        toml.push_str(
            "\n[materials.mirror]\nmirror = [0.85, 0.85, 0.85]\ndiffuse = [0.0, 0.0, 0.0]\n",
        );
    }
    toml.push_str(&camera(
        "front",
        DVec3::new(0.0, 1.7, size.z / 2.0 - 0.5),
        DVec3::new(0.0, 1.4, -size.z / 2.0),
        60.0,
    ));
    let description = format!(
        "gallery: {SCULPTURES} sculptures of {} faces, {}",
        20 * 4u64.pow(level),
        if mirrors {
            "mirrors along both long walls"
        } else {
            "diffuse only"
        }
    );
    (mesh, toml, description)
}
