//! Welding and triangle clean-up shared by the OBJ and glTF importers: equal positions share
//! an id (numbered in order of first use), zero-area triangles and repeats of a kept triangle
//! are dropped and counted for a warning.

use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Triangles whose area is below this fraction of the scene's squared extent are dropped.
const DEGENERATE_AREA: f64 = 1e-14;

/// Positions welded by their bits: the same coordinates give the same id.
#[derive(Default)]
pub(crate) struct Welder {
    pub positions: Vec<[f32; 3]>,
    ids: HashMap<[u32; 3], u32>,
}

impl Welder {
    /// The id of `p`, a new one when it has not been seen.
    pub fn id(&mut self, p: [f32; 3]) -> u32 {
        let positions = &mut self.positions;
        *self.ids.entry(p.map(f32::to_bits)).or_insert_with(|| {
            positions.push(p);
            positions.len() as u32 - 1
        })
    }
}

/// Keeps triangles with area that no kept triangle repeats, counting the ones it drops.
pub(crate) struct TriangleFilter {
    min_area: f64,
    seen: HashSet<[u32; 3]>,
    degenerate: usize,
    duplicate: usize,
}

impl TriangleFilter {
    /// `extent`: the largest absolute coordinate of the mesh (zero-area is relative to it).
    pub fn new(extent: f64) -> TriangleFilter {
        TriangleFilter {
            min_area: DEGENERATE_AREA * (extent * extent).max(1e-30),
            seen: HashSet::new(),
            degenerate: 0,
            duplicate: 0,
        }
    }

    /// Whether the triangle of welded ids `v` at `corners` is kept.
    pub fn keep(&mut self, v: [u32; 3], corners: [[f32; 3]; 3]) -> bool {
        let [a, b, c] = corners.map(|p| glam::DVec3::from(p.map(|x| x as f64)));
        if (b - a).cross(c - a).length() * 0.5 <= self.min_area {
            self.degenerate += 1;
            return false;
        }
        // the same three corners in the same winding, whichever corner comes first
        let rot = (0..3).min_by_key(|&k| v[k]).unwrap_or(0);
        if !self
            .seen
            .insert([v[rot], v[(rot + 1) % 3], v[(rot + 2) % 3]])
        {
            self.duplicate += 1;
            return false;
        }
        true
    }

    /// One warning per kind of dropped triangle, naming the mesh file.
    pub fn warnings(&self, path: &Path) -> Vec<String> {
        let mut warnings = Vec::new();
        if self.degenerate > 0 {
            warnings.push(format!(
                "{}: dropped {} zero-area triangle(s)",
                path.display(),
                self.degenerate
            ));
        }
        if self.duplicate > 0 {
            warnings.push(format!(
                "{}: dropped {} duplicated triangle(s) (same corners and winding as another)",
                path.display(),
                self.duplicate
            ));
        }
        warnings
    }
}
