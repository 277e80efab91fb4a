//! Welding and triangle clean-up shared by the OBJ and glTF importers: equal positions share
//! an id (numbered in order of first use), zero-area triangles and repeats of a kept triangle
//! are dropped and counted for a warning.
//!
//! Both run on the CPU's threads (a 5M-triangle model spent seconds here on one): the points
//! are split into shards by a hash of their key, each shard's table on a thread of its own
//! seeing its points in order, so the first use of every key, and with it the result, is the
//! one a single table filled in order gives, on any number of threads.

use crate::parallel::map_indices;
use std::collections::HashMap;
use std::hash::{BuildHasher, Hash};
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// Triangles whose area is below this fraction of the scene's squared extent are dropped.
const DEGENERATE_AREA: f64 = 1e-14;

/// Positions welded by their bits: the distinct positions in order of first use, and each
/// point's index among them.
pub(crate) struct Welded {
    pub positions: Vec<[f32; 3]>,
    pub ids: Vec<u32>,
}

/// Weld `points`: equal coordinates (bit for bit) get the same id.
pub(crate) fn weld(points: &[[f32; 3]]) -> Welded {
    let first = first_uses(points.len(), |i| points[i].map(f32::to_bits));
    let mut ids = vec![0u32; points.len()];
    let mut positions = Vec::new();
    for (i, f) in first.iter().enumerate() {
        let f = f.load(Relaxed) as usize;
        ids[i] = match f == i {
            true => {
                positions.push(points[i]);
                positions.len() as u32 - 1
            }
            false => ids[f],
        };
    }
    Welded { positions, ids }
}

/// Which triangles to keep: those with area that repeat no kept triangle, and how many of each
/// kind were dropped.
pub(crate) struct Kept {
    pub keep: Vec<bool>,
    degenerate: usize,
    duplicate: usize,
}

/// The triangles of welded ids `triangles` over `positions` to keep; `extent`, the largest
/// absolute coordinate of the mesh, scales what zero area means.
pub(crate) fn keep_triangles(triangles: &[[u32; 3]], positions: &[[f32; 3]], extent: f64) -> Kept {
    let min_area = DEGENERATE_AREA * (extent * extent).max(1e-30);
    let has_area = |v: &[u32; 3]| {
        let [a, b, c] = v.map(|i| glam::DVec3::from(positions[i as usize].map(|x| x as f64)));
        (b - a).cross(c - a).length() * 0.5 > min_area
    };
    let area: Vec<bool> = map_indices(triangles.len(), |i| has_area(&triangles[i]));
    // the same three corners in the same winding, whichever corner comes first; a triangle
    // without area never counts as the first of its corners
    let canonical = |i: usize| {
        let v = triangles[i];
        let rot = (0..3).min_by_key(|&k| v[k]).unwrap_or(0);
        [v[rot], v[(rot + 1) % 3], v[(rot + 2) % 3]]
    };
    let with_area: Vec<u32> = (0..triangles.len() as u32)
        .filter(|&i| area[i as usize])
        .collect();
    let first = first_uses(with_area.len(), |k| canonical(with_area[k] as usize));
    let mut keep = vec![false; triangles.len()];
    for (k, f) in first.iter().enumerate() {
        keep[with_area[k] as usize] = f.load(Relaxed) as usize == k;
    }
    let kept = keep.iter().filter(|&&k| k).count();
    Kept {
        keep,
        degenerate: triangles.len() - with_area.len(),
        duplicate: with_area.len() - kept,
    }
}

impl Kept {
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

/// A quick hash of the keys here (positions' bits, triangles' corner ids): SipHash's defence
/// against chosen keys buys nothing for a mesh, and it was most of the welding's time.
#[derive(Default)]
struct MixHasher(u64);

impl std::hash::Hasher for MixHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.0 = (self.0.rotate_left(5) ^ u64::from_le_bytes(word))
                .wrapping_mul(0x517c_c1b7_2722_0a95);
        }
    }

    /// The MurmurHash3 finaliser: every bit of the state reaches the low bits (the shard).
    fn finish(&self) -> u64 {
        let mut x = self.0;
        x ^= x >> 33;
        x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
        x ^= x >> 33;
        x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        x ^ (x >> 33)
    }
}

type MixState = std::hash::BuildHasherDefault<MixHasher>;

/// For each of `count` items, the first item with the same `key`: shards by the key's hash,
/// each filled in item order on a thread of its own.
fn first_uses<K: Hash + Eq + Send>(
    count: usize,
    key: impl Fn(usize) -> K + Sync,
) -> Vec<AtomicU32> {
    let threads = crate::parallel::threads().min(255);
    let hasher = MixState::default();
    let shard: Vec<u8> = map_indices(count, |i| (hasher.hash_one(key(i)) % threads as u64) as u8);
    let first: Vec<AtomicU32> = (0..count).map(|i| AtomicU32::new(i as u32)).collect();
    std::thread::scope(|scope| {
        for s in 0..threads {
            let (shard, first, key) = (&shard, &first, &key);
            scope.spawn(move || {
                let mut seen: HashMap<K, u32, MixState> = HashMap::default();
                for i in (0..count).filter(|&i| shard[i] as usize == s) {
                    let f = *seen.entry(key(i)).or_insert(i as u32);
                    first[i].store(f, Relaxed);
                }
            });
        }
    });
    first
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    /// The welded ids and the kept triangles are what one table filled in order gives.
    #[test]
    fn welding_and_keeping_match_one_table_in_order() {
        // a grid of points with many repeats, in a scrambled order
        let points: Vec<[f32; 3]> = (0..200_000u32)
            .map(|i| {
                let j = i.wrapping_mul(2_654_435_761) % 5_000;
                [(j % 71) as f32, (j / 71) as f32, 0.5]
            })
            .collect();
        let welded = weld(&points);
        let mut table: HashMap<[u32; 3], u32> = HashMap::new();
        let mut positions = Vec::new();
        for (i, p) in points.iter().enumerate() {
            let id = *table.entry(p.map(f32::to_bits)).or_insert_with(|| {
                positions.push(*p);
                positions.len() as u32 - 1
            });
            assert_eq!(welded.ids[i], id, "point {i}");
        }
        assert_eq!(welded.positions, positions);
        // triangles: some repeated (rotated: the same), some reversed (kept), some flat
        let n = welded.positions.len() as u32;
        let triangles: Vec<[u32; 3]> = (0..60_000u32)
            .map(|i| {
                let a = i.wrapping_mul(40_503) % n;
                let (b, c) = ((a + 1) % n, (a + 71) % n);
                match i % 5 {
                    0 => [b, c, a],
                    1 => [a, c, b],
                    2 => [a, b, a],
                    _ => [a, b, c],
                }
            })
            .collect();
        let kept = keep_triangles(&triangles, &welded.positions, 100.0);
        let mut seen = HashSet::new();
        let (mut flat, mut repeats) = (0, 0);
        for (i, v) in triangles.iter().enumerate() {
            let [a, b, c] = v.map(|k| glam::DVec3::from(positions[k as usize].map(|x| x as f64)));
            let keep = if (b - a).cross(c - a).length() * 0.5 <= DEGENERATE_AREA * 1e4 {
                flat += 1;
                false
            } else {
                let rot = (0..3).min_by_key(|&k| v[k]).unwrap();
                let new = seen.insert([v[rot], v[(rot + 1) % 3], v[(rot + 2) % 3]]);
                repeats += usize::from(!new);
                new
            };
            assert_eq!(kept.keep[i], keep, "triangle {i}");
        }
        assert!(flat > 0 && repeats > 0, "{flat} {repeats}");
        assert_eq!((kept.degenerate, kept.duplicate), (flat, repeats));
    }
}
