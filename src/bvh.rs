//! The bounding volume hierarchy over a scene's triangles, built on the CPU (binned surface area
//! heuristic) and traversed on the GPU by `shaders/common/bvh.wgsl`: the eye rays of the
//! renderer, the shadow rays of direct light and the paths of the reference path tracer all
//! cast through it. It sits below all three, so none depends on another for ray casting. The
//! prepare stage builds the scene's tree once (`SceneBvh`, `PreparedScene::bvh`), walks it on
//! the CPU (`closest_hit`) to find texels buried under other geometry and hands it to
//! propagation. The build splits its subtrees over the CPU's threads; the tree is the same
//! whatever their number.

use crate::parallel::map_indices;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Mirrors WGSL `Triangle` (shaders/common/bvh.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub face: u32,
    pub e1: [f32; 3],
    pub _pad0: u32,
    pub e2: [f32; 3],
    pub _pad1: u32,
    pub uv01: [f32; 4],
    pub uv2: [f32; 4],
}

/// Mirrors WGSL `BvhNode` (shaders/common/bvh.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuBvhNode {
    pub lo: [f32; 3],
    pub index: u32,
    pub hi: [f32; 3],
    pub count: u32,
}

/// Mirrors WGSL `BvhPair` (shaders/render.wgsl): an internal node as its two children's boxes
/// and references, which the renderer reads in one 64-byte load when it opens the node. A
/// reference is `pair << 5` for an internal child, `(first triangle << 5) | count` for a leaf.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuBvhPair {
    pub lo_left: [f32; 3],
    pub left: u32,
    pub hi_left: [f32; 3],
    pub right: u32,
    pub lo_right: [f32; 3],
    pub _pad0: u32,
    pub hi_right: [f32; 3],
    pub _pad1: u32,
}

/// Pair and triangle references keep 27 bits (5 go to a leaf's count).
pub const MAX_PAIR_REFERENCE: usize = 1 << 27;

/// The BVH of `build_bvh` as child pairs (`pairs[0]` holds the root's children; a root that is
/// a leaf gets a pair of itself and a box no ray enters), and the most pairs on a path from the
/// root to a leaf: the deepest the traversal's stack can get.
pub struct BvhPairs {
    pub pairs: Vec<GpuBvhPair>,
    pub depth: u32,
}

/// The BVH as child pairs; None for an empty tree, or one of MAX_PAIR_REFERENCE nodes or more.
pub fn bvh_pairs(nodes: &[GpuBvhNode]) -> Option<BvhPairs> {
    if nodes.is_empty() || nodes.len() >= MAX_PAIR_REFERENCE {
        return None;
    }
    // the pair of internal node i, numbered in node order
    let mut pair_of = vec![u32::MAX; nodes.len()];
    let mut count = 0u32;
    for (i, n) in nodes.iter().enumerate() {
        if n.count == 0 {
            pair_of[i] = count;
            count += 1;
        }
    }
    let reference = |i: usize| -> u32 {
        let n = &nodes[i];
        if n.count == 0 {
            pair_of[i] << 5
        } else {
            debug_assert!(n.count < 32, "leaves hold at most MAX_LEAF_SIZE triangles");
            (n.index << 5) | n.count
        }
    };
    if nodes[0].count > 0 {
        let root = nodes[0];
        let never = [f32::MAX / 2.0; 3];
        let pairs = vec![GpuBvhPair {
            lo_left: root.lo,
            left: reference(0),
            hi_left: root.hi,
            right: reference(0),
            lo_right: never,
            hi_right: never,
            ..Default::default()
        }];
        return Some(BvhPairs { pairs, depth: 1 });
    }
    let mut pairs = Vec::with_capacity(count as usize);
    // pairs above each node; a parent comes before its children in node order
    let mut above = vec![0u32; nodes.len()];
    let mut depth = 0;
    for (i, n) in nodes.iter().enumerate() {
        if n.count > 0 {
            continue;
        }
        for child in [i + 1, n.index as usize] {
            above[child] = above[i] + 1;
            depth = depth.max(above[child]);
        }
        let (l, r) = (i + 1, n.index as usize);
        pairs.push(GpuBvhPair {
            lo_left: nodes[l].lo,
            left: reference(l),
            hi_left: nodes[l].hi,
            right: reference(r),
            lo_right: nodes[r].lo,
            hi_right: nodes[r].hi,
            ..Default::default()
        });
    }
    Some(BvhPairs { pairs, depth })
}

const LEAF_SIZE: usize = 4;
/// A leaf never holds more than this many triangles, whatever the cost model says.
const MAX_LEAF_SIZE: usize = 16;
/// Below this depth splits follow the surface area heuristic; deeper, median splits, which
/// halve every level: 32 + log2(triangles) stays within the GPU's 64-entry traversal stack.
const SAH_DEPTH: u32 = 32;
const SAH_BINS: usize = 16;
/// Where both children of a node have at least this many triangles (and threads remain), the
/// right one is built on a thread of its own while the left one is, the threads shared by size.
const PARALLEL_TRIANGLES: usize = 32 * 1024;
/// A node of at least this many triangles counts its bounds and bins on several threads.
const PARALLEL_PASS: usize = 256 * 1024;

#[derive(Clone, Copy)]
struct Bounds {
    lo: Vec3,
    hi: Vec3,
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds::EMPTY
    }
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, other: Bounds) {
        self.lo = self.lo.min(other.lo);
        self.hi = self.hi.max(other.hi);
    }
    fn area(&self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// `part` over `order`, split into `threads` parts run on threads of their own when it is large
/// enough, the results folded by `merge` (which must not depend on how `order` was split).
fn over_parts<T: Send>(
    order: &[u32],
    threads: usize,
    part: impl Fn(&[u32]) -> T + Sync,
    merge: impl Fn(T, T) -> T,
) -> T {
    if threads < 2 || order.len() < PARALLEL_PASS {
        return part(order);
    }
    let size = order.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = (order.chunks(size))
            .map(|c| scope.spawn(|| part(c)))
            .collect();
        (handles.into_iter())
            .map(|h| h.join().expect("a BVH pass panicked"))
            .reduce(merge)
            .expect("at least one part")
    })
}

/// The best surface-area split of `order` into bins along one of the three axes: (axis, the
/// centroid coordinate below which a triangle goes left, cost) where the cost counts one unit
/// per triangle tested, in proportion to the probability of reaching each child.
fn sah_split(
    order: &[u32],
    boxes: &[Bounds],
    centroids: &[Vec3],
    (clo, chi): (Vec3, Vec3),
    parent_area: f32,
    threads: usize,
) -> Option<(usize, f32, f32)> {
    // the three axes' bins in one pass over the triangles (the pass is memory-bound: each
    // triangle's box and centroid is read once, not once per axis)
    type Bins = [[(Bounds, usize); SAH_BINS]; 3];
    let scale = Vec3::splat(SAH_BINS as f32) / (chi - clo);
    let bin_of =
        |c: Vec3, axis: usize| (((c[axis] - clo[axis]) * scale[axis]) as usize).min(SAH_BINS - 1);
    let count = |part: &[u32]| {
        let mut bins: Bins = [[(Bounds::EMPTY, 0usize); SAH_BINS]; 3];
        for &t in part {
            let (c, b) = (centroids[t as usize], boxes[t as usize]);
            for (axis, axis_bins) in bins.iter_mut().enumerate() {
                let bin = &mut axis_bins[bin_of(c, axis)];
                bin.0.grow(b);
                bin.1 += 1;
            }
        }
        bins
    };
    let all_bins = over_parts(order, threads, count, |mut a, b| {
        for (x, y) in a.iter_mut().flatten().zip(b.iter().flatten()) {
            x.0.grow(y.0);
            x.1 += y.1;
        }
        a
    });
    let mut best: Option<(usize, f32, f32)> = None;
    for (axis, bins) in all_bins.iter().enumerate() {
        let (lo, hi) = (clo[axis], chi[axis]);
        if hi <= lo {
            continue;
        }
        let scale = scale[axis];
        // sweep from the right, then from the left: cost of every boundary between bins
        let mut right_area = [0.0f32; SAH_BINS];
        let mut right_count = [0usize; SAH_BINS];
        let (mut acc, mut n) = (Bounds::EMPTY, 0);
        for i in (1..SAH_BINS).rev() {
            acc.grow(bins[i].0);
            n += bins[i].1;
            right_area[i] = acc.area();
            right_count[i] = n;
        }
        let (mut acc, mut n) = (Bounds::EMPTY, 0);
        for i in 1..SAH_BINS {
            acc.grow(bins[i - 1].0);
            n += bins[i - 1].1;
            if n == 0 || right_count[i] == 0 {
                continue;
            }
            let cost = 1.0
                + (acc.area() * n as f32 + right_area[i] * right_count[i] as f32)
                    / parent_area.max(1e-30);
            if best.is_none_or(|b| cost < b.2) {
                best = Some((axis, lo + i as f32 / scale, cost));
            }
        }
    }
    best
}

/// A scene's BVH as the GPU reads it (`shaders/common/bvh.wgsl`) and the CPU walks it
/// (`closest_hit`): the nodes and the triangles in the order their leaves refer to.
#[derive(Default)]
pub struct SceneBvh {
    pub nodes: Vec<GpuBvhNode>,
    pub triangles: Vec<GpuTriangle>,
}

/// The BVH over `corners` and the triangles in the order its leaves refer to, each with the face
/// `face_of(i)` and the texture coordinates `uv_of(i)` of input triangle i (the path tracer's,
/// direct light's and the renderer's ray casting share it).
pub fn bvh_triangles(
    corners: &[[Vec3; 3]],
    face_of: impl Fn(usize) -> u32 + Sync,
    uv_of: impl Fn(usize) -> [[f32; 2]; 3] + Sync,
) -> (Vec<GpuBvhNode>, Vec<GpuTriangle>) {
    let (nodes, order) = build_bvh(corners);
    let triangles = map_indices(order.len(), |k| {
        let i = order[k];
        let [a, b, c] = corners[i as usize];
        let uv = uv_of(i as usize);
        GpuTriangle {
            v0: a.into(),
            face: face_of(i as usize),
            e1: (b - a).into(),
            e2: (c - a).into(),
            uv01: [uv[0][0], uv[0][1], uv[1][0], uv[1][1]],
            uv2: [uv[2][0], uv[2][1], 0.0, 0.0],
            ..Default::default()
        }
    });
    (nodes, triangles)
}

/// common/ray.wgsl's `intersect` (Moller-Trumbore, in the same f32 steps; rim rays do not grow
/// triangles): the distance, or -1.
pub fn intersect(origin: Vec3, dir: Vec3, tri: &GpuTriangle, t_max: f32) -> f32 {
    let (v0, e1, e2) = (Vec3::from(tri.v0), Vec3::from(tri.e1), Vec3::from(tri.e2));
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return -1.0;
    }
    let inv = 1.0 / det;
    let s = origin - v0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return -1.0;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return -1.0;
    }
    let t = e2.dot(q) * inv;
    if t <= 1e-5 || t >= t_max {
        return -1.0;
    }
    t
}

/// The nearest triangle (distance, index) that the ray from `origin` along `dir` meets closer
/// than `t_max`, passing by the triangles whose face `skip` names: the CPU's walk of
/// `build_bvh`'s tree (the prepare stage's test for texels buried under other geometry,
/// src/prepare/buried.rs). Cut-out holes are not looked up: every triangle is solid here.
pub fn closest_hit(
    nodes: &[GpuBvhNode],
    triangles: &[GpuTriangle],
    origin: Vec3,
    dir: Vec3,
    t_max: f32,
    skip: impl Fn(u32) -> bool,
) -> Option<(f32, usize)> {
    let inv = Vec3::ONE / dir.map(|c| if c.abs() < 1e-20 { 1e-20 } else { c });
    let enters = |n: &GpuBvhNode, t_max: f32| {
        let (a, b) = (
            (Vec3::from(n.lo) - origin) * inv,
            (Vec3::from(n.hi) - origin) * inv,
        );
        a.min(b).max_element().max(0.0) <= a.max(b).min_element().min(t_max)
    };
    let mut best: Option<(f32, usize)> = None;
    let (mut stack, mut top) = ([0u32; 64], usize::from(!nodes.is_empty()));
    while top > 0 {
        top -= 1;
        let index = stack[top];
        let node = &nodes[index as usize];
        let reach = best.map_or(t_max, |b| b.0);
        if !enters(node, reach) {
            continue;
        }
        if node.count > 0 {
            let first = node.index as usize;
            for (i, tri) in triangles
                .iter()
                .enumerate()
                .skip(first)
                .take(node.count as usize)
            {
                let reach = best.map_or(t_max, |b| b.0);
                let t = match skip(tri.face) {
                    true => -1.0,
                    false => intersect(origin, dir, tri, reach),
                };
                if t > 0.0 {
                    best = Some((t, i));
                }
            }
            continue;
        }
        for child in [node.index, index + 1] {
            if top < stack.len() {
                stack[top] = child;
                top += 1;
            }
        }
    }
    best
}

/// A bounding volume hierarchy over `triangles`: binned surface-area-heuristic splits (median
/// splits past depth SAH_DEPTH); returns the nodes and the triangle order the leaves refer to.
/// The left child of an internal node is the node after it; `index` holds the right child.
pub fn build_bvh(triangles: &[[Vec3; 3]]) -> (Vec<GpuBvhNode>, Vec<u32>) {
    build_bvh_on(triangles, crate::parallel::threads())
}

/// `build_bvh` on at most `threads` threads: the same tree whatever their number.
fn build_bvh_on(triangles: &[[Vec3; 3]], threads: usize) -> (Vec<GpuBvhNode>, Vec<u32>) {
    let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
    let centroids: Vec<Vec3> = map_indices(triangles.len(), |i| {
        let t = triangles[i];
        (t[0] + t[1] + t[2]) / 3.0
    });
    let boxes: Vec<Bounds> = map_indices(triangles.len(), |i| {
        let t = triangles[i];
        Bounds {
            lo: t[0].min(t[1]).min(t[2]),
            hi: t[0].max(t[1]).max(t[2]),
        }
    });
    let mut nodes = Vec::with_capacity(triangles.len() * 2 / LEAF_SIZE + 1);
    if !triangles.is_empty() {
        let input = BuildInput {
            boxes: &boxes,
            centroids: &centroids,
            threads,
        };
        build_node(&mut nodes, &mut order, 0, 0, &input);
    }
    (nodes, order)
}

/// What every node of a build reads.
#[derive(Clone, Copy)]
struct BuildInput<'a> {
    boxes: &'a [Bounds],
    centroids: &'a [Vec3],
    /// threads this subtree may use (`build_children` splits them between the children)
    threads: usize,
}

/// The node over `order` (the triangles from position `first` of the final order), and below it
/// its subtree; returns its index in `nodes`.
fn build_node(
    nodes: &mut Vec<GpuBvhNode>,
    order: &mut [u32],
    first: usize,
    depth: u32,
    input: &BuildInput,
) -> u32 {
    let measure = |part: &[u32]| {
        let mut bounds = Bounds::EMPTY;
        let mut centres = Bounds::EMPTY;
        for &t in part {
            bounds.grow(input.boxes[t as usize]);
            let c = input.centroids[t as usize];
            centres.grow(Bounds { lo: c, hi: c });
        }
        (bounds, centres)
    };
    let (bounds, centres) = over_parts(order, input.threads, measure, |mut a, b| {
        a.0.grow(b.0);
        a.1.grow(b.1);
        a
    });
    let me = nodes.len();
    nodes.push(GpuBvhNode {
        lo: bounds.lo.into(),
        hi: bounds.hi.into(),
        index: first as u32,
        count: order.len() as u32,
    });
    let Some(mid) = split(order, depth, input, (bounds, centres)) else {
        return me as u32;
    };
    let r = build_children(nodes, order, (first, mid), depth, input);
    nodes[me].index = r;
    nodes[me].count = 0;
    me as u32
}

/// Where `order` splits into the node's two children (reordered so that the left child's
/// triangles come first), or None where the node stays a leaf. `bounds`: the triangles' and
/// their centroids' bounds.
fn split(
    order: &mut [u32],
    depth: u32,
    input: &BuildInput,
    (bounds, centres): (Bounds, Bounds),
) -> Option<usize> {
    let extent = centres.hi - centres.lo;
    let coincident = extent.max_element() <= 0.0;
    if order.len() <= LEAF_SIZE || (coincident && order.len() <= MAX_LEAF_SIZE) {
        return None;
    }
    // triangles with one centroid (duplicates) are halved like the rest, so that no leaf
    // holds more than MAX_LEAF_SIZE
    let by_sah = if depth < SAH_DEPTH && !coincident {
        let (boxes, centroids) = (input.boxes, input.centroids);
        let centre_bounds = (centres.lo, centres.hi);
        sah_split(
            order,
            boxes,
            centroids,
            centre_bounds,
            bounds.area(),
            input.threads,
        )
    } else {
        None
    };
    let mid = match by_sah {
        // a leaf is cheaper than any split: keep it, if it is small enough
        Some((_, _, cost)) if cost >= order.len() as f32 && order.len() <= MAX_LEAF_SIZE => {
            return None
        }
        Some((axis, boundary, _)) => {
            let mut left = 0;
            for i in 0..order.len() {
                if input.centroids[order[i] as usize][axis] < boundary {
                    order.swap(i, left);
                    left += 1;
                }
            }
            left
        }
        None => 0,
    };
    if mid != 0 && mid != order.len() {
        return Some(mid);
    }
    // no useful area split (or too deep): halve along the widest centroid axis
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |a, b| {
        input.centroids[*a as usize][axis].total_cmp(&input.centroids[*b as usize][axis])
    });
    Some(mid)
}

/// The two subtrees of a node split at `mid` of `order` (whose triangles start at `first`),
/// appended to `nodes`: the left one first. Returns the right child's index.
fn build_children(
    nodes: &mut Vec<GpuBvhNode>,
    order: &mut [u32],
    (first, mid): (usize, usize),
    depth: u32,
    input: &BuildInput,
) -> u32 {
    let (left, right) = order.split_at_mut(mid);
    // where one side is too small for a thread of its own, the sides are built one after the
    // other, each with every thread; otherwise the threads are shared by size (halving them
    // left most idle: SAH splits of furnished rooms peel off a few dozen triangles beside
    // millions, and the threads given to those had nothing to do)
    if input.threads < 2 || left.len().min(right.len()) < PARALLEL_TRIANGLES {
        build_node(nodes, left, first, depth + 1, input);
        return build_node(nodes, right, first + mid, depth + 1, input);
    }
    let total = left.len() + right.len();
    let left_threads =
        ((input.threads * left.len() + total / 2) / total).clamp(1, input.threads - 1);
    // the right subtree on a thread of its own, into its own nodes, appended after the left
    // one's: the same nodes in the same order as one thread makes
    let (left_input, right_input) = (
        BuildInput {
            threads: left_threads,
            ..*input
        },
        BuildInput {
            threads: input.threads - left_threads,
            ..*input
        },
    );
    let mut right_nodes = std::thread::scope(|scope| {
        let worker = scope.spawn(|| {
            let mut own = Vec::with_capacity(right.len() * 2 / LEAF_SIZE + 1);
            build_node(&mut own, right, first + mid, depth + 1, &right_input);
            own
        });
        build_node(nodes, left, first, depth + 1, &left_input);
        worker.join().expect("a BVH builder thread panicked")
    });
    let offset = nodes.len() as u32;
    for n in right_nodes.iter_mut().filter(|n| n.count == 0) {
        n.index += offset;
    }
    nodes.append(&mut right_nodes);
    offset
}

#[cfg(test)]
mod tests {
    use super::build_bvh_on;
    use glam::Vec3;

    /// Subtrees built on threads of their own are appended exactly where one thread puts them:
    /// a triangle soup large enough to split four ways gives the same nodes and leaf order on 1,
    /// 2 and 8 threads.
    #[test]
    fn the_tree_is_the_same_on_any_number_of_threads() {
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let triangles: Vec<[Vec3; 3]> = (0..200_000)
            .map(|_| {
                let c = Vec3::new(next(), next() * next(), next());
                [0, 1, 2].map(|_| c + Vec3::new(next(), next(), next()) * 0.01)
            })
            .collect();
        let (nodes, order) = build_bvh_on(&triangles, 1);
        let as_bytes = |n: &[super::GpuBvhNode]| bytemuck::cast_slice::<_, u8>(n).to_vec();
        // 3 and 16 threads share unevenly between a node's children
        for threads in [2, 3, 8, 16] {
            let (n, o) = build_bvh_on(&triangles, threads);
            assert_eq!(o, order, "leaf order on {threads} threads");
            assert!(
                as_bytes(&n) == as_bytes(&nodes),
                "nodes on {threads} threads"
            );
        }
        assert!(nodes.len() > 50_000);
    }
}
