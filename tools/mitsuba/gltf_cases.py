#!/usr/bin/env python3
"""Write a small glTF 2.0 model that exercises every rule of vlf's glTF import at once, with
pygltflib (no vlf code), for tests/mitsuba.rs: vlf's importer and reference.py's must make the
same scene of it (triangles bit for bit, materials, cameras).

    python3 tools/mitsuba/gltf_cases.py OUT_DIR [--glb]

writes OUT_DIR/cases.gltf (+ cases.bin, texture PNGs; one image as a data: URI) or
OUT_DIR/cases.glb (everything embedded), and OUT_DIR/scene.toml (overrides, a camera).

What is in it: two scenes (`scene` = 1: scene 0's node must not appear); a hierarchy of a
matrix node, TRS nodes (a rotation, a non-uniform and a negative scale: the winding flips), a
mesh instanced three times (twice at the same place: the repeat is dropped); triangle lists
(uint16 / uint32 indices, interleaved POSITION + TEXCOORD with byteStride and byteOffset), a
strip (uint8 indices), a fan (no indices), lines (skipped), a sparse POSITION accessor,
normalised int16 positions and uint16 texture coordinates (KHR_mesh_quantization), a zero-area
triangle; materials: textured diffuse with KHR_texture_transform on TEXCOORD_1, a mirror
(metallic, smooth) whose base colour texture's mean tints it, a rough metal, an emitter with
KHR_materials_emissive_strength and an emissive texture read through the base colour's
coordinates, a texture of factor 1, two materials of one name, an unnamed one, a textured material on a primitive
without texture coordinates, a primitive without material; a perspective camera; a
KHR_lights_punctual light (ignored).
"""

import os
import struct
import sys
import zlib

try:
    import numpy as np
    import pygltflib as g
except ImportError as e:
    sys.exit(f"gltf_cases.py: {e}: install it with `python3 -m pip install pygltflib numpy`")


def png(rgb):
    """8-bit RGB PNG bytes (no filter), written by hand."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\0" + rgb[y].astype(np.uint8).tobytes() for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


class Writer:
    def __init__(self):
        self.gl = g.GLTF2(asset=g.Asset(generator="vlf tools/mitsuba/gltf_cases.py (pygltflib)"))
        self.blob = bytearray()

    def view(self, data, stride=None):
        while len(self.blob) % 4:
            self.blob.append(0)
        self.gl.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data),
                                                byteStride=stride))
        self.blob.extend(data)
        return len(self.gl.bufferViews) - 1

    def accessor(self, view, ctype, count, kind, offset=0, normalized=False, sparse=None, minmax=None):
        a = g.Accessor(bufferView=view, byteOffset=offset, componentType=ctype, count=count, type=kind,
                       normalized=normalized, sparse=sparse)
        if minmax is not None:
            a.min, a.max = minmax
        self.gl.accessors.append(a)
        return len(self.gl.accessors) - 1

    def plain(self, array, ctype, kind, **kw):
        array = np.ascontiguousarray(array)
        mm = None
        if kind == g.VEC3:  # POSITION needs min and max (vlf's glTF crate refuses it without)
            mm = (array.min(axis=0).tolist(), array.max(axis=0).tolist())
        return self.accessor(self.view(array.tobytes()), ctype, len(array), kind, minmax=mm, **kw)


def grid(n, z, size=1.0):
    """(n+1)^2 points of a square in the plane z, and its 2 n^2 triangles (CCW seen from +z)."""
    t = np.linspace(-size, size, n + 1)
    x, y = np.meshgrid(t, t)
    p = np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], axis=1)
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i
            tris += [[a, b, c], [a, c, d]]
    return p, np.array(tris)


def build(out_dir, glb):
    w = Writer()
    gl = w.gl
    gl.extensionsUsed = ["KHR_texture_transform", "KHR_materials_emissive_strength", "KHR_mesh_quantization",
                         "KHR_lights_punctual"]
    rng = np.random.default_rng(7)

    # images: two PNG files beside the model (a data: URI for the third in .gltf), all in the GLB
    imgs = [png(rng.integers(0, 256, (4, 8, 3))), png(rng.integers(30, 256, (8, 4, 3))),
            png(rng.integers(0, 256, (2, 2, 3)))]
    for i, data in enumerate(imgs):
        if glb:
            gl.images.append(g.Image(bufferView=w.view(data), mimeType="image/png"))
        elif i == 2:
            import base64
            gl.images.append(g.Image(uri="data:image/png;base64," + base64.b64encode(data).decode()))
        else:
            name = f"tex {i}.png"  # a space: the uri is percent-encoded
            with open(os.path.join(out_dir, name), "wb") as f:
                f.write(data)
            gl.images.append(g.Image(uri=f"tex%20{i}.png"))
        gl.textures.append(g.Texture(source=i))

    def pbr(base=(1, 1, 1), metallic=0.0, roughness=1.0, tex=None, tex_ext=None, tex_coord=0):
        info = None
        if tex is not None:
            info = g.TextureInfo(index=tex, texCoord=tex_coord, extensions=tex_ext or {})
        return g.PbrMetallicRoughness(baseColorFactor=list(base) + [1.0], metallicFactor=metallic,
                                      roughnessFactor=roughness, baseColorTexture=info)

    mats = [
        g.Material(name="painted", doubleSided=True, pbrMetallicRoughness=pbr(
            (0.8, 0.6, 0.4), tex=0, tex_coord=0,
            tex_ext={"KHR_texture_transform": {"offset": [0.25, -0.5], "rotation": 0.3, "scale": [2.0, 0.5],
                                               "texCoord": 1}})),
        g.Material(name="chrome", pbrMetallicRoughness=pbr((0.9, 0.8, 0.7), metallic=1.0, roughness=0.1, tex=1)),
        g.Material(name="roughmetal", pbrMetallicRoughness=pbr((0.5, 0.5, 0.6), metallic=1.0, roughness=0.5)),
        g.Material(name="lamp", emissiveFactor=[1.0, 0.5, 0.25], pbrMetallicRoughness=pbr((0.3, 0.3, 0.3), tex=2),
                   emissiveTexture=g.TextureInfo(index=1, texCoord=0),
                   extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}),
        g.Material(name="dup", pbrMetallicRoughness=pbr((1.0, 1.0, 1.0), tex=2)),  # factor 1: a PNG for Mitsuba
        g.Material(name="dup", pbrMetallicRoughness=pbr((0.6, 0.4, 0.2)), alphaMode="BLEND"),
        g.Material(pbrMetallicRoughness=pbr((0.1, 0.7, 0.1))),  # unnamed: material6
        g.Material(name="untextured-uv", pbrMetallicRoughness=pbr((0.7, 0.7, 0.7), tex=0)),
    ]
    gl.materials = mats

    meshes = []
    # 0: a 3x3 grid, interleaved POSITION + TEXCOORD_0 + TEXCOORD_1 (stride 28, offset 0/12/20),
    #    uint16 indices, with one zero-area triangle appended (corners on a line)
    p, t = grid(3, 0.0)
    uv0 = (p[:, :2] + 1) / 2
    uv1 = uv0[:, ::-1] * 1.5
    inter = np.zeros((len(p), 7), dtype=np.float32)
    inter[:, :3], inter[:, 3:5], inter[:, 5:7] = p, uv0, uv1
    v = w.view(inter.tobytes(), stride=28)
    pos = w.accessor(v, g.FLOAT, len(p), g.VEC3, 0, minmax=(p.min(0).tolist(), p.max(0).tolist()))
    t0 = w.accessor(v, g.FLOAT, len(p), g.VEC2, 12)
    t1 = w.accessor(v, g.FLOAT, len(p), g.VEC2, 20)
    idx = np.concatenate([t.ravel(), [0, 1, 2]]).astype(np.uint16)
    ind = w.plain(idx, g.UNSIGNED_SHORT, g.SCALAR)
    meshes.append([g.Primitive(attributes=g.Attributes(POSITION=pos, TEXCOORD_0=t0, TEXCOORD_1=t1), indices=ind,
                               material=0)])
    # 1: a strip (uint8 indices) of the mirror, a fan (no indices) of the lamp, lines (skipped)
    sp = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.1], [1, 1, 0.1], [0, 2, 0.3], [1, 2, 0.3]], dtype=np.float32)
    spos = w.plain(sp, g.FLOAT, g.VEC3)
    suv = w.plain((sp[:, :2] / 2).astype(np.float32), g.FLOAT, g.VEC2)
    sind = w.plain(np.array([0, 1, 2, 3, 4, 5], dtype=np.uint8), g.UNSIGNED_BYTE, g.SCALAR)
    ang = np.linspace(0, np.pi, 6)
    fp = np.concatenate([[[0, 0, 0.5]], np.stack([np.cos(ang), np.sin(ang), np.full(6, 0.5)], 1)]).astype(np.float32)
    fpos = w.plain(fp, g.FLOAT, g.VEC3)
    fuv = w.plain(((fp[:, :2] + 1) / 2).astype(np.float32), g.FLOAT, g.VEC2)
    meshes.append([
        g.Primitive(attributes=g.Attributes(POSITION=spos, TEXCOORD_0=suv), indices=sind, mode=5, material=1),
        g.Primitive(attributes=g.Attributes(POSITION=fpos, TEXCOORD_0=fuv), mode=6, material=3),
        g.Primitive(attributes=g.Attributes(POSITION=spos), mode=1, material=2),
    ])
    # 2: a sparse POSITION accessor (a base grid, three corners moved), uint32 indices, rough
    #    metal; plus a primitive without material and one of the unnamed material
    p2, t2 = grid(2, 0.0)
    base = w.view(p2.astype(np.float32).tobytes())
    moved = np.array([1, 4, 7], dtype=np.uint16)
    vals = np.array([[0.1, -1.2, 0.2], [0.0, 0.0, 0.5], [-0.2, 1.1, 0.1]], dtype=np.float32)
    sparse = g.Sparse(count=3, indices=g.AccessorSparseIndices(bufferView=w.view(moved.tobytes()), componentType=g.UNSIGNED_SHORT),
                      values=g.AccessorSparseValues(bufferView=w.view(vals.tobytes())))
    p2s = p2.copy()
    p2s[moved] = vals
    spos2 = w.accessor(base, g.FLOAT, len(p2), g.VEC3, sparse=sparse, minmax=(p2s.min(0).tolist(), p2s.max(0).tolist()))
    ind2 = w.plain(t2.ravel().astype(np.uint32), g.UNSIGNED_INT, g.SCALAR)
    # 3: normalised int16 positions, normalised uint16 texture coordinates (quantised), both dups,
    #    and the textured material without texture coordinates
    p3, t3 = grid(2, 0.25)
    q = np.round(p3 * 32767).astype(np.int16)
    qpos = w.plain(q, g.SHORT, g.VEC3, normalized=True)
    quv = w.plain(np.round((p3[:, :2] + 1) / 2 * 65535).astype(np.uint16), g.UNSIGNED_SHORT, g.VEC2, normalized=True)
    ind3 = w.plain(t3.ravel().astype(np.uint16), g.UNSIGNED_SHORT, g.SCALAR)
    meshes.append([
        g.Primitive(attributes=g.Attributes(POSITION=spos2), indices=ind2, material=2),
        g.Primitive(attributes=g.Attributes(POSITION=qpos), indices=ind3),
        g.Primitive(attributes=g.Attributes(POSITION=fpos), mode=6, material=6),
    ])
    meshes.append([
        g.Primitive(attributes=g.Attributes(POSITION=qpos, TEXCOORD_0=quv), indices=ind3, material=4),
        g.Primitive(attributes=g.Attributes(POSITION=fpos), mode=6, material=5),
        g.Primitive(attributes=g.Attributes(POSITION=spos), indices=sind, mode=5, material=7),
    ])
    gl.meshes = [g.Mesh(primitives=m) for m in meshes]

    s = 0.5 ** 0.5
    gl.nodes = [
        # 0: root with a matrix (rotation about y by 90 degrees, translation), children 1, 2
        g.Node(name="root", matrix=[0, 0, -1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 3, 0.5, -2, 1], children=[1, 2, 5]),
        # 1: TRS (rotation about x, non-uniform scale) with the grid; child 3 mirrors it in x
        g.Node(name="tilted", mesh=0, translation=[0, 1, 0], rotation=[0.25881904, 0, 0, 0.9659258],
               scale=[2, 1, 0.5], children=[3]),
        # 2: strip / fan / lines, and the sparse mesh instanced twice at one place (node 4 too)
        g.Node(name="parts", mesh=1, translation=[-1, 0, 1], children=[4, 6, 7]),
        g.Node(name="mirrored", mesh=0, scale=[-1, 1, 1], translation=[0, 0, 2]),
        g.Node(name="sparse-a", mesh=2, translation=[0, -1, 0]),
        g.Node(name="quantised", mesh=3, rotation=[0, s, 0, s], scale=[1.5, 1.5, 1.5]),
        g.Node(name="sparse-b", mesh=2, translation=[0, -1, 0]),  # the same place: dropped as repeats
        g.Node(name="cam", camera=0, translation=[0, 1, 6], rotation=[-0.0871557, 0, 0, 0.9961947],
               extensions={"KHR_lights_punctual": {"light": 0}}),
        g.Node(name="not-in-scene-1", mesh=1),
    ]
    gl.cameras = [g.Camera(name="gltf-cam", type="perspective",
                           perspective=g.Perspective(yfov=0.8, aspectRatio=1.5, znear=0.01))]
    gl.extensions = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 10.0}]}}
    gl.scenes = [g.Scene(nodes=[8]), g.Scene(nodes=[0])]
    gl.scene = 1

    gl.buffers = [g.Buffer(byteLength=len(w.blob))]
    model = "cases.glb" if glb else "cases.gltf"
    if glb:
        gl.set_binary_blob(bytes(w.blob))
        gl.save_binary(os.path.join(out_dir, model))
    else:
        gl.buffers[0].uri = "cases.bin"
        with open(os.path.join(out_dir, "cases.bin"), "wb") as f:
            f.write(bytes(w.blob))
        gl.save(os.path.join(out_dir, model))
    with open(os.path.join(out_dir, "scene.toml"), "w") as f:
        f.write(f'''name = "gltf-cases"
mesh = "{model}"

[sky]
radiance = [0.2, 0.2, 0.25]

[materials.roughmetal]
diffuse = [0.3, 0.2, 0.1]
mirror = [0.1, 0.1, 0.1]

[materials.painted]
two_sided = false

[materials.chrome]
mirror = [0.5, 0.5, 0.5]

[materials."dup#5"]
emission = [0.5, 0.0, 0.0]

[[camera]]
name = "front"
eye = [11.0, 1.5, 2.0]
target = [3.0, 0.8, -2.0]
up = [0.0, 1.0, 0.0]
fov_y_deg = 45.0
size = [64, 64]
''')


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 1:
        sys.exit(__doc__)
    os.makedirs(args[0], exist_ok=True)
    build(args[0], "--glb" in sys.argv)
