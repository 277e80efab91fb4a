//! The bounding volume hierarchy the renderer's eye rays and the reference path tracer traverse
//! (reference::build_bvh, shaders/common/bvh.wgsl): every triangle in exactly one leaf, every
//! box holding what is under it, the depth within the GPU's 64-entry stack even for
//! pathological input, and CPU traversals written like the shaders' (the BVH of
//! common/bvh.wgsl, and the child pairs the renderer casts through, render.wgsl's cast_bvh, with
//! the stack its scene gets) finding the same closest triangle as testing every triangle.

use glam::Vec3;
use vlf::bvh::{bvh_pairs, BvhPairs};
use vlf::reference::{build_bvh, GpuBvhNode};

/// A tiny deterministic generator (xorshift), so failures reproduce.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn vec(&mut self) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next())
    }
}

fn intersect(origin: Vec3, dir: Vec3, t: &[Vec3; 3]) -> Option<f32> {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - t[0];
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    let d = e2.dot(q) * inv;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && d > 1e-5).then_some(d)
}

fn box_entry(n: &GpuBvhNode, origin: Vec3, inv: Vec3, t_max: f32) -> Option<f32> {
    let a = (Vec3::from(n.lo) - origin) * inv;
    let b = (Vec3::from(n.hi) - origin) * inv;
    let t0 = a.min(b).max_element();
    let t1 = a.max(b).min_element();
    (t1 >= t0.max(0.0) && t0 < t_max).then_some(t0.max(0.0))
}

/// The shader's traversal: children tested when their parent is opened, only entered ones
/// pushed (nearer on top) with their entry distance, stale entries dropped; a 64-entry stack
/// (overflow is a failure here).
fn trace(
    nodes: &[GpuBvhNode],
    order: &[u32],
    tris: &[[Vec3; 3]],
    origin: Vec3,
    dir: Vec3,
) -> Option<(f32, u32)> {
    let inv = dir.recip();
    let mut best: Option<(f32, u32)> = None;
    let t_max = |best: Option<(f32, u32)>| best.map_or(f32::INFINITY, |b| b.0);
    let root = box_entry(&nodes[0], origin, inv, f32::INFINITY)?;
    let mut stack = vec![(0u32, root)];
    while let Some((index, entry)) = stack.pop() {
        if entry >= t_max(best) {
            continue;
        }
        let node = &nodes[index as usize];
        if node.count > 0 {
            for i in node.index..node.index + node.count {
                let tri = order[i as usize];
                if let Some(t) = intersect(origin, dir, &tris[tri as usize]) {
                    if best.is_none_or(|b| t < b.0) {
                        best = Some((t, tri));
                    }
                }
            }
            continue;
        }
        let (left, right) = (index + 1, node.index);
        let tl = box_entry(&nodes[left as usize], origin, inv, t_max(best));
        let tr = box_entry(&nodes[right as usize], origin, inv, t_max(best));
        match (tl, tr) {
            (Some(l), Some(r)) if r < l => stack.extend([(left, l), (right, r)]),
            (Some(l), Some(r)) => stack.extend([(right, r), (left, l)]),
            (Some(l), None) => stack.push((left, l)),
            (None, Some(r)) => stack.push((right, r)),
            (None, None) => {}
        }
        assert!(stack.len() <= 64, "the traversal stack overflowed");
    }
    best
}

/// The renderer's traversal (render.wgsl, cast_bvh) over bvh::bvh_pairs: internal nodes in a
/// loop of their own, nearer child first, the farther one pushed with its entry distance; the
/// stack as deep as src/render/mod.rs makes it for this tree (overflow is a failure here).
fn cast_pairs(
    tree: &BvhPairs,
    order: &[u32],
    tris: &[[Vec3; 3]],
    origin: Vec3,
    dir: Vec3,
) -> Option<(f32, u32)> {
    let capacity = tree.depth.next_multiple_of(8).max(16) as usize;
    let inv = dir.recip();
    let mut best: Option<(f32, u32)> = None;
    let reach = |best: Option<(f32, u32)>| best.map_or(f32::INFINITY, |b| b.0);
    let entry = |lo: [f32; 3], hi: [f32; 3], t_max: f32| {
        box_entry(
            &GpuBvhNode {
                lo,
                hi,
                ..Default::default()
            },
            origin,
            inv,
            t_max,
        )
    };
    let mut stack: Vec<(u32, f32)> = Vec::new();
    let mut node = Some(0u32);
    while let Some(mut current) = node {
        while current & 31 == 0 {
            let p = &tree.pairs[(current >> 5) as usize];
            let tl = entry(p.lo_left, p.hi_left, reach(best));
            let tr = entry(p.lo_right, p.hi_right, reach(best));
            current = match (tl, tr) {
                (Some(l), Some(r)) => {
                    let (near, far) = if r < l {
                        (p.right, p.left)
                    } else {
                        (p.left, p.right)
                    };
                    stack.push((far, l.max(r)));
                    assert!(stack.len() <= capacity, "the traversal stack overflowed");
                    near
                }
                (Some(_), None) => p.left,
                (None, Some(_)) => p.right,
                (None, None) => u32::MAX,
            };
            if current == u32::MAX {
                break;
            }
        }
        if current != u32::MAX {
            for i in (current >> 5)..(current >> 5) + (current & 31) {
                let tri = order[i as usize];
                if let Some(t) = intersect(origin, dir, &tris[tri as usize]) {
                    if best.is_none_or(|b| t < b.0) {
                        best = Some((t, tri));
                    }
                }
            }
        }
        node = None;
        while let Some((next, t)) = stack.pop() {
            if t < reach(best) {
                node = Some(next);
                break;
            }
        }
    }
    best
}

fn check_structure(nodes: &[GpuBvhNode], order: &[u32], tris: &[[Vec3; 3]]) -> u32 {
    let mut seen = vec![0u32; tris.len()];
    let mut max_depth = 0;
    let mut stack = vec![(0u32, 0u32)];
    while let Some((index, depth)) = stack.pop() {
        max_depth = max_depth.max(depth);
        let n = &nodes[index as usize];
        let (lo, hi) = (Vec3::from(n.lo), Vec3::from(n.hi));
        let under: Vec<u32> = if n.count > 0 {
            (n.index..n.index + n.count)
                .map(|i| order[i as usize])
                .collect()
        } else {
            stack.push((index + 1, depth + 1));
            stack.push((n.index, depth + 1));
            for child in [index + 1, n.index] {
                let c = &nodes[child as usize];
                assert!(
                    Vec3::from(c.lo).cmpge(lo).all() && Vec3::from(c.hi).cmple(hi).all(),
                    "child box outside its parent"
                );
            }
            vec![]
        };
        for t in under {
            seen[t as usize] += 1;
            for p in tris[t as usize] {
                assert!(
                    p.cmpge(lo).all() && p.cmple(hi).all(),
                    "triangle outside its leaf's box"
                );
            }
        }
    }
    assert!(
        seen.iter().all(|&n| n == 1),
        "every triangle belongs to exactly one leaf"
    );
    max_depth
}

#[test]
fn a_random_soup_is_traversed_to_the_same_closest_triangle_as_brute_force() {
    let mut rng = Rng(0x9e3779b97f4a7c15);
    // small triangles scattered through a box, plus a few big walls: like a furnished room
    let mut tris: Vec<[Vec3; 3]> = (0..3000)
        .map(|_| {
            let c = rng.vec() * 10.0;
            [c, c + (rng.vec() - 0.5) * 0.6, c + (rng.vec() - 0.5) * 0.6]
        })
        .collect();
    tris.push([
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(11.0, -1.0, -1.0),
        Vec3::new(-1.0, 11.0, -1.0),
    ]);
    tris.push([
        Vec3::new(-1.0, -1.0, 11.0),
        Vec3::new(-1.0, 11.0, 11.0),
        Vec3::new(11.0, -1.0, 11.0),
    ]);
    let (nodes, order) = build_bvh(&tris);
    let depth = check_structure(&nodes, &order, &tris);
    println!("{} nodes, depth {depth}", nodes.len());
    let tree = bvh_pairs(&nodes).unwrap();
    assert_eq!(tree.depth, depth, "the pairs' depth is the tree's");
    assert!(tree
        .pairs
        .iter()
        .all(|p| [p.left, p.right].iter().all(|&r| r & 31 <= 16)));
    let mut hits = 0;
    for _ in 0..4000 {
        let origin = rng.vec() * 12.0 - 1.0;
        let dir = (rng.vec() - 0.5).normalize();
        let brute = tris
            .iter()
            .enumerate()
            .filter_map(|(i, t)| intersect(origin, dir, t).map(|d| (d, i as u32)))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let bvh = trace(&nodes, &order, &tris, origin, dir);
        assert_eq!(
            bvh.map(|b| b.1),
            brute.map(|b| b.1),
            "ray from {origin} along {dir}"
        );
        let pairs = cast_pairs(&tree, &order, &tris, origin, dir);
        assert_eq!(
            pairs.map(|b| b.1),
            brute.map(|b| b.1),
            "pairs: ray from {origin} along {dir}"
        );
        hits += brute.is_some() as u32;
    }
    assert!(hits > 1000, "too few rays hit anything to test: {hits}");
}

#[test]
fn pathological_input_stays_within_the_traversal_stack() {
    // exponentially spaced slivers along one axis invite a chain of one-sided area splits
    let tris: Vec<[Vec3; 3]> = (0..20_000)
        .map(|i| {
            let x = 1.0005f32.powi(i);
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
                Vec3::new(x, 0.0, 1.0),
            ]
        })
        .collect();
    let (nodes, order) = build_bvh(&tris);
    let depth = check_structure(&nodes, &order, &tris);
    assert!(
        depth < 60,
        "depth {depth}: the GPU traversal keeps at most 64 entries"
    );
    // and 10,000 copies of one triangle: halved down to leaves of at most 16 (a leaf's count
    // has 5 bits in the renderer's pairs), not an endless split
    let same = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 10_000];
    let (nodes, order) = build_bvh(&same);
    let depth = check_structure(&nodes, &order, &same);
    assert!(
        nodes.iter().all(|n| n.count <= 16) && depth <= 12,
        "depth {depth}"
    );
    let tree = bvh_pairs(&nodes).unwrap();
    let hit = cast_pairs(&tree, &order, &same, Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
    assert_eq!(hit.map(|h| h.0), Some(1.0));
}

/// The renderer's eye rays through the BVH see what testing every triangle sees: the generated
/// classroom (about 1,100 triangles) rendered both ways on the GPU
/// (`vlf::render::with_exhaustive_triangles`).
#[cfg(feature = "lab")] // the classroom comes from the lab's generator
#[test]
fn eye_rays_through_the_bvh_see_what_exhaustive_rays_see() {
    let dir = tempfile::tempdir().unwrap();
    let options = vlf::lab::generate::GenerateOptions {
        kind: vlf::lab::generate::SceneKind::Classroom,
        size: 1000,
        mirrors: true,
        glossy: false,
    };
    let generated = vlf::lab::generate::generate(&options, dir.path()).unwrap();
    let scene = vlf::scene::Scene::load(&generated.scene).unwrap();
    let params = vlf::propagate::PropagationParams {
        geodesic_frequency: 4,
        grid_resolution: 32,
        tile_size: 8,
        texel_density: 4.0,
        tolerance: 1e-2,
        max_iterations: 20,
        perturb: 1,
        accelerate: true,
        memory_budget_mib: None,
        direct_samples: 16,
        mirror_direct: false,
        rim_rays: false,
    };
    let ctx = vlf::gpu::GpuContext::new().expect(
        "a GPU adapter (on a machine without one: sudo apt-get install mesa-vulkan-drivers)",
    );
    let (lf, resident, _) =
        vlf::propagate::propagate(ctx, &scene, &params, &vlf::progress::Silent).unwrap();
    let render = |threshold: usize| {
        let mut renderer = vlf::render::with_exhaustive_triangles(threshold, || {
            vlf::render::Renderer::new(&resident, &lf, &vlf::gpu::MemoryLedger::default())
        })
        .unwrap();
        lf.meta
            .cameras
            .iter()
            .map(|c| renderer.render(c, 96, 72).unwrap())
            .collect::<Vec<_>>()
    };
    let (bvh, exhaustive) = (render(0), render(usize::MAX));
    assert!(generated.triangles > 256 && !bvh.is_empty());
    for (a, b) in bvh.iter().zip(&exhaustive) {
        let pixels = a.pixels.len();
        let differ = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(x, y)| {
                x.iter()
                    .zip(y.iter())
                    .any(|(p, q)| (p - q).abs() > 1e-5 * q.abs().max(1e-3))
            })
            .count();
        let lit = a
            .pixels
            .iter()
            .filter(|p| p.iter().any(|v| *v > 0.0))
            .count();
        println!("{differ} of {pixels} pixels differ, {lit} lit");
        assert!(
            lit > pixels / 4,
            "the view shows too little of the room to compare: {lit} of {pixels} lit"
        );
        assert_eq!(
            differ, 0,
            "the BVH's eye rays found other surfaces than exhaustive rays"
        );
    }
}
