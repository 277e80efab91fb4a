#!/usr/bin/env python3
"""Writes assets/avatar/mannequin.glb: vlf's shipped avatar, a gender-neutral low-poly
mannequin 1.75 m tall with one skin (a humanoid skeleton of 19 joints), smooth per-vertex
normals, smooth JOINTS_0/WEIGHTS_0 and three plain materials (skin, shirt, trousers).
Standard library only; the bytes are deterministic (the tests regenerate and compare them).

    python3 tools/make-avatar.py [OUT.glb] [--names mixamo]

Model space: +y up, facing +z (glTF's convention, so the character's left is +x), feet at
y = 0, bind pose a T-pose. `--names mixamo` writes the same figure with Mixamo's joint names
(mixamorig:Hips, mixamorig:LeftArm, ...), which the tests use to check the loader's aliases.
"""
import json
import math
import os
import struct
import sys

# joint: (parent, position in model space, metres). Left is +x.
JOINTS = [
    ("hips", None, (0.0, 0.95, 0.0)),
    ("spine", "hips", (0.0, 1.06, 0.0)),
    ("chest", "spine", (0.0, 1.22, 0.0)),
    ("neck", "chest", (0.0, 1.45, 0.0)),
    ("head", "neck", (0.0, 1.55, 0.0)),
]
for side, sx in (("l", 1.0), ("r", -1.0)):
    JOINTS += [
        (f"shoulder_{side}", "chest", (0.04 * sx, 1.41, 0.0)),
        (f"upper_arm_{side}", f"shoulder_{side}", (0.17 * sx, 1.41, 0.0)),
        (f"forearm_{side}", f"upper_arm_{side}", (0.45 * sx, 1.41, 0.0)),
        (f"hand_{side}", f"forearm_{side}", (0.70 * sx, 1.41, 0.0)),
        (f"thigh_{side}", "hips", (0.09 * sx, 0.93, 0.0)),
        (f"shin_{side}", f"thigh_{side}", (0.09 * sx, 0.51, 0.0)),
        (f"foot_{side}", f"shin_{side}", (0.09 * sx, 0.08, 0.0)),
    ]
INDEX = {name: i for i, (name, _, _) in enumerate(JOINTS)}
POS = {name: p for name, _, p in JOINTS}

MIXAMO = {"hips": "Hips", "spine": "Spine", "chest": "Spine2", "neck": "Neck", "head": "Head"}
for side, word in (("l", "Left"), ("r", "Right")):
    MIXAMO.update({f"shoulder_{side}": f"{word}Shoulder", f"upper_arm_{side}": f"{word}Arm",
                   f"forearm_{side}": f"{word}ForeArm", f"hand_{side}": f"{word}Hand",
                   f"thigh_{side}": f"{word}UpLeg", f"shin_{side}": f"{word}Leg",
                   f"foot_{side}": f"{word}Foot"})

# material: name, linear base colour
MATERIALS = [("skin", (0.62, 0.42, 0.31)), ("shirt", (0.16, 0.30, 0.52)),
             ("trousers", (0.13, 0.13, 0.15))]


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def scale(a, s):
    return tuple(x * s for x in a)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a):
    return scale(a, 1.0 / math.sqrt(dot(a, a)))


def capsule(a, b, radii, side, segments, cap_rings, body_rings):
    """A capsule from a to b (its caps' tips at a and b): radii (across `side`, along the
    axis for the caps, across the third direction). Vertices with outward normals, and
    triangles as vertex-index triples."""
    rx, ry, rz = radii
    u = unit(sub(b, a))
    length = math.sqrt(dot(sub(b, a), sub(b, a)))
    half = max(length / 2.0 - ry, 0.0)
    centre = scale(add(a, b), 0.5)
    v = unit(sub(side, scale(u, dot(side, u))))
    w = cross(v, u)
    rings = [(-half, -90.0 + 90.0 * k / cap_rings) for k in range(cap_rings + 1)]
    if half > 0.0:
        rings += [(-half + 2.0 * half * k / body_rings, 0.0) for k in range(1, body_rings)]
        rings += [(half, 90.0 * k / cap_rings) for k in range(cap_rings + 1)]
    else:
        rings += [(0.0, 90.0 * k / cap_rings) for k in range(1, cap_rings + 1)]
    verts, ring_start = [], []
    for y0, lat in rings:
        phi = math.radians(lat)
        n_around = 1 if abs(lat) == 90.0 else segments
        ring_start.append((len(verts), n_around))
        for s in range(n_around):
            th = 2.0 * math.pi * s / segments
            c, sn = math.cos(phi), math.sin(phi)
            local = (rx * c * math.cos(th), y0 + ry * sn, rz * c * math.sin(th))
            grad = (c * math.cos(th) / rx, sn / ry, c * math.sin(th) / rz)
            p = add(centre, add(add(scale(v, local[0]), scale(u, local[1])), scale(w, local[2])))
            n = unit(add(add(scale(v, grad[0]), scale(u, grad[1])), scale(w, grad[2])))
            verts.append((p, n))
    tris = []
    for (s0, n0), (s1, n1) in zip(ring_start, ring_start[1:]):
        for k in range(segments):
            a0, a1 = s0 + k % n0, s0 + (k + 1) % n0
            b0, b1 = s1 + k % n1, s1 + (k + 1) % n1
            if n0 > 1:
                tris.append((a0, a1, b0))
            if n1 > 1:
                tris.append((a1, b1, b0))
    return verts, tris


def chain_weights(p, a, chain, blend):
    """Weights along a part's axis: chain is [(joint, point)], each joint owning the axis from
    its point to the next one's; a linear blend `blend` metres either side of each boundary."""
    u = unit(sub(chain[-1][1], chain[0][1])) if len(chain) > 1 else (0.0, 1.0, 0.0)
    s = dot(sub(p, a), u)
    bounds = [dot(sub(q, a), u) for _, q in chain]
    w = {chain[0][0]: 1.0}
    for k in range(1, len(chain)):
        t = min(max((s - bounds[k]) / (2.0 * blend) + 0.5, 0.0), 1.0)
        if t <= 0.0:
            break
        prev = chain[k - 1][0]
        w = {j: x * (1.0 - t) for j, x in w.items() if j != prev}
        w[prev] = 1.0 - t
        w[chain[k][0]] = t
        w = {j: x for j, x in w.items() if x > 0.0}
    return w


def parts():
    """(material, capsule end a, end b, radii, side, segments, cap rings, body rings, chain, blend)"""
    y, out = (0.0, 1.0, 0.0), []
    j = lambda *names: [(n, POS[n]) for n in names]
    out.append(("skin", (0.0, 1.535, 0.015), (0.0, 1.75, 0.015), (0.085, 0.1075, 0.1),
                (1.0, 0.0, 0.0), 16, 6, 2, j("neck", "head"), 0.02))
    out.append(("skin", (0.0, 1.38, 0.0), (0.0, 1.60, 0.0), (0.05, 0.05, 0.05),
                (1.0, 0.0, 0.0), 12, 3, 4, j("chest", "neck", "head"), 0.03))
    out.append(("shirt", (0.0, 0.98, 0.0), (0.0, 1.47, 0.0), (0.165, 0.10, 0.105),
                (1.0, 0.0, 0.0), 16, 4, 6, j("hips", "spine", "chest"), 0.05))
    out.append(("trousers", (0.0, 0.82, 0.0), (0.0, 1.06, 0.0), (0.155, 0.09, 0.105),
                (1.0, 0.0, 0.0), 16, 4, 2, j("hips"), 0.05))
    for sd, sx in (("l", 1.0), ("r", -1.0)):
        n = lambda name: f"{name}_{sd}"
        out.append(("shirt", (0.02 * sx, 1.41, 0.0), (0.21 * sx, 1.41, 0.0), (0.055, 0.05, 0.055),
                    y, 12, 3, 2, j("chest", n("shoulder"), n("upper_arm")), 0.03))
        out.append(("shirt", (0.15 * sx, 1.41, 0.0), (0.48 * sx, 1.41, 0.0), (0.046, 0.046, 0.046),
                    y, 12, 3, 6, j(n("shoulder"), n("upper_arm"), n("forearm")), 0.04))
        out.append(("skin", (0.42 * sx, 1.41, 0.0), (0.72 * sx, 1.41, 0.0), (0.038, 0.038, 0.038),
                    y, 12, 3, 6, j(n("upper_arm"), n("forearm"), n("hand")), 0.04))
        out.append(("skin", (0.68 * sx, 1.41, 0.0), (0.88 * sx, 1.41, 0.0), (0.022, 0.05, 0.045),
                    y, 12, 3, 2, j(n("forearm"), n("hand")), 0.02))
        out.append(("trousers", (0.09 * sx, 1.00, 0.0), (0.09 * sx, 0.48, 0.0), (0.075, 0.075, 0.075),
                    (1.0, 0.0, 0.0), 12, 3, 6, j("hips", n("thigh"), n("shin")), 0.05))
        out.append(("trousers", (0.09 * sx, 0.54, 0.0), (0.09 * sx, 0.05, 0.0), (0.055, 0.055, 0.055),
                    (1.0, 0.0, 0.0), 12, 3, 6, j(n("thigh"), n("shin"), n("foot")), 0.05))
        out.append(("skin", (0.09 * sx, 0.04, -0.06), (0.09 * sx, 0.04, 0.19), (0.045, 0.05, 0.04),
                    (1.0, 0.0, 0.0), 12, 3, 2, j(n("foot")), 0.02))
    return out


def build():
    """Vertices (position, normal, joints, weights) and per-material triangle lists."""
    verts, tris = [], {m: [] for m, _ in MATERIALS}
    for mat, a, b, radii, side, seg, cap, body, chain, blend in parts():
        pv, pt = capsule(a, b, radii, side, seg, cap, body)
        base = len(verts)
        for p, n in pv:
            p = tuple(round(c, 6) for c in p)
            n = tuple(round(c, 6) for c in n)
            w = sorted(chain_weights(p, a, chain, blend).items(), key=lambda kv: (-kv[1], INDEX[kv[0]]))[:4]
            total = sum(x for _, x in w)
            ids = [INDEX[name] for name, _ in w] + [0] * (4 - len(w))
            ws = [round(x / total, 6) for _, x in w] + [0.0] * (4 - len(w))
            verts.append((p, n, ids, ws))
        for t in pt:
            t = tuple(base + i for i in t)
            (p0, n0, _, _), (p1, n1, _, _), (p2, n2, _, _) = (verts[i] for i in t)
            if dot(cross(sub(p1, p0), sub(p2, p0)), add(add(n0, n1), n2)) < 0.0:
                t = (t[0], t[2], t[1])
            tris[mat].append(t)
    return verts, tris


def glb(names):
    verts, tris = build()
    blob = bytearray()
    views, accessors = [], []

    def add_view(data, target=None):
        while len(blob) % 4:
            blob.append(0)
        view = {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)}
        if target:
            view["target"] = target
        blob.extend(data)
        views.append(view)
        return len(views) - 1

    def add_accessor(fmt, rows, ctype, kind, target=None, minmax=False):
        data = b"".join(struct.pack("<" + fmt, *r) for r in rows)
        acc = {"bufferView": add_view(data, target), "componentType": ctype,
               "count": len(rows), "type": kind}
        if minmax:
            acc["min"] = [min(r[k] for r in rows) for k in range(len(rows[0]))]
            acc["max"] = [max(r[k] for r in rows) for k in range(len(rows[0]))]
            acc["min"] = [struct.unpack("<f", struct.pack("<f", x))[0] for x in acc["min"]]
            acc["max"] = [struct.unpack("<f", struct.pack("<f", x))[0] for x in acc["max"]]
        accessors.append(acc)
        return len(accessors) - 1

    position = add_accessor("3f", [v[0] for v in verts], 5126, "VEC3", 34962, True)
    normal = add_accessor("3f", [v[1] for v in verts], 5126, "VEC3", 34962)
    joints = add_accessor("4H", [v[2] for v in verts], 5123, "VEC4", 34962)
    weights = add_accessor("4f", [v[3] for v in verts], 5126, "VEC4", 34962)
    prims = []
    for m, (mat, _) in enumerate(MATERIALS):
        idx = add_accessor("3H", tris[mat], 5123, "SCALAR", 34963)
        accessors[idx]["count"] *= 3
        prims.append({"attributes": {"POSITION": position, "NORMAL": normal, "JOINTS_0": joints,
                                     "WEIGHTS_0": weights}, "indices": idx, "material": m})
    ibm = [(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -p[0], -p[1], -p[2], 1) for _, _, p in JOINTS]
    ibm_acc = add_accessor("16f", ibm, 5126, "MAT4")
    nodes = [{"name": "mannequin", "mesh": 0, "skin": 0}]
    for name, parent, p in JOINTS:
        rel = sub(p, POS[parent]) if parent else p
        node = {"name": names[name], "translation": [round(c, 6) for c in rel]}
        kids = [1 + i for i, (_, par, _) in enumerate(JOINTS) if par == name]
        if kids:
            node["children"] = kids
        nodes.append(node)
    doc = {
        "asset": {"version": "2.0", "generator": "vlf tools/make-avatar.py",
                  "copyright": "CC0 1.0 (public domain dedication), the vlf authors"},
        "scene": 0,
        "scenes": [{"name": "avatar", "nodes": [0, 1]}],
        "nodes": nodes,
        "meshes": [{"name": "mannequin", "primitives": prims}],
        "skins": [{"name": "humanoid", "joints": [1 + i for i in range(len(JOINTS))],
                   "inverseBindMatrices": ibm_acc, "skeleton": 1}],
        "materials": [{"name": n, "pbrMetallicRoughness": {"baseColorFactor": list(c) + [1.0],
                       "metallicFactor": 0.0, "roughnessFactor": 1.0}} for n, c in MATERIALS],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": 0}],
    }
    while len(blob) % 4:
        blob.append(0)
    doc["buffers"][0]["byteLength"] = len(blob)
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    out = struct.pack("<4sII", b"glTF", 2, total)
    out += struct.pack("<I4s", len(js), b"JSON") + js
    out += struct.pack("<I4s", len(blob), b"BIN\0") + bytes(blob)
    return out, len(verts), sum(len(t) for t in tris.values())


def main(argv):
    mixamo = "--names" in argv and argv[argv.index("--names") + 1] == "mixamo"
    rest = [a for i, a in enumerate(argv) if a != "--names" and (i == 0 or argv[i - 1] != "--names")]
    default = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "assets", "avatar", "mannequin.glb")
    out_path = rest[0] if rest else default
    names = {n: ("mixamorig:" + MIXAMO[n] if mixamo else n) for n, _, _ in JOINTS}
    data, nv, nt = glb(names)
    os.makedirs(os.path.dirname(os.path.abspath(out_path)), exist_ok=True)
    with open(out_path, "wb") as f:
        f.write(data)
    print(f"{out_path}: {len(JOINTS)} joints, {nv} vertices, {nt} triangles, {len(data)} bytes")


if __name__ == "__main__":
    main(sys.argv[1:])
