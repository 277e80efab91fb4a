// Up to four rays through the BVH of common/bvh.wgsl together (render.wgsl: the eye rays of one
// pixel's samples, the reflections of its sample pairs). The rays are nearly the same, so they
// open nearly the same nodes: each node and each triangle is read once for all of them, and the
// loop's branches are taken once, where four separate traversals would do all of it four times.
// Every ray gets exactly the hit `trace` would give it (the same tests, the same tie rule); a
// node is skipped only when every ray has a hit nearer than where the first of them enters it.
// Needs common/bvh.wgsl before it.

const PACKET: u32 = 4u;

struct Rays {
    origin: array<vec3<f32>, 4>,
    dir: array<vec3<f32>, 4>,
    // rays in use (1..4); the others are ignored
    count: u32,
}

// The nearest entry into the box among the rays that enter it before their own hit (1e30: none).
fn packet_box_entry(lo: vec3<f32>, hi: vec3<f32>, rays: Rays, inv: array<vec3<f32>, 4>, hits: array<Hit, 4>) -> f32 {
    var entry = 1e30;
    for (var k = 0u; k < PACKET; k++) {
        if k < rays.count {
            let t = box_entry(lo, hi, rays.origin[k], inv[k], hits[k].t * TIE);
            entry = select(entry, min(entry, t), t >= 0.0);
        }
    }
    return entry;
}

fn trace_packet(rays: Rays) -> array<Hit, 4> {
    var hits: array<Hit, 4>;
    var inv: array<vec3<f32>, 4>;
    for (var k = 0u; k < PACKET; k++) {
        hits[k] = Hit(1e30, NO_FACE, 0.0, 0.0);
        let d = rays.dir[k];
        inv[k] = 1.0 / select(d, vec3<f32>(1e-20), abs(d) < vec3<f32>(1e-20));
    }
    let root = packet_box_entry(nodes[0].lo, nodes[0].hi, rays, inv, hits);
    if root >= 1e30 {
        return hits;
    }
    var stack: array<u32, 64>;
    var entry: array<f32, 64>;
    var top = 1u;
    stack[0] = 0u;
    entry[0] = root;
    while top > 0u {
        top -= 1u;
        // the farthest hit so far: a node entered beyond it holds nothing nearer for any ray
        var farthest = 0.0;
        for (var k = 0u; k < PACKET; k++) {
            farthest = select(farthest, max(farthest, hits[k].t), k < rays.count);
        }
        if entry[top] >= farthest * TIE {
            continue;
        }
        let index = stack[top];
        let node = nodes[index];
        if node.count > 0u {
            for (var i = node.index; i < node.index + node.count; i++) {
                let tri = triangles[i];
                for (var k = 0u; k < PACKET; k++) {
                    if k < rays.count {
                        let r = intersect(rays.origin[k], rays.dir[k], tri, hits[k].t * TIE);
                        if closer(r.x, i, hits[k]) {
                            hits[k] = Hit(r.x, i, r.y, r.z);
                        }
                    }
                }
            }
            continue;
        }
        let left = nodes[index + 1u];
        let right = nodes[node.index];
        let t_left = packet_box_entry(left.lo, left.hi, rays, inv, hits);
        let t_right = packet_box_entry(right.lo, right.hi, rays, inv, hits);
        let enter_left = t_left < 1e30;
        let enter_right = t_right < 1e30;
        if enter_left && enter_right {
            if top + 2u <= 64u {
                let right_first = t_right < t_left;
                stack[top] = select(node.index, index + 1u, right_first);
                entry[top] = select(t_right, t_left, right_first);
                stack[top + 1u] = select(index + 1u, node.index, right_first);
                entry[top + 1u] = select(t_left, t_right, right_first);
                top += 2u;
            }
        } else if (enter_left || enter_right) && top < 64u {
            stack[top] = select(node.index, index + 1u, enter_left);
            entry[top] = min(t_left, t_right);
            top += 1u;
        }
    }
    return hits;
}
