#!/usr/bin/env python3
"""Convert a Mitsuba 0.6 scene (scene.xml + OBJ shapes + bitmap textures), as Benedikt
Bitterli's rendering resources ship them, into one glTF 2.0 model for vlf.

    python3 tools/models/mitsuba2gltf.py SRC_DIR/scene.xml OUT_DIR [--drop-dielectric]
        [--cutouts] [--max-extent METRES]

Writes OUT_DIR/model.gltf + model.bin (+ the textures it uses, copied) and prints the first
sensor as a vlf [[camera]] (eye, target, up, vertical fov) for the scene.toml. Only Python 3's
standard library is needed.

Rules (what the light field can hold, see README "glTF models"):
- one glTF mesh primitive per Mitsuba BSDF id (material name = the id; anonymous BSDFs get
  `bsdf<i>`); `twosided` -> doubleSided; `mask`/`bumpmap` -> their inner BSDF;
- --cutouts: a `mask` whose opacity is a bitmap that is also its inner BSDF's colour texture
  (leaves, as Bitterli's scenes make them) -> alphaMode MASK, alphaCutoff 0.5 (the texture's
  alpha is the coverage, as in glTF); any other mask stays opaque, said on stderr. Without it
  every mask is opaque (what the accuracy suite's Mitsuba references, which treat alpha as
  opaque, were made with);
- diffuse/roughdiffuse `reflectance`, plastic/roughplastic `diffuseReflectance` -> baseColor
  (rgb factor, or a bitmap texture: PNG/JPEG only), metallic 0;
- conductor/roughconductor -> metallic 1, roughness 0.5 (vlf: diffuse of the base colour; a
  smooth one would become an ideal mirror), base colour its specularReflectance or 0.6 grey;
- --max-extent M leaves out shapes wider than M (e.g. a ground plane far beyond the building,
  which would make vlf's normalised grid coarse over the rooms);
- dielectric/thindielectric (window panes, glass) -> left out with --drop-dielectric (vlf makes
  glass opaque, which would shut the sky out), else a white diffuse;
- an `area` emitter on a shape -> emissiveFactor x KHR_materials_emissive_strength;
- shapes: `obj` (world transform applied, polygons cut into fans) and `rectangle`; others are
  skipped with a message. Sky emitters (sunsky, envmap) are not converted: give [sky] radiance.
"""
import json
import math
import os
import shutil
import struct
import sys
import xml.etree.ElementTree as ET


def floats(s):
    return [float(x) for x in s.replace(",", " ").split()]


def matrix_of(node):
    """The 4x4 row-major toWorld of a shape or sensor (matrix/lookat/translate/scale/rotate)."""
    m = [[1.0 if i == j else 0.0 for j in range(4)] for i in range(4)]
    t = None
    for c in node:
        if c.tag == "transform" and c.get("name") in ("toWorld", "to_world"):
            t = c
    if t is None:
        return m

    def mul(a, b):
        return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]

    for op in t:
        if op.tag == "matrix":
            v = floats(op.get("value"))
            o = [v[0:4], v[4:8], v[8:12], v[12:16]]
        elif op.tag == "translate":
            o = [[1, 0, 0, float(op.get("x", 0))], [0, 1, 0, float(op.get("y", 0))],
                 [0, 0, 1, float(op.get("z", 0))], [0, 0, 0, 1]]
        elif op.tag == "scale":
            if op.get("value"):
                sx = sy = sz = float(op.get("value"))
            else:
                sx, sy, sz = (float(op.get(k, 1)) for k in "xyz")
            o = [[sx, 0, 0, 0], [0, sy, 0, 0], [0, 0, sz, 0], [0, 0, 0, 1]]
        elif op.tag == "lookat":
            eye = floats(op.get("origin"))
            tgt = floats(op.get("target"))
            up = floats(op.get("up", "0 1 0"))
            d = norm(sub(tgt, eye))
            left = norm(cross(up, d))
            nup = cross(d, left)
            o = [[left[0], nup[0], d[0], eye[0]], [left[1], nup[1], d[1], eye[1]],
                 [left[2], nup[2], d[2], eye[2]], [0, 0, 0, 1]]
        else:
            print(f"mitsuba2gltf: transform op <{op.tag}> not handled: ignored", file=sys.stderr)
            continue
        m = mul(o, m)
    return m


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    n = math.sqrt(sum(x * x for x in a)) or 1.0
    return [x / n for x in a]


def xform(m, p):
    return [m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] for i in range(3)]


def det3(m):
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))


def read_obj(path):
    """Positions, texture coordinates and triangles [(vi, ti), x3] of an OBJ (fans)."""
    vs, vts, tris = [], [], []
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("v "):
                vs.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("vt "):
                p = line.split()[1:3]
                vts.append([float(p[0]), float(p[1]) if len(p) > 1 else 0.0])
            elif line.startswith("f "):
                corners = []
                for c in line.split()[1:]:
                    parts = c.split("/")
                    vi = int(parts[0])
                    vi = vi - 1 if vi > 0 else len(vs) + vi
                    ti = None
                    if len(parts) > 1 and parts[1]:
                        ti = int(parts[1])
                        ti = ti - 1 if ti > 0 else len(vts) + ti
                    corners.append((vi, ti))
                for k in range(1, len(corners) - 1):
                    tris.append((corners[0], corners[k], corners[k + 1]))
    return vs, vts, tris


class Material:
    def __init__(self, name):
        self.name = name
        self.color = [0.5, 0.5, 0.5]
        self.texture = None
        self.metallic = 0.0
        self.double_sided = False
        self.emission = None
        self.dielectric = False
        # the opacity bitmap of a `mask` around the BSDF, if it has one
        self.opacity = None


def spectrum(node, names):
    """(rgb or None, texture filename or None) of the first child named in names."""
    for c in node:
        if c.get("name") not in names:
            continue
        if c.tag in ("rgb", "srgb", "spectrum"):
            v = floats(c.get("value"))
            if len(v) == 1:
                v = v * 3
            return v[:3], None
        if c.tag == "float":
            return [float(c.get("value"))] * 3, None
        if c.tag == "texture" and c.get("type") == "bitmap":
            for s in c:
                if s.get("name") == "filename":
                    return None, s.get("value")
    return None, None


def material_of(bsdf, name):
    m = Material(name)
    node = bsdf
    while True:
        t = node.get("type")
        if t == "twosided":
            m.double_sided = True
        if t == "mask":
            _, m.opacity = spectrum(node, ("opacity",))
        if t in ("twosided", "mask", "bumpmap", "blendbsdf"):
            inner = node.find("bsdf")
            if inner is None:
                break
            node = inner
            continue
        break
    t = node.get("type")
    if t in ("diffuse", "roughdiffuse"):
        rgb, tex = spectrum(node, ("reflectance",))
    elif t in ("plastic", "roughplastic"):
        rgb, tex = spectrum(node, ("diffuseReflectance", "diffuse_reflectance"))
    elif t in ("conductor", "roughconductor"):
        rgb, tex = spectrum(node, ("specularReflectance", "specular_reflectance"))
        m.metallic = 1.0
        if rgb is None and tex is None:
            rgb = [0.6, 0.6, 0.6]
    elif t in ("dielectric", "thindielectric", "roughdielectric"):
        m.dielectric = True
        rgb, tex = [1.0, 1.0, 1.0], None
    else:
        print(f"mitsuba2gltf: BSDF {name!r} of type {t!r}: grey 0.5", file=sys.stderr)
        rgb, tex = None, None
    if rgb is None and tex is None:
        rgb = [0.5, 0.5, 0.5]
    if rgb is not None:
        m.color = [min(max(x, 0.0), 1.0) for x in rgb]
    else:
        m.color = [1.0, 1.0, 1.0]
        m.texture = tex
    return m


def main():
    argv = sys.argv[1:]
    max_extent = None
    if "--max-extent" in argv:
        i = argv.index("--max-extent")
        max_extent = float(argv[i + 1])
        del argv[i:i + 2]
    args = [a for a in argv if not a.startswith("--")]
    drop_dielectric = "--drop-dielectric" in argv
    cutouts = "--cutouts" in argv
    if len(args) != 2:
        sys.exit(__doc__)
    xml_path, out = args
    src = os.path.dirname(os.path.abspath(xml_path))
    root = ET.parse(xml_path).getroot()
    os.makedirs(out, exist_ok=True)

    materials = {}
    for b in root.findall("bsdf"):
        if b.get("id"):
            materials[b.get("id")] = material_of(b, b.get("id"))

    groups = {}  # material name -> (material, positions, uvs, indices)
    anon = 0
    skipped = {}
    for shape in root.findall("shape"):
        kind = shape.get("type")
        mat = None
        ref = shape.find("ref")
        if ref is not None:
            mat = materials.get(ref.get("id"))
        b = shape.find("bsdf")
        if b is not None:
            mat = material_of(b, b.get("id") or f"bsdf{anon}")
            anon += 1
        if mat is None:
            mat = Material("default")
        em = shape.find("emitter")
        if em is not None and em.get("type") == "area":
            rgb, _ = spectrum(em, ("radiance",))
            if rgb:
                mat = Material(mat.name + "_emitter")
                mat.color = [0.0, 0.0, 0.0]
                mat.emission = rgb
        if mat.dielectric and drop_dielectric:
            skipped[mat.name] = skipped.get(mat.name, 0) + 1
            continue
        m = matrix_of(shape)
        if kind == "obj":
            fn = next(s.get("value") for s in shape if s.get("name") == "filename")
            vs, vts, tris = read_obj(os.path.join(src, fn))
        elif kind == "rectangle":
            vs = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]
            vts = [[0, 0], [1, 0], [1, 1], [0, 1]]
            tris = [((0, 0), (1, 1), (2, 2)), ((0, 0), (2, 2), (3, 3))]
        else:
            print(f"mitsuba2gltf: shape type {kind!r} skipped", file=sys.stderr)
            continue
        if max_extent is not None:
            w = [xform(m, p) for p in vs]
            ext = max(max(p[i] for p in w) - min(p[i] for p in w) for i in range(3))
            if ext > max_extent:
                print(f"mitsuba2gltf: a {kind} shape of {mat.name!r} ({ext:.1f} wide) left out",
                      file=sys.stderr)
                continue
        flip = det3(m) < 0
        g = groups.setdefault(mat.name, (mat, [], [], []))
        _, pos, uv, idx = g
        wv = [xform(m, p) for p in vs]
        remap = {}
        for tri in tris:
            corners = tri[::-1] if flip else tri
            for vi, ti in corners:
                key = (vi, ti)
                k = remap.get(key)
                if k is None:
                    k = len(pos)
                    remap[key] = k
                    pos.append(wv[vi])
                    t = vts[ti] if ti is not None and ti < len(vts) else [0.0, 0.0]
                    uv.append([t[0], 1.0 - t[1]])
                idx.append(k)
    for name, n in skipped.items():
        print(f"mitsuba2gltf: {n} dielectric shape(s) of {name!r} left out", file=sys.stderr)

    # glTF
    blob = bytearray()
    views, accessors, meshes_prims, gl_materials, images, textures = [], [], [], [], [], []
    tex_index = {}

    def add_view(data, target):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data),
                      "target": target})
        blob.extend(data)
        return len(views) - 1

    tri_total = 0
    for name, (mat, pos, uv, idx) in groups.items():
        if not idx:
            continue
        mi = len(gl_materials)
        pbr = {"baseColorFactor": mat.color + [1.0], "metallicFactor": mat.metallic,
               "roughnessFactor": 0.5 if mat.metallic else 1.0}
        if mat.texture:
            ext = os.path.splitext(mat.texture)[1].lower()
            if ext in (".png", ".jpg", ".jpeg"):
                if mat.texture not in tex_index:
                    dst = os.path.join("textures", os.path.basename(mat.texture))
                    os.makedirs(os.path.join(out, "textures"), exist_ok=True)
                    shutil.copyfile(os.path.join(src, mat.texture), os.path.join(out, dst))
                    images.append({"uri": dst.replace(os.sep, "/")})
                    textures.append({"source": len(images) - 1})
                    tex_index[mat.texture] = len(textures) - 1
                pbr["baseColorTexture"] = {"index": tex_index[mat.texture]}
            else:
                print(f"mitsuba2gltf: texture {mat.texture} ({name}) not PNG/JPEG: 0.5 grey",
                      file=sys.stderr)
                pbr["baseColorFactor"] = [0.5, 0.5, 0.5, 1.0]
        gm = {"name": name, "pbrMetallicRoughness": pbr, "doubleSided": mat.double_sided}
        if cutouts and mat.opacity:
            if mat.opacity == mat.texture and "baseColorTexture" in pbr:
                gm["alphaMode"] = "MASK"
                gm["alphaCutoff"] = 0.5
            else:
                print(f"mitsuba2gltf: mask of {name!r}: its opacity {mat.opacity} is not its "
                      "colour texture; left opaque", file=sys.stderr)
        if mat.emission:
            peak = max(mat.emission)
            gm["emissiveFactor"] = [x / peak for x in mat.emission]
            gm["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": peak}}
        gl_materials.append(gm)
        pdata = b"".join(struct.pack("<3f", *p) for p in pos)
        udata = b"".join(struct.pack("<2f", *t) for t in uv)
        idata = struct.pack(f"<{len(idx)}I", *idx)
        lo = [min(p[i] for p in pos) for i in range(3)]
        hi = [max(p[i] for p in pos) for i in range(3)]
        a0 = len(accessors)
        accessors.append({"bufferView": add_view(pdata, 34962), "componentType": 5126,
                          "count": len(pos), "type": "VEC3", "min": lo, "max": hi})
        accessors.append({"bufferView": add_view(udata, 34962), "componentType": 5126,
                          "count": len(uv), "type": "VEC2"})
        accessors.append({"bufferView": add_view(idata, 34963), "componentType": 5125,
                          "count": len(idx), "type": "SCALAR"})
        meshes_prims.append({"name": name, "primitives": [{
            "attributes": {"POSITION": a0, "TEXCOORD_0": a0 + 1}, "indices": a0 + 2,
            "material": mi}]})
        tri_total += len(idx) // 3
    with open(os.path.join(out, "model.bin"), "wb") as f:
        f.write(blob)
    doc = {
        "asset": {"version": "2.0", "generator": "vlf tools/models/mitsuba2gltf.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(meshes_prims)))}],
        "nodes": [{"mesh": i, "name": m["name"]} for i, m in enumerate(meshes_prims)],
        "meshes": meshes_prims,
        "materials": gl_materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": "model.bin", "byteLength": len(blob)}],
    }
    if images:
        doc["images"] = images
        doc["textures"] = textures
    if any("extensions" in m for m in gl_materials):
        doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
    with open(os.path.join(out, "model.gltf"), "w") as f:
        json.dump(doc, f, indent=1)
    print(f"mitsuba2gltf: {out}/model.gltf: {tri_total} triangles, {len(gl_materials)} materials",
          file=sys.stderr)

    sensor = root.find("sensor")
    if sensor is not None:
        m = matrix_of(sensor)
        eye = [m[i][3] for i in range(3)]
        fwd = [m[i][2] for i in range(3)]
        up = [m[i][1] for i in range(3)]
        fov = 45.0
        axis = "x"
        w, h = 1280, 720
        for c in sensor:
            if c.get("name") == "fov":
                fov = float(c.get("value"))
            if c.get("name") == "fovAxis":
                axis = c.get("value")
        film = sensor.find("film")
        if film is not None:
            for c in film:
                if c.get("name") == "width":
                    w = int(c.get("value"))
                if c.get("name") == "height":
                    h = int(c.get("value"))
        if axis in ("x", "larger" if w >= h else "smaller"):
            fovy = 2 * math.degrees(math.atan(math.tan(math.radians(fov) / 2) * h / w))
        else:
            fovy = fov
        r = lambda v: [round(x, 4) for x in v]
        print(f"eye = {r(eye)}\ntarget = {r([eye[i] + fwd[i] for i in range(3)])}\n"
              f"up = {r(up)}\nfov_y_deg = {fovy:.2f}\nsize = [{w}, {h}]")


if __name__ == "__main__":
    main()
