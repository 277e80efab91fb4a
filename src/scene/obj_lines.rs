//! An OBJ's geometry parsed on the CPU's threads, the way tobj reads it (tobj parses on one:
//! 1.3-2.2 s of a 5M-triangle OBJ on a GPU host). `obj.rs` takes from it what it took from
//! tobj's models: the corners of every triangle over positions in the order faces first use
//! them, their texture coordinates, and the objects with their materials.
//!
//! It reads the subset of OBJ that scenes use, with tobj's rules (a new object at `o`/`g` and
//! at a change of `usemtl`, polygons as fans, indices from 1 or relative); where a file steps
//! outside it (a `v` with a weight or colours, `l` elements, an index to a later element, an
//! object whose corners have texture coordinates only in part, a `usemtl` without a name, a
//! number tobj would not read), it answers `None` and the importer lets tobj read the file, so
//! such files import (or fail) exactly as before.

use std::collections::HashMap;
use std::path::Path;

/// What the importer needs of an OBJ's geometry.
#[derive(Debug, PartialEq)]
pub(crate) struct ObjGeometry {
    /// positions in the order the faces first use them (each position of an index once)
    pub points: Vec<[f32; 3]>,
    /// each triangle's corners as indices into `points`
    pub corners: Vec<[u32; 3]>,
    /// each triangle's texture coordinates, where its object has them
    pub uv: Vec<Option<[[f32; 2]; 3]>>,
    pub objects: Vec<ObjectPart>,
}

/// One of tobj's models: a run of triangles with one name and one material.
#[derive(Debug, PartialEq)]
pub(crate) struct ObjectPart {
    pub name: String,
    pub material: Option<usize>,
    /// its triangles have texture coordinates
    pub textured: bool,
    /// some of its corners had texture coordinates and some not: none are kept (tobj's models
    /// cannot say which corners had them)
    pub partly_textured: bool,
    pub triangles: usize,
}

impl ObjGeometry {
    /// tobj's models (read with `single_index` and `triangulate`) in the same form.
    pub fn from_models(models: &[tobj::Model]) -> ObjGeometry {
        let mut geometry = ObjGeometry {
            points: Vec::new(),
            corners: Vec::new(),
            uv: Vec::new(),
            objects: Vec::new(),
        };
        for model in models {
            let mesh = &model.mesh;
            let first = geometry.points.len() as u32;
            // tobj lists texture coordinates only for the corners that have them
            let textured = !mesh.texcoords.is_empty();
            let aligned = mesh.texcoords.len() / 2 == mesh.positions.len() / 3;
            (geometry.points).extend(mesh.positions.chunks(3).map(|p| [p[0], p[1], p[2]]));
            for tri in mesh.indices.chunks(3) {
                geometry.corners.push([0, 1, 2].map(|k| first + tri[k]));
                geometry.uv.push((textured && aligned).then(|| {
                    [0, 1, 2].map(|k| {
                        let i = tri[k] as usize;
                        [mesh.texcoords[2 * i], mesh.texcoords[2 * i + 1]]
                    })
                }));
            }
            geometry.objects.push(ObjectPart {
                name: model.name.clone(),
                material: mesh.material_id,
                textured: textured && aligned,
                partly_textured: textured && !aligned,
                triangles: mesh.indices.len() / 3,
            });
        }
        geometry
    }
}

/// A material library's materials and their indices by name, as tobj's loader returns them.
pub(crate) type Library = tobj::MTLLoadResult;

/// The materials of every library, as tobj merges them (an error where none could be read).
pub(crate) type Materials = Result<Vec<tobj::Material>, tobj::LoadError>;

/// `text` (an OBJ) parsed on the CPU's threads, `load_library` called for each `mtllib` in file
/// order; the materials as tobj merges them. None where tobj must read the file.
pub(crate) fn parse(
    text: &str,
    load_library: impl Fn(&Path) -> Library,
) -> Option<(ObjGeometry, Materials)> {
    let pieces = crate::parallel::line_pieces(text, crate::parallel::threads() * 4);
    let counts: Vec<Counts> = on_pieces(&pieces, |piece| Some(Counts::of(piece)))?;
    let mut before = Counts::default();
    let starts: Vec<Counts> = (counts.iter())
        .map(|c| {
            let start = before;
            before = before.plus(c);
            start
        })
        .collect();
    let indexed: Vec<(&str, Counts)> = pieces.iter().copied().zip(starts).collect();
    let parsed: Vec<Piece> = on_pieces(&indexed, |&(piece, start)| Piece::parse(piece, start))?;
    let (objects, materials) = walk_objects(&parsed, load_library);
    Some((gather(&parsed, objects)?, materials))
}

/// `f` of each piece on a thread of its own, in order; None if any answers None.
fn on_pieces<P: Sync, T: Send>(pieces: &[P], f: impl Fn(&P) -> Option<T> + Sync) -> Option<Vec<T>> {
    std::thread::scope(|scope| {
        let handles: Vec<_> = pieces.iter().map(|p| scope.spawn(|| f(p))).collect();
        (handles.into_iter())
            .map(|h| h.join().expect("an OBJ reader thread panicked"))
            .collect()
    })
}

/// Elements before a line: positions, texture coordinates, normals.
#[derive(Clone, Copy, Default)]
struct Counts {
    v: usize,
    vt: usize,
    vn: usize,
}

impl Counts {
    fn of(piece: &str) -> Counts {
        let mut counts = Counts::default();
        for line in piece.split('\n') {
            match line.split_whitespace().next() {
                Some("v") => counts.v += 1,
                Some("vt") => counts.vt += 1,
                Some("vn") => counts.vn += 1,
                _ => {}
            }
        }
        counts
    }

    fn plus(self, o: &Counts) -> Counts {
        Counts {
            v: self.v + o.v,
            vt: self.vt + o.vt,
            vn: self.vn + o.vn,
        }
    }
}

/// A line that starts or names an object, or loads materials, after `triangles` triangles of
/// its piece.
enum Event {
    Object(String),
    Material(String),
    Library(String),
}

/// One piece of the file: its elements and its triangles (corners as indices into the whole
/// file's elements; a texture index of u32::MAX where a corner has none).
#[derive(Default)]
struct Piece {
    positions: Vec<[f32; 3]>,
    texcoords: Vec<[f32; 2]>,
    triangles: Vec<[u32; 3]>,
    triangle_uv: Vec<[u32; 3]>,
    events: Vec<(usize, Event)>,
}

const NO_INDEX: u32 = u32::MAX;

impl Piece {
    /// The piece whose first line comes after `start`'s elements; None where tobj must read it.
    fn parse(text: &str, start: Counts) -> Option<Piece> {
        let mut piece = Piece::default();
        let mut at = start;
        for raw in text.split('\n') {
            let line = raw.strip_suffix('\r').unwrap_or(raw);
            let mut words = line.split_whitespace();
            match words.next() {
                Some("v") => {
                    piece.positions.push(numbers::<3>(&mut words)?);
                    if words.next().is_some() {
                        return None; // a weight or colours: tobj's
                    }
                    at.v += 1;
                }
                Some("vt") => {
                    piece.texcoords.push(numbers::<2>(&mut words)?);
                    at.vt += 1;
                }
                Some("vn") => {
                    numbers::<3>(&mut words)?;
                    at.vn += 1;
                }
                Some("f") => piece.face(words, at)?,
                Some("o" | "g") => {
                    let size = line.chars().next().map_or(0, char::len_utf8);
                    let name = match line[size..].trim() {
                        "" => "unnamed_object",
                        name => name,
                    };
                    piece.event(Event::Object(name.to_owned()));
                }
                Some(key @ ("mtllib" | "usemtl")) => {
                    let name = line.split_once(' ').map_or("", |s| s.1).trim().to_owned();
                    piece.event(match key {
                        "mtllib" => Event::Library(name),
                        _ if name.is_empty() => return None,
                        _ => Event::Material(name),
                    });
                }
                Some("l") => return None,
                _ => {}
            }
        }
        Some(piece)
    }

    fn event(&mut self, event: Event) {
        self.events.push((self.triangles.len(), event));
    }

    /// A face as a fan of triangles (tobj's order), its corners resolved against `at`.
    fn face<'a>(&mut self, words: impl Iterator<Item = &'a str>, at: Counts) -> Option<()> {
        let mut corners: Vec<(u32, u32)> = Vec::with_capacity(4);
        for word in words {
            corners.push(corner(word, at)?);
        }
        if corners.len() < 3 {
            return None; // points and lines: tobj's
        }
        let textured = corners[0].1 != NO_INDEX;
        if corners.iter().any(|c| (c.1 != NO_INDEX) != textured) {
            return None;
        }
        for k in 2..corners.len() {
            let fan = [corners[0], corners[k - 1], corners[k]];
            self.triangles.push(fan.map(|c| c.0));
            self.triangle_uv.push(fan.map(|c| c.1));
        }
        Some(())
    }
}

/// The first N numbers of a line, as tobj reads them.
fn numbers<'a, const N: usize>(words: &mut impl Iterator<Item = &'a str>) -> Option<[f32; N]> {
    let mut out = [0.0; N];
    for x in out.iter_mut() {
        *x = words.next()?.parse().ok()?;
    }
    Some(out)
}

/// A face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`: its position and texture coordinate
/// indices from 0 (relative ones resolved against `at`); None for an index tobj would refuse or
/// one to an element after the line.
fn corner(word: &str, at: Counts) -> Option<(u32, u32)> {
    let mut parts = word.split('/');
    let resolve = |part: Option<&str>, count: usize| -> Option<u32> {
        let x: isize = part?.parse().ok()?;
        let i = if x < 0 { count as isize + x } else { x - 1 };
        (i >= 0 && (i as usize) < count).then_some(i as u32)
    };
    let v = resolve(parts.next(), at.v)?;
    let vt = match parts.next() {
        None | Some("") => NO_INDEX,
        part => resolve(part, at.vt)?,
    };
    match parts.next() {
        None | Some("") => {}
        part => {
            resolve(part, at.vn)?;
        }
    }
    parts.next().is_none().then_some((v, vt))
}

/// The objects tobj makes of the pieces' events and triangles (materials looked up as the
/// libraries load, in file order), and the materials as tobj merges them.
fn walk_objects(
    pieces: &[Piece],
    load_library: impl Fn(&Path) -> Library,
) -> (Vec<ObjectPart>, Materials) {
    let mut materials: Vec<tobj::Material> = Vec::new();
    let mut by_name: HashMap<String, usize> = HashMap::new();
    let mut library_error = None;
    let mut objects = Vec::new();
    // tobj's name for an object before any `o` or `g`
    let mut current = ObjectPart {
        name: "unnamed_object".to_owned(),
        material: None,
        textured: false,
        partly_textured: false,
        triangles: 0,
    };
    let mut pending = 0; // triangles of the current object
    for piece in pieces {
        let mut seen = 0;
        for (before, event) in &piece.events {
            pending += before - seen;
            seen = *before;
            match event {
                Event::Object(name) => {
                    if pending > 0 {
                        objects.push(close(&current, &mut pending));
                    }
                    current.name = name.clone();
                }
                Event::Material(name) => {
                    let material = by_name.get(name).copied();
                    if current.material != material && pending > 0 {
                        objects.push(close(&current, &mut pending));
                    }
                    current.material = material;
                }
                Event::Library(file) => match load_library(Path::new(file)) {
                    Ok((mut loaded, names)) => {
                        let offset = materials.len();
                        materials.append(&mut loaded);
                        by_name.extend(names.into_iter().map(|(n, i)| (n, i + offset)));
                    }
                    Err(e) => library_error = Some(e),
                },
            }
        }
        pending += piece.triangles.len() - seen;
    }
    objects.push(close(&current, &mut pending));
    let materials = match (materials.is_empty(), library_error) {
        (true, Some(e)) => Err(e),
        _ => Ok(materials),
    };
    (objects, materials)
}

/// The current object with its pending triangles, and in its place a new one with the same
/// name and material.
fn close(current: &ObjectPart, pending: &mut usize) -> ObjectPart {
    ObjectPart {
        name: current.name.clone(),
        material: current.material,
        textured: false,
        partly_textured: false,
        triangles: std::mem::take(pending),
    }
}

/// The pieces' triangles joined, positions numbered by first use, texture coordinates looked
/// up; each object's `textured` from its triangles (None where an object mixes triangles with
/// and without them: tobj's).
fn gather(pieces: &[Piece], mut objects: Vec<ObjectPart>) -> Option<ObjGeometry> {
    let positions: Vec<&[f32; 3]> = pieces.iter().flat_map(|p| &p.positions).collect();
    let texcoords: Vec<&[f32; 2]> = pieces.iter().flat_map(|p| &p.texcoords).collect();
    let triangles = pieces
        .iter()
        .flat_map(|p| p.triangles.iter().zip(&p.triangle_uv));
    let mut point_of = vec![NO_INDEX; positions.len()];
    let mut geometry = ObjGeometry {
        points: Vec::new(),
        corners: Vec::new(),
        uv: Vec::new(),
        objects: Vec::new(),
    };
    let mut object = 0;
    let mut left = objects.first().map_or(0, |o| o.triangles);
    for (tri, uv) in triangles {
        while left == 0 {
            object += 1;
            left = objects[object].triangles;
        }
        left -= 1;
        let corners = tri.map(|v| {
            let p = &mut point_of[v as usize];
            if *p == NO_INDEX {
                *p = geometry.points.len() as u32;
                geometry.points.push(*positions[v as usize]);
            }
            *p
        });
        geometry.corners.push(corners);
        let textured = uv[0] != NO_INDEX;
        let first = left + 1 == objects[object].triangles;
        if first {
            objects[object].textured = textured;
        } else if objects[object].textured != textured {
            return None;
        }
        geometry
            .uv
            .push(textured.then(|| uv.map(|t| *texcoords[t as usize])));
    }
    geometry.objects = objects;
    Some(geometry)
}
