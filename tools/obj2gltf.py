#!/usr/bin/env python3
"""Write a vlf OBJ/MTL scene as glTF 2.0 with pygltflib (an independent writer: it shares no
code with vlf), for tests/gltf.rs: the same scene through both importers must give the same
light field.

    python3 tools/obj2gltf.py scenes/cornell/scene.toml OUT_DIR [--glb]

writes OUT_DIR/model.gltf (+ model.bin, textures copied) or OUT_DIR/model.glb (everything
embedded) and OUT_DIR/scene.toml (the same sky and cameras, mesh = the model).

Each run of faces with one material becomes a primitive, in the OBJ's order; polygons are cut
into fans from their first corner (as tobj does). Kd -> baseColorFactor (metallic 0), map_Kd ->
baseColorTexture, Ke -> emissiveFactor x KHR_materials_emissive_strength, map_Ke ->
emissiveTexture; texture v is flipped (glTF's v runs down the image). Needs `pip install
pygltflib numpy`.
"""
import os
import shutil
import sys

try:
    import numpy as np
    import pygltflib as g
except ImportError as e:  # the tests look for this message
    sys.exit(f"obj2gltf.py: {e}: install it with `python3 -m pip install pygltflib numpy`")

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = None


def read_mtl(path):
    mats, cur = {}, None
    for raw in open(path):
        w = raw.split("#")[0].split()
        if not w:
            continue
        if w[0] == "newmtl":
            cur = mats.setdefault(w[1], {"order": len(mats)})
        elif cur is not None and w[0] in ("Kd", "Ke", "Ks"):
            cur[w[0]] = [float(x) for x in w[1:4]]
        elif cur is not None and w[0] in ("map_Kd", "map_Ke"):
            cur[w[0]] = w[-1]
    return mats


def read_obj(path):
    """Positions, texture coordinates and runs of (material, [polygon corners])."""
    v, vt, runs, mtllib, mat = [], [], [], None, None
    for raw in open(path):
        w = raw.split("#")[0].split()
        if not w:
            continue
        if w[0] == "v":
            v.append([float(x) for x in w[1:4]])
        elif w[0] == "vt":
            vt.append([float(x) for x in w[1:3]])
        elif w[0] == "mtllib":
            mtllib = w[1]
        elif w[0] == "usemtl":
            mat = w[1]
        elif w[0] == "f":
            corners = []
            for c in w[1:]:
                parts = c.split("/")
                i = int(parts[0])
                t = int(parts[1]) if len(parts) > 1 and parts[1] else None
                corners.append((i - 1 if i > 0 else len(v) + i,
                                None if t is None else (t - 1 if t > 0 else len(vt) + t)))
            if not runs or runs[-1][0] != mat:
                runs.append((mat, []))
            runs[-1][1].append(corners)
    return v, vt, runs, mtllib


def material(gl, name, m, images):
    kd, ke = m.get("Kd", [0.0, 0.0, 0.0]), m.get("Ke", [0.0, 0.0, 0.0])
    if any(m.get("Ks", [0, 0, 0])):
        sys.exit(f"obj2gltf.py: material {name}: Ks (mirrors) is not converted")
    pbr = g.PbrMetallicRoughness(baseColorFactor=kd + [1.0], metallicFactor=0.0, roughnessFactor=1.0)
    mat = g.Material(name=name, pbrMetallicRoughness=pbr)
    if "map_Kd" in m:
        pbr.baseColorTexture = g.TextureInfo(index=texture(gl, m["map_Kd"], images))
    strength = max(ke)
    if strength > 0:
        mat.emissiveFactor = [c / strength for c in ke]
        if strength != 1.0:
            mat.extensions = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
    if "map_Ke" in m:
        mat.emissiveTexture = g.TextureInfo(index=texture(gl, m["map_Ke"], images))
    gl.materials.append(mat)


def texture(gl, uri, images):
    if uri not in images:
        images[uri] = len(gl.textures)
        gl.images.append(g.Image(uri=uri))
        gl.textures.append(g.Texture(source=len(gl.images) - 1))
    return images[uri]


def convert(scene_toml, out_dir, glb):
    text = open(scene_toml).read()
    if tomllib is None:
        sys.exit("obj2gltf.py: needs Python 3.11 or newer (tomllib)")
    scene = tomllib.loads(text)
    src = os.path.dirname(os.path.abspath(scene_toml))
    obj = os.path.join(src, scene["mesh"])
    v, vt, runs, mtllib = read_obj(obj)
    mats = read_mtl(os.path.join(os.path.dirname(obj), mtllib)) if mtllib else {}
    os.makedirs(out_dir, exist_ok=True)
    gl = g.GLTF2(asset=g.Asset(generator="vlf tools/obj2gltf.py (pygltflib)"))
    gl.extensionsUsed = ["KHR_materials_emissive_strength"]
    images, index_of = {}, {}
    for name, m in sorted(mats.items(), key=lambda kv: kv[1]["order"]):
        index_of[name] = len(gl.materials)
        material(gl, name, m, images)
    blob, prims = bytearray(), []

    def add(array, target, kind, ctype, minmax=False):
        while len(blob) % 4:
            blob.append(0)
        gl.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=array.nbytes, target=target))
        blob.extend(array.tobytes())
        acc = g.Accessor(bufferView=len(gl.bufferViews) - 1, componentType=ctype, count=len(array), type=kind)
        if minmax:
            acc.min, acc.max = array.min(axis=0).tolist(), array.max(axis=0).tolist()
        gl.accessors.append(acc)
        return len(gl.accessors) - 1

    for mat, polygons in runs:
        # corners in order of first use, one vertex per (position, texture coordinate) pair
        key_of, pos, uv, tris = {}, [], [], []
        for poly in polygons:
            ids = []
            for c in poly:
                if c not in key_of:
                    key_of[c] = len(pos)
                    pos.append(v[c[0]])
                    uv.append(vt[c[1]] if c[1] is not None else None)
                ids.append(key_of[c])
            tris += [[ids[0], ids[k], ids[k + 1]] for k in range(1, len(ids) - 1)]
        attrs = g.Attributes(POSITION=add(np.array(pos, dtype=np.float32), g.ARRAY_BUFFER, g.VEC3, g.FLOAT, True))
        if all(t is not None for t in uv):
            flipped = [[t[0], 1.0 - t[1]] for t in uv]
            attrs.TEXCOORD_0 = add(np.array(flipped, dtype=np.float32), g.ARRAY_BUFFER, g.VEC2, g.FLOAT)
        indices = add(np.array(tris, dtype=np.uint32).reshape(-1), g.ELEMENT_ARRAY_BUFFER, g.SCALAR, g.UNSIGNED_INT)
        prims.append(g.Primitive(attributes=attrs, indices=indices, material=index_of.get(mat)))
    gl.meshes.append(g.Mesh(primitives=prims))
    gl.nodes.append(g.Node(mesh=0))
    gl.scenes.append(g.Scene(nodes=[0]))
    gl.scene = 0
    model = "model.glb" if glb else "model.gltf"
    gl.buffers.append(g.Buffer(byteLength=len(blob)))
    for uri in images:
        shutil.copy(os.path.join(os.path.dirname(obj), uri), os.path.join(out_dir, uri))
    if glb:
        gl.set_binary_blob(bytes(blob))
        gl.convert_images(g.ImageFormat.DATAURI, path=out_dir)
        gl.save_binary(os.path.join(out_dir, model))
    else:
        gl.buffers[0].uri = "model.bin"
        open(os.path.join(out_dir, "model.bin"), "wb").write(bytes(blob))
        gl.save(os.path.join(out_dir, model))
    lines, top = [], True  # drop the top-level name and mesh, keep the rest
    for l in text.splitlines():
        top = top and not l.startswith("[")
        if not (top and l.split("=")[0].strip() in ("name", "mesh")):
            lines.append(l)
    with open(os.path.join(out_dir, "scene.toml"), "w") as f:
        f.write(f'name = "{scene["name"]}-gltf"\nmesh = "{model}"\n' + "\n".join(lines) + "\n")


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 2:
        sys.exit(__doc__)
    convert(args[0], args[1], "--glb" in sys.argv)
