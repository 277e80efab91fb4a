#!/usr/bin/env python3
"""Independent Mitsuba 3 path-traced reference for vlf scenes (ARCHITECTURE.md, "Scene files: the contract").

Shares no code with vlf: scene.toml, OBJ and MTL are parsed here, and glTF 2.0 (.gltf / .glb,
with json + numpy), each with vlf's rules. The scene is written out as a standalone
Mitsuba XML scene (PLY meshes, one per material; textures as 8-bit sRGB PNG, or
premultiplied by their factor as linear EXR) and that very file is what gets rendered, so
`--export` produces exactly what the reference renders.

    python3 tools/mitsuba/reference.py SCENE.toml|MODEL.glb --camera NAME --size WxH --spp N -o out.exr
        [--seed S] [--variant llvm_ad_rgb|scalar_rgb] [--variance var.exr] [--png out.png]
    python3 tools/mitsuba/reference.py SCENE.toml --export DIR     # DIR/<camera>.xml, geometry.xml, ...

A .gltf / .glb given instead of a scene.toml is read as `vlf` reads it: with the scene.toml
beside it whose `mesh` names it, else with the model's cameras (or one framing the model).

Output: linear RGB radiance, float32 EXR (3 channels, ZIP compressed), row 0 = top.
"""

import argparse
import base64
import json
import math
import os
import struct
import sys
import tempfile
import time
import tomllib
import urllib.parse
import zlib
from pathlib import Path

try:
    import numpy as np
except ImportError:
    sys.exit("error: numpy is not installed for this Python (" + sys.executable + "): pip install mitsuba numpy")


def _pick_llvm():
    """Dr.Jit's LLVM backend needs LLVM >= 16 (older ones abort with "Cannot select ...
    fminimum"); Debian 12 ships 14/15 by default: prefer the newest libLLVM found."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    import glob
    import re
    best = None
    for d in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib", "/usr/local/lib"):
        for f in glob.glob(f"{d}/libLLVM*.so*") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so*"):
            m = re.search(r"libLLVM-?(\d+)", os.path.basename(f))
            if m and int(m.group(1)) >= 16 and (best is None or int(m.group(1)) > best[0]):
                best = (int(m.group(1)), f)
    if best:
        os.environ["DRJIT_LIBLLVM_PATH"] = best[1]


_pick_llvm()

# ---------------------------------------------------------------------------------------------
# scene.toml


class SceneError(Exception):
    pass


def _color(v, where, reflectance):
    if not (isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) for x in v)):
        raise SceneError(f"{where}: expected [r, g, b], found {v!r}")
    v = [float(x) for x in v]
    if any(not math.isfinite(x) or x < 0 for x in v):
        raise SceneError(f"{where}: {v} must be finite and >= 0")
    if reflectance and any(x > 1 for x in v):
        raise SceneError(f"{where}: reflectance {v} exceeds 1")
    return v


def load_scene_toml(path):
    """scene.toml, or a .gltf / .glb model on its own (as `vlf` loads one: a scene.toml beside
    it whose mesh names it supplies sky, cameras and overrides; else none of them)."""
    path = Path(path)
    if is_gltf(path):
        beside = path.parent / "scene.toml"
        if beside.is_file():
            with open(beside, "rb") as f:
                mesh = tomllib.load(f).get("mesh")
            if mesh is not None and Path(mesh).name == path.name:
                return load_scene_toml(beside)
        return {"name": path.stem, "mesh": path.resolve(), "sky": None, "cameras": [], "overrides": {}}
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    unknown = set(doc) - {"name", "mesh", "sky", "camera", "materials"}
    if unknown:
        raise SceneError(f"{path}: unknown keys {sorted(unknown)}")
    if "mesh" not in doc:
        raise SceneError(f"{path}: `mesh` is required")
    sky = None
    if "sky" in doc:
        sky = _color(doc["sky"].get("radiance"), "sky.radiance", False)
        if not any(x > 0 for x in sky):
            sky = None  # all-zero sky = no sky (vlf does the same)
    cameras = []
    for i, c in enumerate(doc.get("camera", [])):
        cam = {
            "name": c["name"],
            "eye": [float(x) for x in c["eye"]],
            "target": [float(x) for x in c["target"]],
            "up": [float(x) for x in c["up"]],
            "fov_y_deg": float(c["fov_y_deg"]),
            "size": [int(x) for x in c["size"]],
        }
        cameras.append(cam)
    overrides = {}
    for name, o in doc.get("materials", {}).items():
        bad = set(o) - {"mirror", "diffuse", "emission", "two_sided", "roughness"}
        if bad:
            raise SceneError(f"{path}: materials.{name}: unknown keys {sorted(bad)}")
        ov = {}
        for key, refl in (("mirror", True), ("diffuse", True), ("emission", False)):
            if key in o:
                ov[key] = _color(o[key], f"materials.{name}.{key}", refl)
        if "two_sided" in o:
            ov["two_sided"] = bool(o["two_sided"])
        if "roughness" in o:
            r = float(o["roughness"])
            if not 0.0 <= r <= 1.0:
                raise SceneError(f"{path}: materials.{name}.roughness: {r} must be a GGX alpha in [0, 1]")
            ov["roughness"] = r
        overrides[name] = ov
    return {
        "name": doc.get("name", path.parent.name),
        "mesh": (path.parent / doc["mesh"]).resolve(),
        "sky": sky,
        "cameras": cameras,
        "overrides": overrides,
    }


# ---------------------------------------------------------------------------------------------
# OBJ / MTL


def _strip(line):
    return line.split("#", 1)[0].strip()


def load_mtl(path):
    """name -> {Kd, Ks, Ke, Pr, Pm, d, map_Kd, map_Ke, map_d, normal: (normals | height, path, -bm)}
    (paths resolved against the MTL's folder)."""
    mats = {}
    cur = None
    for raw in Path(path).read_text().splitlines():
        line = _strip(raw)
        if not line:
            continue
        key, _, rest = line.partition(" ")
        key, rest = key.strip(), rest.strip()
        if key == "newmtl":
            cur = {"Kd": [0.0] * 3, "Ks": [0.0] * 3, "Ke": [0.0] * 3}
            mats[rest] = cur
        elif cur is None:
            continue
        elif key in ("Kd", "Ks", "Ke"):
            cur[key] = [float(x) for x in rest.split()[:3]]
        elif key in ("map_Kd", "map_Ke", "map_d"):
            cur[key] = (Path(path).parent / rest).resolve()
        elif key in ("norm", "bump", "map_Bump", "map_bump"):
            # a normal map (norm) or a height map (bump): options, then the file; -bm read
            words = rest.split()
            bm = float(words[words.index("-bm") + 1]) if "-bm" in words[:-1] else 1.0
            kind = "normals" if key == "norm" else "height"
            if key == "norm" or "normal" not in cur:
                cur["normal"] = (kind, (Path(path).parent / words[-1]).resolve(), bm)
        elif key in ("Pr", "Pm"):
            cur[key] = float(rest.split()[0])
        elif key == "d":
            cur["d"] = float(rest.split()[0])
    return mats


def _mtl_roughness(m):
    """GGX alpha of an MTL material's specular part: Pr^2 where it has Pr in [0, 1] and Ks > 0
    (Ns is not read: MTL files set it on every material whatever their intent)."""
    pr = m.get("Pr")
    if pr is None or not 0.0 <= pr <= 1.0 or max(m["Ks"]) <= 0:
        return 0.0
    return float(np.float32(pr) * np.float32(pr))


def _mtl_metal(m):
    """MTL's PBR metal by glTF's rules (the scene contract): Pm >= 0.5 and Pr <= 0.6 (0 where
    not given) make Kd the specular part, an ideal mirror up to Pr 0.2, GGX alpha Pr^2 above,
    with no diffuse part; None for a dielectric or a rougher metal. Otherwise (specular colour,
    alpha)."""
    pm, pr = m.get("Pm"), m.get("Pr", 0.0)
    if pm is None or not 0.0 <= pm <= 1.0 or not 0.0 <= pr <= 1.0 or pm < 0.5 or pr > 0.6:
        return None
    return m["Kd"], (float(np.float32(pr) * np.float32(pr)) if pr > 0.2 else 0.0)


def load_obj(path):
    """Positions, texcoords and fan-triangulated faces (grouped by `usemtl` name, None if
    none). Each triangle is ((v0, v1, v2), (t0, t1, t2) or None), indices 0-based."""
    path = Path(path)
    positions, texcoords = [], []
    tris = []  # (material, (v0,v1,v2), (t0,t1,t2) | None)
    mtllibs = []
    material = None
    for lineno, raw in enumerate(path.read_text().splitlines(), 1):
        line = _strip(raw)
        if not line:
            continue
        words = line.split()
        key = words[0]
        if key == "v":
            positions.append([float(x) for x in words[1:4]])
        elif key == "vt":
            uv = [float(x) for x in words[1:3]]
            texcoords.append(uv + [0.0] * (2 - len(uv)))
        elif key == "f":
            corners = []
            for w in words[1:]:
                parts = w.split("/")
                vi = int(parts[0])
                vi = vi - 1 if vi > 0 else len(positions) + vi
                ti = None
                if len(parts) > 1 and parts[1]:
                    ti = int(parts[1])
                    ti = ti - 1 if ti > 0 else len(texcoords) + ti
                if not (0 <= vi < len(positions)):
                    raise SceneError(f"{path}:{lineno}: vertex index out of range")
                corners.append((vi, ti))
            for k in range(1, len(corners) - 1):  # fan triangulation
                c = (corners[0], corners[k], corners[k + 1])
                vs = tuple(x[0] for x in c)
                ts = tuple(x[1] for x in c)
                tris.append((material, vs, None if any(t is None for t in ts) else ts))
        elif key == "usemtl":
            material = line.split(None, 1)[1].strip() if len(words) > 1 else None
        elif key == "mtllib":
            mtllibs.append((path.parent / line.split(None, 1)[1].strip()).resolve())
    return np.array(positions, dtype=np.float64), np.array(texcoords, dtype=np.float64).reshape(-1, 2), tris, mtllibs


# ---------------------------------------------------------------------------------------------
# glTF 2.0 (.gltf with external or data: buffers, .glb), read with json + numpy. Here, not
# in a module of its own: `vlf export mitsuba` embeds this one file and runs it alone. Shares no
# code with vlf, but reproduces the scene vlf's importer (src/scene/gltf.rs,
# src/scene/gltf/material.rs) makes of a model, rule for rule, so that a difference between the
# two renderers measures transport, not a different scene:
#
# - geometry: the default scene (`scene`, else scenes[0], else every root node), depth first,
#   each mesh instance in its world transform (`matrix`, or T * R * S composed in float32 as the
#   `gltf` crate does, then float64 products); corners placed in float64 and rounded to float32;
#   a negative determinant reverses the winding; triangle lists, strips and fans (points and
#   lines skipped with a warning); accessors of any component type, byteOffset / byteStride,
#   normalised integers (KHR_mesh_quantization), sparse substitutions;
# - clean-up: corners welded by their float32 bits, zero-area triangles (area <= 1e-14 x the
#   largest absolute coordinate squared) and repeats of a kept triangle (same corners, same
#   winding) dropped, in file order;
# - materials (scene.toml `[materials.NAME]` overrides on top): metallic >= 0.5 and roughness
#   <= 0.2 -> an ideal mirror of baseColorFactor (times the mean of its base colour texture),
#   0.2 < roughness <= 0.6 -> the same as a glossy GGX lobe of alpha roughness^2;
#   everything else -> diffuse of baseColorFactor x baseColorTexture; emission = emissiveFactor
#   x KHR_materials_emissive_strength (x emissiveTexture); doubleSided -> two-sided; alpha
#   MASK (BLEND as MASK at 0.5) over the base colour texture's alpha -> a `mask` BSDF (the
#   factor's alpha folded into the cutoff), without a texture opaque; transmission, normal /
#   occlusion / metallic-roughness maps ignored; one set of texture
#   coordinates per material (the base colour's, else the emissive's) with its
#   KHR_texture_transform; every sampler taken as repeat + bilinear; primitives without a
#   material: grey diffuse 0.5;
# - cameras: perspective glTF cameras join the scene.toml ones (a scene.toml camera of the same
#   name wins); KHR_lights_punctual lights are ignored (as vlf does, with a warning).


READ_EXTENSIONS = ("KHR_texture_transform", "KHR_materials_emissive_strength", "KHR_lights_punctual",
                   "KHR_materials_transmission", "KHR_mesh_quantization")
MAX_INSTANCES = 1 << 20
MAX_DEPTH = 256
MAX_ZERO_ELEMENTS = 1 << 24
MIRROR_METALLIC = np.float32(0.5)
MIRROR_ROUGHNESS = np.float32(0.2)
GLOSSY_ROUGHNESS = np.float32(0.6)
DEGENERATE_AREA = 1e-14

_COMPONENT = {5120: "i1", 5121: "u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_DIMS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
F32 = np.float32


def is_gltf(path):
    """True for a .gltf / .glb path (vlf decides by the extension too)."""
    return Path(path).suffix.lower() in (".gltf", ".glb")


# ---------------------------------------------------------------------------------------------
# the file, buffers, accessors


class _J(dict):
    """A glTF JSON object: its fields also as attributes, None when absent (but for names of
    dict's own methods: sparse `values` is read with .get)."""
    __slots__ = ()

    def __getattr__(self, key):
        return self.get(key)


_ARRAYS = ("accessors", "bufferViews", "buffers", "nodes", "meshes", "materials", "textures", "images",
           "cameras", "scenes", "samplers")


def read_gltf_json(path):
    """The document (JSON objects as `_J`) and the GLB binary chunk (None for .gltf). The JSON is
    read with Python's json module: pygltflib's dataclass decoding takes about 1.5 ms per JSON
    object (6 s for a model of 3800 accessors and views), which dominates large models."""
    data = path.read_bytes()
    blob = None
    if data[:4] == b"glTF":
        if len(data) < 12:
            raise SceneError(f"{path}: not a valid binary glTF (.glb): truncated header")
        _, version, length = struct.unpack_from("<4sII", data, 0)
        if version != 2:
            raise SceneError(f"{path}: binary glTF version {version}, not 2")
        end, off, text = min(length, len(data)), 12, None
        while off + 8 <= end:
            size, kind = struct.unpack_from("<II", data, off)
            chunk = data[off + 8:off + 8 + size]
            if len(chunk) < size:
                raise SceneError(f"{path}: not a valid binary glTF (.glb): a chunk runs past the end")
            if kind == 0x4E4F534A and text is None:
                text = chunk
            elif kind == 0x004E4942 and blob is None:
                blob = chunk
            off += 8 + size
        if text is None:
            raise SceneError(f"{path}: not a valid binary glTF (.glb): no JSON chunk")
    else:
        text = data
    try:
        doc = json.loads(text.decode("utf-8-sig"), object_hook=_J)
    except (UnicodeDecodeError, ValueError) as e:
        raise SceneError(f"{path}: not valid glTF JSON: {e}") from None
    if not isinstance(doc, _J):
        raise SceneError(f"{path}: not valid glTF JSON: not an object")
    for key in _ARRAYS:
        doc[key] = doc.get(key) or []
    return doc, blob


def _read_uri(uri, folder):
    if uri.startswith("data:"):
        head, sep, payload = uri[5:].partition(";base64,")
        if not sep:
            raise SceneError("a data: URI that is not base64")
        s = "".join(payload.split()).rstrip("=").replace("-", "+").replace("_", "/")
        try:
            return base64.b64decode(s + "=" * (-len(s) % 4), validate=True)
        except ValueError:
            raise SceneError("a data: URI with bad base64") from None
    if "://" in uri:
        raise SceneError(f"{uri!r}: only files beside the model and data: URIs are read")
    f = Path(folder) / urllib.parse.unquote(uri)
    try:
        return f.read_bytes()
    except OSError as e:
        raise SceneError(f"{f}: cannot read: {e}") from None


def load_buffers(doc, blob, path):
    out = []
    for i, b in enumerate(doc.buffers):
        if b.uri is None:
            data = blob
            if data is None:
                raise SceneError(f"buffer {i} is the GLB binary chunk, which the file does not have")
        else:
            data = _read_uri(b.uri, path.parent)
        if b.byteLength is not None and len(data) < b.byteLength:
            raise SceneError(f"buffer {i}: byteLength says {b.byteLength} bytes, but only {len(data)} are there")
        out.append(memoryview(data))
    return out


def _view_bytes(doc, buffers, index):
    if index is None or not 0 <= index < len(doc.bufferViews):
        raise SceneError(f"buffer view {index} does not exist")
    v = doc.bufferViews[index]
    data = buffers[v.buffer]
    start, length = v.byteOffset or 0, v.byteLength or 0
    if start + length > len(data):
        raise SceneError(f"buffer view {index} (bytes {start}..{start + length}) lies outside buffer {v.buffer}")
    return data[start:start + length], v.byteStride


def _strided(data, offset, stride, count, dtype, dims):
    """`count` elements of `dims` components of `dtype`, `stride` bytes apart, from `offset`."""
    dt = np.dtype(dtype)
    if count == 0:
        return np.zeros((0, dims), dtype=dt)
    end = offset + stride * (count - 1) + dt.itemsize * dims
    if end > len(data):
        raise SceneError(f"{count} elements from byte {offset}, {stride} apart, overrun their buffer view ({len(data)} bytes)")
    return np.ndarray((count, dims), dtype=dt, buffer=data, offset=offset, strides=(stride, dt.itemsize)).copy()


def _to_f32(raw, normalized):
    """vlf's conversion: every component to float32; normalised integers scaled to [0, 1] /
    [-1, 1] in float32."""
    k = raw.dtype.kind
    out = raw.astype(F32)
    if normalized and raw.dtype.itemsize < 4:
        top = F32(np.iinfo(raw.dtype).max)
        out = out / top
        if k == "i":
            out = np.maximum(out, F32(-1.0))
    return out


def read_accessor(doc, buffers, index, dims, integers=False):
    """An accessor's values: float32 (count, dims), as vlf converts them, or with
    integers=True the raw integers (index buffers; see `read_indices`)."""
    if index is None or not 0 <= index < len(doc.accessors):
        raise SceneError(f"accessor {index} does not exist")
    a = doc.accessors[index]
    at = f"(accessor {index})"
    if _DIMS.get(a.type) != dims:
        raise SceneError(f"{at} has {a.type} elements, {dims} components expected")
    dtype = _COMPONENT.get(a.componentType)
    if dtype is None:
        raise SceneError(f"{at}: unknown componentType {a.componentType}")
    comp = np.dtype(dtype).itemsize
    count = a.count or 0
    if a.bufferView is not None:
        data, stride = _view_bytes(doc, buffers, a.bufferView)
        stride = stride or comp * dims
        if stride < comp * dims:
            raise SceneError(f"{at}: byteStride {stride} is smaller than an element ({comp * dims} bytes)")
        try:
            raw = _strided(data, a.byteOffset or 0, stride, count, dtype, dims)
        except SceneError as e:
            raise SceneError(f"{at}: {e}") from None
    else:
        if count > MAX_ZERO_ELEMENTS:
            raise SceneError(f"{at}: {count} elements without a buffer view")
        raw = np.zeros((count, dims), dtype=dtype)
    if a.sparse is not None and (a.sparse.count or 0) > 0:
        s = a.sparse
        n = s.count
        idata, _ = _view_bytes(doc, buffers, s.indices.bufferView)
        itype = _COMPONENT.get(s.indices.componentType)
        if itype not in ("u1", "<u2", "<u4"):
            raise SceneError(f"{at}: sparse indices must be unsigned integers")
        idx = _strided(idata, s.indices.byteOffset or 0, np.dtype(itype).itemsize, n, itype, 1)[:, 0]
        sv = s.get("values") or _J()  # not s.values: dict's method
        vdata, _ = _view_bytes(doc, buffers, sv.bufferView)
        vals = _strided(vdata, sv.byteOffset or 0, comp * dims, n, dtype, dims)
        if (idx.astype(np.int64) >= count).any():
            raise SceneError(f"{at}: sparse index {int(idx.max())} is out of range ({count})")
        raw = raw.copy()
        raw[idx.astype(np.int64)] = vals  # in order: a later repeat wins, as in vlf's loop
    if integers:
        return raw
    out = _to_f32(raw, bool(a.normalized))
    if not np.isfinite(out).all():
        raise SceneError(f"{at} holds a value that is not finite")
    return out


def read_indices(doc, buffers, index, vertices, notes):
    a = doc.accessors[index] if index is not None and 0 <= index < len(doc.accessors) else None
    if a is None:
        raise SceneError(f"indices: accessor {index} does not exist")
    if a.type != "SCALAR" or a.componentType not in (5121, 5123, 5125):
        raise SceneError(f"indices (accessor {index}) must be SCALAR unsigned integers")
    raw = read_accessor(doc, buffers, index, 1, integers=True)[:, 0].astype(np.int64)
    # vlf reads index buffers through float32 (exact only below 2^24): say where it would differ
    if len(raw) and raw.max() >= (1 << 24):
        moved = int((raw.astype(F32).astype(np.int64) != raw).sum())
        if moved:
            notes.append(f"indices (accessor {index}): {moved} index value(s) above 2^24 that vlf's importer "
                         "rounds through float32 (it would connect other vertices there); read exactly here")
    if len(raw) and raw.max() >= vertices:
        raise SceneError(f"indices (accessor {index}): index {int(raw.max())} is out of range ({vertices} vertices)")
    return raw


def assemble(mode, idx):
    """Corner index triples from a triangle list (4), strip (5) or fan (6)."""
    idx = np.asarray(idx, dtype=np.int64)
    n = len(idx)
    if mode == 5:
        if n < 3:
            return np.zeros((0, 3), dtype=np.int64)
        i = np.arange(n - 2)
        odd = (i % 2) == 1
        a = np.where(odd, idx[i + 1], idx[i])
        b = np.where(odd, idx[i], idx[i + 1])
        return np.stack([a, b, idx[i + 2]], axis=1)
    if mode == 6:
        if n < 3:
            return np.zeros((0, 3), dtype=np.int64)
        i = np.arange(1, n - 1)
        return np.stack([np.full(len(i), idx[0]), idx[i], idx[i + 1]], axis=1)
    return idx[: n - n % 3].reshape(-1, 3)


# ---------------------------------------------------------------------------------------------
# transforms (float32 TRS as the gltf crate composes it, float64 products as glam's DMat4)


def local_matrix(node):
    """Column-major 4x4 (m[col][row]) as float64 from float32 inputs."""
    if node.matrix is not None:
        m = np.array(node.matrix, dtype=F32).reshape(4, 4)  # glTF stores columns
        return m.astype(np.float64)
    t = np.array(node.translation if node.translation is not None else [0, 0, 0], dtype=F32)
    x, y, z, s = (F32(v) for v in (node.rotation if node.rotation is not None else [0, 0, 0, 1]))
    sc = np.array(node.scale if node.scale is not None else [1, 1, 1], dtype=F32)
    x2, y2, z2 = x + x, y + y, z + z
    xx2, xy2, xz2 = x2 * x, x2 * y, x2 * z
    yy2, yz2, zz2 = y2 * y, y2 * z, z2 * z
    sy2, sz2, sx2 = y2 * s, z2 * s, x2 * s
    one, zero = F32(1.0), F32(0.0)
    r = np.array([[one - yy2 - zz2, xy2 + sz2, xz2 - sy2, zero],
                  [xy2 - sz2, one - xx2 - zz2, yz2 + sx2, zero],
                  [xz2 + sy2, yz2 - sx2, one - xx2 - yy2, zero],
                  [zero, zero, zero, one]], dtype=F32)  # r[col][row]
    tm = np.eye(4, dtype=F32)
    tm[3, :3] = t
    sm = np.diag(np.append(sc, one)).astype(F32)
    # the crate's float32 products, zeros included (they decide the sign of a zero)
    return mat_mul(mat_mul(tm, r), sm).astype(np.float64)


def mat_mul(p, q):
    """p * q for column-major p[col][row], summed in glam's (and the gltf crate's) order, in
    p's precision."""
    out = np.zeros((4, 4), dtype=p.dtype)
    for j in range(4):
        out[j] = p[0] * q[j][0] + p[1] * q[j][1] + p[2] * q[j][2] + p[3] * q[j][3]
    return out


def transform_points(m, pts):
    """float32 (n, 3) -> world float32 (n, 3): float64 ((c0 x + c1 y) + c2 z) + c3."""
    x, y, z = (pts[:, k].astype(np.float64) for k in range(3))
    out = np.empty(pts.shape, dtype=F32)
    for r in range(3):
        out[:, r] = (m[0][r] * x + m[1][r] * y + m[2][r] * z + m[3][r]).astype(F32)
    return out


# ---------------------------------------------------------------------------------------------
# materials


def _check_color(c, reflectance, what):
    if not np.isfinite(c).all():
        raise SceneError(f"{what} {c.tolist()} is not finite")
    if (c < 0).any():
        raise SceneError(f"{what} {c.tolist()} has a negative component")
    if reflectance and (c > 1).any():
        raise SceneError(f"{what} {c.tolist()} exceeds 1: a surface cannot reflect more light than it receives")


def _uv_transform(info):
    """KHR_texture_transform as float32 [[a, b, c], [d, e, f]] (u' = a u + b v + c), or None."""
    t = (info.extensions or {}).get("KHR_texture_transform") if info is not None else None
    if t is None:
        return None
    ox, oy = (F32(v) for v in t.get("offset", [0.0, 0.0]))
    r = F32(t.get("rotation", 0.0))
    sx, sy = (F32(v) for v in t.get("scale", [1.0, 1.0]))
    s, c = F32(math.sin(r)), F32(math.cos(r))
    m = np.array([[c * sx, s * sy, ox], [-s * sx, c * sy, oy]], dtype=F32)
    if np.array_equal(m, np.array([[1, 0, 0], [0, 1, 0]], dtype=F32)):
        return None
    return m


def _tex_coord(info):
    t = (info.extensions or {}).get("KHR_texture_transform")
    if t is not None and t.get("texCoord") is not None:
        return int(t["texCoord"])
    return int(info.texCoord or 0)


def _image_of(doc, info):
    if info.index is None or not 0 <= info.index < len(doc.textures):
        raise SceneError(f"texture {info.index} does not exist")
    src = doc.textures[info.index].source
    if src is None or not 0 <= src < len(doc.images):
        raise SceneError(f"texture {info.index} has no image vlf can read")
    return src


def plan_materials(doc, overrides):
    """Every material in the document's order: vlf's name (name, or material<i>; a repeated
    name gets #<i>) and what it becomes, overrides applied."""
    seen, plans, notes = {}, [], []
    for index, m in enumerate(doc.materials):
        base = m.name if m.name is not None else f"material{index}"
        seen[base] = seen.get(base, 0) + 1
        name = f"{base}#{index}" if seen[base] > 1 else base
        pbr = m.pbrMetallicRoughness or _J()
        bcf = pbr.baseColorFactor if pbr.baseColorFactor is not None else [1.0, 1.0, 1.0, 1.0]
        base_color = np.array(bcf[:3], dtype=F32)
        try:
            _check_color(base_color, True, "baseColorFactor")
            metallic = F32(1.0 if pbr.metallicFactor is None else pbr.metallicFactor)
            roughness = F32(1.0 if pbr.roughnessFactor is None else pbr.roughnessFactor)
            strength = F32(((m.extensions or {}).get("KHR_materials_emissive_strength") or {}).get("emissiveStrength", 1.0))
            emission = np.array(m.emissiveFactor if m.emissiveFactor is not None else [0, 0, 0], dtype=F32) * strength
            _check_color(emission, False, "emissiveFactor x emissive_strength")
        except SceneError as e:
            raise SceneError(f"material {name}: {e}") from None
        mirror = bool(metallic >= MIRROR_METALLIC and roughness <= GLOSSY_ROUGHNESS)
        # a metal's lobe; a dielectric's specular part (a `mirror` override) stays an ideal mirror
        alpha = float(roughness * roughness) if (mirror and roughness > MIRROR_ROUGHNESS) else 0.0
        base_tex, emit_tex = pbr.baseColorTexture, m.emissiveTexture
        o = overrides.get(name, {})
        # a scene.toml override of the specular part or the diffuse colour replaces the kind
        overridden = any(k in o for k in ("mirror", "roughness", "diffuse"))
        # metal that varies over the surface (a metallic-roughness texture), or a textured metal:
        # the rules per texel of the base colour texture (split_metal, once the images are read)
        mr_tex = pbr.metallicRoughnessTexture if not overridden else None
        split = None
        if mr_tex is not None or (mirror and base_tex is not None and not overridden):
            split = {"mr_image": _image_of(doc, mr_tex) if mr_tex is not None else None,
                     "metallic": float(metallic), "roughness": float(roughness), "base": base_color}
            mirror, alpha = False, 0.0
        diffuse_info = base_tex if not mirror else None
        # a cut-out as vlf makes one: alpha MASK (BLEND taken as a MASK at 0.5) over the base
        # colour texture's alpha, the factor's alpha folded into the cutoff (a x f < c is a < c / f)
        cut = m.alphaMode in ("MASK", "BLEND") and base_tex is not None and bcf[3] > 0
        alpha_info = base_tex if cut else None
        cutoff = (0.5 if m.alphaMode == "BLEND" or m.alphaCutoff is None else m.alphaCutoff) / (bcf[3] if cut else 1.0)
        coords = next((i for i in (diffuse_info, alpha_info, emit_tex, mr_tex) if i is not None), None)
        what = []
        if overridden or split is not None:
            pass
        elif mirror and alpha > 0:
            what.append(f"metallic {metallic} roughness {roughness}: glossy metal (GGX alpha {alpha}) of the base colour")
        elif mirror:
            what.append(f"metallic {metallic} roughness {roughness}: ideal mirror of the base colour")
        elif metallic > 0:
            what.append(f"metallic {metallic} roughness {roughness}: rough metal taken as diffuse")
        if m.alphaMode in ("MASK", "BLEND") and not cut:
            what.append(f"alpha {m.alphaMode} without a base colour texture treated as opaque")
        if m.normalTexture is not None:
            what.append("normal texture not exported (vlf reads it; this reader does for MTL norm / bump only)")
        tr = ((m.extensions or {}).get("KHR_materials_transmission") or {}).get("transmissionFactor", 0.0)
        if tr and tr > 0:
            what.append(f"transmission {tr} treated as opaque")
        if what:
            notes.append(f"glTF material {name!r}: " + "; ".join(what))
        mat = {
            "name": name,
            "diffuse": np.array(o["diffuse"], dtype=F32) if "diffuse" in o else (np.zeros(3, F32) if mirror else base_color),
            "mirror": np.array(o["mirror"], dtype=F32) if "mirror" in o else (base_color if mirror else np.zeros(3, F32)),
            "emission": np.array(o["emission"], dtype=F32) if "emission" in o else emission,
            "two_sided": bool(o["two_sided"]) if "two_sided" in o else bool(m.doubleSided),
            "roughness": float(o.get("roughness", alpha)),
        }
        for c in range(3):
            if float(mat["diffuse"][c]) + float(mat["mirror"][c]) > 1 + 1e-6:
                raise SceneError(f"material {name}: diffuse {mat['diffuse'].tolist()} + mirror {mat['mirror'].tolist()} "
                                f"exceeds 1 in channel {c}: the surface would create energy")
        plans.append({
            "material": mat,
            "diffuse_image": _image_of(doc, diffuse_info) if diffuse_info is not None else None,
            "emission_image": _image_of(doc, emit_tex) if emit_tex is not None else None,
            "alpha_image": _image_of(doc, alpha_info) if alpha_info is not None else None,
            "alpha_cutoff": float(cutoff),
            "split": split,
            "uv_set": _tex_coord(coords) if coords is not None else None,
            "uv_transform": _uv_transform(coords) if coords is not None else None,
        })
    return plans, notes


# ---------------------------------------------------------------------------------------------
# images


def image_bytes(doc, buffers, index, folder):
    im = doc.images[index]
    if im.bufferView is not None:
        data, _ = _view_bytes(doc, buffers, im.bufferView)
        return bytes(data)
    if im.uri is None:
        raise SceneError(f"image {index} has neither a uri nor a bufferView")
    return _read_uri(im.uri, folder)


def _bitmap_array(data, name):
    """Encoded PNG / JPEG bytes -> the pixels as Mitsuba decodes them, (h, w, channels)."""
    import mitsuba as mi
    s = mi.MemoryStream()
    s.write(data)
    s.seek(0)
    try:
        bmp = mi.Bitmap(s)
    except Exception as e:
        raise SceneError(f"{name}: not a readable PNG or JPEG image: {e}") from None
    a = np.array(bmp)
    return a[:, :, None] if a.ndim == 2 else a


def decode_alpha(data, name, grey):
    """Encoded PNG / JPEG bytes -> float64 (h, w) coverage in [0, 1]: the alpha channel, else
    (`grey`, MTL map_d) the grey level, else 1 (glTF base colour without alpha)."""
    a = _bitmap_array(data, name)
    scale = 65535.0 if a.dtype == np.uint16 else (255.0 if a.dtype == np.uint8 else 1.0)
    a = a.astype(np.float64) / scale
    ch = a.shape[2]
    if ch in (2, 4):
        return a[:, :, ch - 1]
    return a[:, :, 0] if grey else np.ones(a.shape[:2])


def decode_rgb8(data, name):
    """Encoded PNG / JPEG bytes -> uint8 (h, w, 3), as vlf's `into_rgb8` (alpha dropped, grey
    replicated, 16 bits rounded to 8)."""
    a = _bitmap_array(data, name)
    if a.dtype == np.uint16:
        a = np.round(a.astype(np.float64) / 257.0).astype(np.uint8)
    elif a.dtype != np.uint8:
        a = np.clip(np.round(a.astype(np.float64) * 255.0), 0, 255).astype(np.uint8)
    ch = a.shape[2]
    if ch in (1, 2):
        a = np.repeat(a[:, :, :1], 3, axis=2)
    else:
        a = a[:, :, :3]
    return np.ascontiguousarray(a)


def srgb_lut():
    """vlf's sRGB decode, in float32 (src/color.rs)."""
    x = np.arange(256, dtype=F32) / F32(255.0)
    lo = x / F32(12.92)
    hi = np.power((x + F32(0.055)) / F32(1.055), F32(2.4)).astype(F32)
    return np.where(x <= F32(0.04045), lo, hi).astype(F32)


def texture_mean(rgb8):
    lut = srgb_lut()
    counts = [np.bincount(rgb8[:, :, c].ravel(), minlength=256) for c in range(3)]
    n = max(rgb8.shape[0] * rgb8.shape[1], 1)
    return np.array([float((counts[c] * lut.astype(np.float64)).sum()) / n for c in range(3)], dtype=F32)


# ---------------------------------------------------------------------------------------------
# the model


def _bilinear_at_centres(img, h, w):
    """img (rows from the top, float) sampled bilinearly with wrapping at the centres of an
    h x w grid over the same texture space."""
    ih, iw = img.shape[:2]
    if (ih, iw) == (h, w):
        return img
    y = (np.arange(h) + 0.5) / h * ih - 0.5
    x = (np.arange(w) + 0.5) / w * iw - 0.5
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = (y - y0)[:, None, None], (x - x0)[None, :, None]
    at = lambda yy, xx: img[np.mod(yy, ih)][:, np.mod(xx, iw)]
    return ((at(y0, x0) * (1 - fx) + at(y0, x0 + 1) * fx) * (1 - fy)
            + (at(y0 + 1, x0) * (1 - fx) + at(y0 + 1, x0 + 1) * fx) * fy)


def split_metal(plan, base_loader, mr_loader):
    """A metallic-roughness material per texel, by the rules of plan_materials applied to each
    texel of the base colour texture's grid (the metallic-roughness texture, roughness in green
    and metallic in blue, raw, sampled bilinearly there): a metal texel (metallic >= 0.5,
    roughness <= 0.6) reflects the base colour with GGX alpha roughness^2 (0 at roughness 0.2 or
    less: an ideal mirror, unless another metal texel of the material is glossy, then a lobe of
    alpha 0.001), any other texel is diffuse of it. Returns linear float arrays: the diffuse
    part's and the specular part's reflectance (base colour factor included), the alpha per
    texel (None: every metal texel an ideal mirror; non-metal texels take the metal texels'
    mean), and whether each part is present."""
    lut = srgb_lut()
    base = lut[base_loader()].astype(np.float64) if base_loader is not None else None
    mr = mr_loader().astype(np.float64) / 255.0 if mr_loader is not None else None
    h, w = base.shape[:2] if base is not None else (mr.shape[:2] if mr is not None else (1, 1))
    if base is None:
        base = np.ones((h, w, 3))
    if mr is None:
        metallic, rough = np.full((h, w), plan["metallic"]), np.full((h, w), plan["roughness"])
    else:
        mr = _bilinear_at_centres(mr, h, w)
        metallic, rough = plan["metallic"] * mr[:, :, 2], plan["roughness"] * mr[:, :, 1]
    metal = (metallic >= MIRROR_METALLIC) & (rough <= GLOSSY_ROUGHNESS)
    alpha = np.where(rough > MIRROR_ROUGHNESS, rough * rough, 0.0)
    glossy = bool((alpha[metal] > 0).any())
    colour = base * np.asarray(plan["base"], dtype=np.float64)
    diffuse = np.where(metal[:, :, None], 0.0, colour)
    specular = np.where(metal[:, :, None], colour, 0.0)
    alpha_map = None
    if glossy:
        a = np.maximum(alpha, 1e-3)
        alpha_map = np.where(metal, a, a[metal].mean())
    return {"diffuse": diffuse.astype(F32), "specular": specular.astype(F32),
            "alpha": None if alpha_map is None else alpha_map.astype(F32),
            "has_diffuse": bool(diffuse.max() > 0), "has_specular": bool(specular.max() > 0)}


def _walk_roots(doc):
    if doc.scene is not None and 0 <= doc.scene < len(doc.scenes):
        return list(doc.scenes[doc.scene].nodes or [])
    if doc.scenes:
        return list(doc.scenes[0].nodes or [])
    children = {c for n in doc.nodes for c in (n.children or [])}
    return [i for i in range(len(doc.nodes)) if i not in children]


def _gltf_camera(doc, node, cam_index, world, names):
    cam = doc.cameras[cam_index]
    if cam.type != "perspective" or cam.perspective is None:
        return None, True
    p = cam.perspective
    eye = world[3][:3].copy()
    fwd = -world[2][:3]
    up = world[1][:3].copy()
    nf = np.linalg.norm(fwd)
    fwd = fwd / nf if nf > 0 else fwd * 0
    nu = np.linalg.norm(up)
    up = up / nu if nu > 0 else up * 0
    fov = math.degrees(float(F32(p.yfov or 0.0)))
    aspect = float(F32(p.aspectRatio)) if p.aspectRatio is not None else 4.0 / 3.0
    ok = (np.isfinite(eye).all() and nf > 0 and np.linalg.norm(np.cross(fwd, up)) ** 2 > 1e-12
          and 0 < fov < 180 and math.isfinite(aspect) and aspect > 0)
    if not ok:
        return None, False
    base = cam.name if cam.name is not None else (node.name if node.name is not None else f"camera{cam_index}")
    name, k = base, 2
    while name in names:
        name, k = f"{base}#{k}", k + 1
    names.add(name)
    height = 768
    width = min(max(int(round(height * aspect)), 1), 16384)
    f = lambda v: [float(F32(x)) for x in v]
    return {"name": name, "eye": f(eye), "target": f(eye + fwd), "up": f(up), "fov_y_deg": float(F32(fov)),
            "size": [width, height]}, False


def load_gltf(path, overrides):
    """Read a glTF model the way vlf does. Returns dict with: triangles (n, 3, 3) float32 world
    corners, material (n,) int (len(materials) = the grey default), uv (n, 3, 2) float32 in
    vlf's convention (v = 0 at the image's bottom row) with has_uv (n,) bool, materials (list
    of dicts), images (index -> loader of uint8 RGB), welded (m, 3) float32 positions, cameras,
    warnings."""
    path = Path(path)
    doc, blob = read_gltf_json(path)
    for ext in doc.extensionsRequired or []:
        if ext not in READ_EXTENSIONS:
            raise SceneError(f"{path}: requires the extension {ext}, which vlf cannot read")
    warnings = []
    ignored = [e for e in (doc.extensionsUsed or []) if e not in READ_EXTENSIONS]
    if ignored:
        warnings.append(f"{path}: extension(s) {', '.join(ignored)} not read: ignored")
    buffers = load_buffers(doc, blob, path)
    plans, notes = plan_materials(doc, overrides)
    warnings += notes

    tris, mats, uvs, has_uv = [], [], [], []
    cameras, names = [], set()
    skipped, orthographic, lights, missing_uv = 0, 0, [], {}
    stack = [(i, np.eye(4), 0) for i in reversed(_walk_roots(doc))]
    instances = 0
    identity = np.eye(4)
    while stack:
        ni, parent, depth = stack.pop()
        instances += 1
        if depth > MAX_DEPTH or instances > MAX_INSTANCES:
            raise SceneError(f"{path}: the node hierarchy is deeper than {MAX_DEPTH} levels or has more than "
                            f"{MAX_INSTANCES} instances (a cycle?) at node {ni}")
        if not 0 <= ni < len(doc.nodes):
            raise SceneError(f"{path}: node {ni} does not exist")
        node = doc.nodes[ni]
        world = mat_mul(parent, local_matrix(node))
        if node.mesh is not None:
            mesh = doc.meshes[node.mesh]
            for pi, prim in enumerate(mesh.primitives or []):
                at = f"{path}: mesh {node.mesh} primitive {pi}"
                mode = 4 if prim.mode is None else prim.mode
                if mode in (0, 1, 2, 3):
                    skipped += 1
                    continue
                if mode not in (4, 5, 6):
                    raise SceneError(f"{at}: unknown mode {mode}")
                pos_index = getattr(prim.attributes, "POSITION", None)
                if pos_index is None:
                    raise SceneError(f"{at}: has no POSITION attribute")
                if 0 <= pos_index < len(doc.accessors) and (doc.accessors[pos_index].min is None
                                                            or doc.accessors[pos_index].max is None):
                    # required by the specification; vlf's glTF crate refuses the file without
                    raise SceneError(f"{at}: POSITION accessor {pos_index} has no min / max (glTF 2.0 requires them)")
                try:
                    pts = read_accessor(doc, buffers, pos_index, 3)
                    count = len(pts)
                    if prim.indices is not None:
                        idx = read_indices(doc, buffers, prim.indices, count, warnings)
                    else:
                        idx = np.arange(count, dtype=np.int64)
                    corners = assemble(mode, idx)
                    if prim.material is not None and not 0 <= prim.material < len(plans):
                        raise SceneError(f"material {prim.material} does not exist")
                    mi_ = len(plans) if prim.material is None else prim.material
                    plan = plans[mi_] if mi_ < len(plans) else None
                    uv = None
                    if plan is not None and plan["uv_set"] is not None:
                        a = getattr(prim.attributes, f"TEXCOORD_{plan['uv_set']}", None)
                        if a is None:
                            missing_uv[plan["material"]["name"]] = missing_uv.get(plan["material"]["name"], 0) + 1
                        else:
                            uv = read_accessor(doc, buffers, a, 2)
                            if len(uv) < count:
                                raise SceneError(f"TEXCOORD has {len(uv)} elements, POSITION {count}")
                except SceneError as e:
                    raise SceneError(f"{at}: {e}") from None
                if np.linalg.det(world.T) < 0:
                    corners = corners[:, [0, 2, 1]]
                placed = pts if np.array_equal(world, identity) else transform_points(world, pts)
                tris.append(placed[corners])
                mats.append(np.full(len(corners), mi_, dtype=np.int64))
                if uv is not None:
                    t = plan["uv_transform"]
                    u, v = uv[:, 0], uv[:, 1]
                    if t is not None:
                        u, v = (t[0, 0] * u + t[0, 1] * v + t[0, 2]).astype(F32), (t[1, 0] * u + t[1, 1] * v + t[1, 2]).astype(F32)
                    uvv = np.stack([u, (F32(1.0) - v).astype(F32)], axis=1)  # glTF's v runs down the image
                    uvs.append(uvv[corners])
                    has_uv.append(np.ones(len(corners), dtype=bool))
                else:
                    uvs.append(np.zeros((len(corners), 3, 2), dtype=F32))
                    has_uv.append(np.zeros(len(corners), dtype=bool))
        if node.camera is not None:
            c, ortho = _gltf_camera(doc, node, node.camera, world, names)
            orthographic += ortho
            if c is not None:
                cameras.append(c)
        light = ((node.extensions or {}).get("KHR_lights_punctual") or {}).get("light")
        if light is not None:
            lights.append(str(light))
        for child in reversed(node.children or []):
            stack.append((child, world, depth + 1))
    if skipped:
        warnings.append(f"{path}: skipped {skipped} point/line primitive(s)")
    for name, n in sorted(missing_uv.items()):
        warnings.append(f"{path}: {n} primitive(s) with the textured material {name!r} have no texture coordinates: "
                        "their textures are ignored")
    if orthographic:
        warnings.append(f"{path}: {orthographic} orthographic camera(s) skipped")
    if lights:
        warnings.append(f"{path}: KHR_lights_punctual light(s) {', '.join(lights)} ignored (as vlf ignores them)")

    tri = np.concatenate(tris) if tris else np.zeros((0, 3, 3), dtype=F32)
    mat = np.concatenate(mats) if mats else np.zeros(0, dtype=np.int64)
    uv = np.concatenate(uvs) if uvs else np.zeros((0, 3, 2), dtype=F32)
    huv = np.concatenate(has_uv) if has_uv else np.zeros(0, dtype=bool)

    keep, welded, dropped = clean_triangles(tri)
    if dropped[0]:
        warnings.append(f"{path}: dropped {dropped[0]} zero-area triangle(s)")
    if dropped[1]:
        warnings.append(f"{path}: dropped {dropped[1]} duplicated triangle(s) (same corners and winding as another)")
    tri, mat, uv, huv = tri[keep], mat[keep], uv[keep], huv[keep]
    if len(tri) == 0:
        raise SceneError(f"{path}: the model has no triangles with area: nothing to light")

    folder = path.parent
    cache = {}

    def loader(index):
        def load_image():
            if index not in cache:
                cache[index] = decode_rgb8(image_bytes(doc, buffers, index, folder), f"{path} image {index}")
            return cache[index]
        return load_image

    materials = []
    for p in plans:
        m = dict(p["material"])
        m["diffuse_tex"] = f"image{p['diffuse_image']}" if p["diffuse_image"] is not None else None
        if p["split"] is not None:
            mr = p["split"]["mr_image"]
            base = loader(p["diffuse_image"]) if p["diffuse_image"] is not None else None
            m["split"] = split_metal(p["split"], base, loader(mr) if mr is not None else None)
            m["diffuse_tex"] = None
        m["emission_tex"] = f"image{p['emission_image']}" if p["emission_image"] is not None else None
        if p["alpha_image"] is not None:
            m["alpha_tex"] = f"image{p['alpha_image']}"
            m["alpha_cutoff"] = p["alpha_cutoff"]
        materials.append(m)
    if (mat == len(plans)).any():
        warnings.append(f"{path}: primitives without a material get a grey diffuse default (0.5)")
    images = {f"image{i}": loader(i) for i in range(len(doc.images))}
    # the encoded bytes of the images cut-outs read their alpha from
    alpha_bytes = {m["alpha_tex"]: (lambda i=int(m["alpha_tex"][5:]): image_bytes(doc, buffers, i, folder))
                   for m in materials if m.get("alpha_tex")}
    return {"triangles": tri, "material": mat, "uv": uv, "has_uv": huv, "materials": materials,
            "images": images, "alpha_bytes": alpha_bytes, "welded": welded, "cameras": cameras,
            "warnings": warnings}


def _group_rows(keys):
    """Rows of equal keys (a list of uint64 columns, most significant first): each row's group
    id and, per group, the index of its first row (lexsort is stable)."""
    n = len(keys[0])
    order = np.lexsort(keys[::-1])
    new = np.zeros(n, dtype=bool)
    new[:1] = True
    for k in keys:
        ks = k[order]
        new[1:] |= ks[1:] != ks[:-1]
    ids = np.empty(n, dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, order[new]


def clean_triangles(tri):
    """vlf's weld + filter over triangles in order: which to keep, the welded positions (every
    corner's, dropped triangles' included) and (zero-area, duplicated) counts."""
    n = len(tri)
    if n == 0:
        return np.zeros(0, dtype=bool), np.zeros((0, 3), dtype=F32), (0, 0)
    t64 = tri.astype(np.float64)
    extent = float(np.abs(t64).max())
    min_area = DEGENERATE_AREA * max(extent * extent, 1e-30)
    cr = np.cross(t64[:, 1] - t64[:, 0], t64[:, 2] - t64[:, 0])
    area = 0.5 * np.sqrt((cr * cr).sum(axis=1))
    good = area > min_area
    # weld by bits: equal float32 patterns share an id
    bits = np.ascontiguousarray(tri.reshape(-1, 3)).view(np.uint32).astype(np.uint64)
    ids, first = _group_rows([(bits[:, 0] << np.uint64(32)) | bits[:, 1], bits[:, 2]])
    welded = tri.reshape(-1, 3)[np.sort(first)]
    ids = ids.reshape(n, 3)
    # canonical rotation: the smallest id first (any total order of the ids gives the same test)
    r = np.argmin(ids, axis=1)
    rows = np.arange(n)
    canon = np.stack([ids[rows, r], ids[rows, (r + 1) % 3], ids[rows, (r + 2) % 3]], axis=1).astype(np.uint64)
    cand = np.nonzero(good)[0]
    c = canon[cand]
    _, first_of = _group_rows([(c[:, 0] << np.uint64(32)) | c[:, 1], c[:, 2]])
    keep = np.zeros(n, dtype=bool)
    keep[cand[first_of]] = True
    return keep, welded, (int(n - good.sum()), int(good.sum() - keep.sum()))


def framing_camera(welded):
    """vlf's camera for a model without one (src/scene/mod.rs `framing_camera`)."""
    p = welded.astype(np.float64)
    lo, hi = p.min(axis=0), p.max(axis=0)
    centre = (lo + hi) * 0.5
    radius = max(float(np.sqrt(((p - centre) ** 2).sum(axis=1)).max()), 1e-12)
    scale = 0.99 / radius
    radius = 0.99 / scale
    d = np.array([0.35, 0.3, 1.0])
    d /= np.linalg.norm(d)
    eye = centre + d * radius / math.sin(math.radians(30.0)) * 1.05
    f = lambda v: [float(F32(x)) for x in v]
    return {"name": "view", "eye": f(eye), "target": f(centre), "up": [0.0, 1.0, 0.0], "fov_y_deg": 60.0,
            "size": [1024, 768]}


# ---------------------------------------------------------------------------------------------
# scene assembly (vlf semantics)


def build(scene):
    """The scene as vlf makes it: {"materials": {name: material}, "groups": {(material name,
    textured): (corners (n, 3, 3), uv (n, 3, 2) with v = 0 at the image's bottom row, or
    None)}, "images": {key: loader of uint8 RGB}, "cameras": extra cameras of the model,
    "warnings", "bounds"}. A material: diffuse, mirror, emission (RGB), two_sided,
    diffuse_tex / emission_tex (keys of "images", or None). The model's cameras are added to
    scene["cameras"] as vlf adds them."""
    built = build_gltf(scene) if is_gltf(scene["mesh"]) else build_obj(scene)
    # the model's own cameras join scene.toml's (a scene.toml camera of the same name wins)
    have = {c["name"] for c in scene["cameras"]}
    scene["cameras"] += [c for c in built["cameras"] if c["name"] not in have]
    return built


def merge_extra_obj(built, path):
    """Add an OBJ's triangles as ordinary one-sided geometry with its own MTL materials (named
    "object: NAME"): the moving objects at a frozen pose (`vlf export mitsuba --objects`), so the
    reference has the full solution with them (the light they block and the light they reflect)."""
    extra = build_obj({"mesh": path, "overrides": {}, "cameras": []})
    for name, m in extra["materials"].items():
        built["materials"]["object: " + name] = dict(m, name="object: " + name)
    for (name, uv), arrays in extra["groups"].items():
        built["groups"][("object: " + name, uv)] = arrays
    built["images"].update(extra["images"])
    built["warnings"] = sorted(set(built["warnings"]) | {"extra mesh: " + w for w in extra["warnings"]})
    lo, hi = built["bounds"]
    built["bounds"] = (np.minimum(lo, extra["bounds"][0]), np.maximum(hi, extra["bounds"][1]))


def _image_file_loader(path):
    cache = []

    def load():
        if not cache:
            cache.append(decode_rgb8(Path(path).read_bytes(), str(path)))
        return cache[0]
    return load


def build_obj(scene):
    positions, texcoords, tris, mtllibs = load_obj(scene["mesh"])
    mtl = {}
    for lib in mtllibs:
        mtl.update(load_mtl(lib))
    warnings = []
    unknown = set(scene["overrides"]) - set(mtl)
    if unknown:
        raise SceneError(f"[materials.{sorted(unknown)[0]}] overrides a material the mesh's MTL does not define")

    images = {}
    materials = {}
    for name, m in mtl.items():
        o = scene["overrides"].get(name, {})
        metal = _mtl_metal(m)
        kd, ks, alpha = (m["Kd"], m["Ks"], _mtl_roughness(m)) if metal is None else ([0.0] * 3, metal[0], metal[1])
        mat = {
            "name": name,
            "diffuse": o.get("diffuse", kd),
            "mirror": o.get("mirror", ks),
            "emission": o.get("emission", m["Ke"]),
            "two_sided": o.get("two_sided", False),
            "roughness": o.get("roughness", alpha),
            # a metal's base colour texture is not read (it has no diffuse part)
            "diffuse_tex": str(m["map_Kd"]) if m.get("map_Kd") and metal is None else None,
            "emission_tex": str(m["map_Ke"]) if m.get("map_Ke") else None,
            # a cut-out as vlf takes MTL's dissolve: map_d x d below 0.5 is a hole (d without
            # map_d: opaque)
            "alpha_tex": str(m["map_d"]) if m.get("map_d") else None,
            "alpha_cutoff": 0.5 / max(m.get("d", 1.0), 1e-6),
            # MTL norm (a tangent-space normal map, -bm its scale) or bump (a height map)
            "normal_tex": m.get("normal"),
        }
        for key in ("diffuse_tex", "emission_tex"):
            if mat[key] is not None:
                images.setdefault(mat[key], _image_file_loader(mat[key]))
        for c in range(3):
            if mat["diffuse"][c] + mat["mirror"][c] > 1 + 1e-6:
                raise SceneError(f"material {name}: diffuse + mirror exceeds 1 in channel {c}")
        materials[name] = mat
    default = {"name": "(default)", "diffuse": [0.5] * 3, "mirror": [0.0] * 3, "emission": [0.0] * 3,
               "two_sided": False, "roughness": 0.0, "diffuse_tex": None, "emission_tex": None}

    # weld equal positions, drop zero-area and duplicated (same corners, same winding) triangles
    key_of = {}
    weld = np.empty(len(positions), dtype=np.int64)
    for i, p in enumerate(positions.astype(np.float32)):
        weld[i] = key_of.setdefault(p.tobytes(), i)
    extent = float(np.abs(positions).max()) if len(positions) else 1.0
    min_area = 1e-14 * max(extent * extent, 1e-30)
    seen = set()
    groups = {}  # (material name, textured) -> list of (vs, ts)
    dropped = [0, 0]
    for mname, vs, ts in tris:
        a, b, c = (positions[v] for v in vs)
        if 0.5 * np.linalg.norm(np.cross(b - a, c - a)) <= min_area:
            dropped[0] += 1
            continue
        w = [int(weld[v]) for v in vs]
        r = w.index(min(w))
        key = (w[r], w[(r + 1) % 3], w[(r + 2) % 3])
        if key in seen:
            dropped[1] += 1
            continue
        seen.add(key)
        mat = materials.get(mname)
        if mat is None:
            if mname is not None:
                warnings.append(f"usemtl {mname}: not in the MTL; grey default (Kd 0.5)")
            mname = "(default)"
            materials.setdefault(mname, default)
            mat = default
        textured = bool(mat["diffuse_tex"] or mat["emission_tex"] or mat.get("alpha_tex") or mat.get("normal_tex"))
        uv = ts is not None and textured
        if textured and ts is None:
            warnings.append(f"material {mname}: a triangle without vt; its textures are ignored there")
        groups.setdefault((mname, uv), []).append((vs, ts if uv else None))
    if dropped[0] or dropped[1]:
        warnings.append(f"dropped {dropped[0]} zero-area and {dropped[1]} duplicated triangle(s)")
    arrays = {}
    for key, tri_list in groups.items():
        vs = np.array([t[0] for t in tri_list], dtype=np.int64)
        uv = np.array([t[1] for t in tri_list], dtype=np.int64) if key[1] else None
        arrays[key] = (positions[vs], texcoords[uv] if uv is not None else None)
    lo, hi = positions.min(axis=0), positions.max(axis=0)
    return {"materials": materials, "groups": arrays, "images": images, "cameras": [],
            "warnings": sorted(set(warnings)), "bounds": (lo, hi)}


def build_gltf(scene):
    try:
        g = load_gltf(scene["mesh"], scene["overrides"])
    except SceneError as e:
        raise SceneError(str(e)) from None
    mats = list(g["materials"])
    default = {"name": "(default)", "diffuse": [0.5] * 3, "mirror": [0.0] * 3, "emission": [0.0] * 3,
               "two_sided": False, "roughness": 0.0, "diffuse_tex": None, "emission_tex": None}
    if (g["material"] == len(mats)).any():
        mats.append(default)
    names = [m["name"] for m in mats]
    for name in scene["overrides"]:
        # vlf accepts "(default)" here when the model uses it, and then ignores it
        if name not in names:
            raise SceneError(f"[materials.{name}] overrides a material that {scene['mesh']} does not use; "
                             f"it has: {', '.join(names)}")
    groups = {}
    for mi_, m in enumerate(mats):
        sel = g["material"] == mi_
        if not sel.any():
            continue
        textured = bool(m["diffuse_tex"] or m["emission_tex"] or m.get("alpha_tex") or m.get("split"))
        for uv in ((True, False) if textured else (False,)):
            s = sel & (g["has_uv"] if uv else ~g["has_uv"]) if textured else sel
            if s.any():
                groups[(m["name"], uv)] = (g["triangles"][s], g["uv"][s] if uv else None)
    welded = g["welded"]
    cameras = list(g["cameras"])
    if not cameras and not scene["cameras"]:
        cameras.append(framing_camera(welded))
    return {"materials": {m["name"]: m for m in mats}, "groups": groups, "images": g["images"],
            "alpha_bytes": g["alpha_bytes"], "cameras": cameras, "warnings": g["warnings"],
            "bounds": (welded.min(axis=0).astype(np.float64), welded.max(axis=0).astype(np.float64))}


# ---------------------------------------------------------------------------------------------
# files: PLY meshes, EXR images


def write_ply(path, corners, uv):
    """Binary PLY, three vertices of its own per triangle (flat faces, no shared normals).
    `corners` (n, 3, 3); `uv` (n, 3, 2) with v = 0 at the image's bottom row (OBJ's and vlf's
    convention) or None. Mitsuba's bitmap texture puts uv (0,0) at the image's top-left and its
    PLY loader keeps uv as written, so v is stored as 1 - v."""
    n = len(corners)
    has_uv = uv is not None
    verts = np.empty((n, 3, 5 if has_uv else 3), dtype="<f4")
    verts[:, :, :3] = corners
    if has_uv:
        uv = np.asarray(uv, dtype=np.float64)
        verts[:, :, 3] = uv[:, :, 0]
        verts[:, :, 4] = 1.0 - uv[:, :, 1]
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {3 * n}",
              "property float x", "property float y", "property float z"]
    if has_uv:
        header += ["property float u", "property float v"]
    header += [f"element face {n}", "property list uchar int vertex_indices", "end_header"]
    faces = np.empty(n, dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"] = 3
    faces["i"] = np.arange(3 * n, dtype=np.int32).reshape(n, 3)
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode())
        f.write(verts.tobytes())
        f.write(faces.tobytes())


def write_exr(path, rgb):
    """float32 RGB scanline OpenEXR, ZIP compression (16 lines per block), row 0 = top."""
    rgb = np.ascontiguousarray(rgb, dtype="<f4")
    h, w, _ = rgb.shape
    level = 9 if h * w <= (1 << 20) else 1  # big textures: fast rather than small

    def attr(name, typ, data):
        return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(data)) + data

    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
    header = b"".join([
        struct.pack("<ii", 20000630, 2),
        attr("channels", "chlist", chlist),
        attr("compression", "compression", bytes([3])),  # ZIP_COMPRESSION
        attr("dataWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1)),
        attr("displayWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1)),
        attr("lineOrder", "lineOrder", bytes([0])),
        attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
        attr("screenWindowWidth", "float", struct.pack("<f", 1.0)),
        b"\0",
    ])
    chunks = []
    for y0 in range(0, h, 16):
        block = rgb[y0:y0 + 16]  # lines, each: B row, G row, R row
        raw = np.ascontiguousarray(block[:, :, ::-1].transpose(0, 2, 1)).tobytes()
        buf = np.frombuffer(raw, dtype=np.uint8)
        reordered = np.concatenate([buf[0::2], buf[1::2]]).astype(np.int16)
        pred = reordered.copy()
        pred[1:] = (reordered[1:] - reordered[:-1] + 128) & 0xFF
        data = zlib.compress(pred.astype(np.uint8).tobytes(), level)
        if len(data) >= len(raw):
            data = raw
        chunks.append(struct.pack("<ii", y0, len(data)) + data)
    offset = len(header) + 8 * len(chunks)
    table = []
    for c in chunks:
        table.append(struct.pack("<Q", offset))
        offset += len(c)
    tmp = Path(str(path) + f".tmp-{os.getpid()}")
    with open(tmp, "wb") as f:
        f.write(header + b"".join(table) + b"".join(chunks))
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def srgb_png(path, rgb, exposure=1.0):
    import mitsuba as mi
    x = np.clip(rgb * exposure, 0.0, 1.0)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    img = (x * 255 + 0.5).astype(np.uint8)
    mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB).write(str(path))


# ---------------------------------------------------------------------------------------------
# Mitsuba XML


def _v(x):
    return ", ".join(repr(float(c)) for c in x)


def _texture_xml(name, file, raw=True):
    return (f'<texture type="bitmap" name="{name}"><string name="filename" value="{file}"/>'
            f'<boolean name="raw" value="{"true" if raw else "false"}"/><string name="filter_type" value="bilinear"/>'
            f'<string name="wrap_mode" value="repeat"/></texture>')


class Textures:
    """The export's texture files: an image times a factor (Kd / Ke / base colour / emission).
    Factor 1: the image's own 8-bit sRGB pixels as PNG, decoded by Mitsuba (`raw=false`; its
    sRGB curve is vlf's to 3e-6); any other factor: linear (vlf's sRGB curve) x factor as a
    float32 EXR (`raw=true`). One file per (image, factor), shared by every material using it."""

    def __init__(self, out_dir, images):
        self.out_dir, self.images, self.files, self.stats = Path(out_dir), images, {}, {}
        self.lut = srgb_lut()

    def rgb8(self, key):
        return self.images[key]()

    def linear_stats(self, key):
        """(max, mean) of the image in linear light, per channel."""
        if key not in self.stats:
            px = self.rgb8(key).reshape(-1, 3)
            hist = [np.bincount(px[:, c], minlength=256) for c in range(3)]
            lut = self.lut.astype(np.float64)
            mx = np.array([lut[np.nonzero(h)[0].max()] if h.sum() else 0.0 for h in hist])
            mean = np.array([(h * lut).sum() / max(h.sum(), 1) for h in hist])
            self.stats[key] = (mx, mean)
        return self.stats[key]

    def xml(self, name, key, factor):
        import mitsuba as mi
        f32 = np.asarray(factor, dtype=np.float32)
        unit = bool(np.all(f32 == 1.0))
        fk = (key, f32.tobytes())
        if fk not in self.files:
            (self.out_dir / "textures").mkdir(exist_ok=True)
            stem = f"textures/{len(self.files):03d}-{safe_name(Path(key).stem)}"
            if unit:
                file = stem + ".png"
                mi.Bitmap(self.rgb8(key), mi.Bitmap.PixelFormat.RGB).write(str(self.out_dir / file))
            else:
                file = stem + ".exr"
                write_exr(self.out_dir / file, self.lut[self.rgb8(key)] * f32)
            self.files[fk] = file
        return _texture_xml(name, self.files[fk], raw=not unit)


def mirror_probability(mirror, diffuse):
    """vlf_mix's probability of sampling the mirror lobe (any value in (0, 1) is unbiased): the
    mirror's share of the two mean reflectances' luminance, kept within [0.01, 0.99]."""
    lum = lambda c: float(0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
    return min(max(lum(mirror) / max(lum(mirror) + lum(diffuse), 1e-12), 0.01), 0.99)


def split_bsdf_xml(out_dir, stem, split):
    """A material split per texel (split_metal) as Mitsuba BSDFs of float textures: diffuse of
    the diffuse part's texture plus a GGX `roughconductor` (no Fresnel) of the specular part's
    texture and the alpha texture, summed by `blendbsdf` at weight 0.5 with both doubled (exact
    for two non-delta lobes); with ideal mirror texels only, `conductor`, or vlf_mix beside a
    diffuse part."""
    (out_dir / "textures").mkdir(exist_ok=True)

    def tex(name, part, values):
        file = f"textures/{stem}-{part}.exr"
        write_exr(out_dir / file, values.astype(np.float32))
        return _texture_xml(name, file)

    d, sp, a = split["diffuse"], split["specular"], split["alpha"]
    has_d, has_s = split["has_diffuse"], split["has_specular"]
    if not has_s:
        return f'<bsdf type="diffuse">{tex("reflectance", "diffuse", d)}</bsdf>'
    if a is not None:
        scale = 2.0 if has_d else 1.0
        lobe = (f'<bsdf type="roughconductor"><string name="material" value="none"/>'
                f'<string name="distribution" value="ggx"/>{tex("alpha", "alpha", np.repeat(a[:, :, None], 3, axis=2))}'
                f'{tex("specular_reflectance", "specular", sp * scale)}</bsdf>')
        if not has_d:
            return lobe
        return (f'<bsdf type="blendbsdf"><float name="weight" value="0.5"/>'
                f'<bsdf type="diffuse">{tex("reflectance", "diffuse", d * 2.0)}</bsdf>{lobe}</bsdf>')
    if not has_d:
        return (f'<bsdf type="conductor"><string name="material" value="none"/>'
                f'{tex("specular_reflectance", "specular", sp)}</bsdf>')
    p = mirror_probability(sp.reshape(-1, 3).mean(axis=0), d.reshape(-1, 3).mean(axis=0))
    return (f'<bsdf type="vlf_mix"><float name="mirror_prob" value="{p!r}"/>{tex("diffuse", "diffuse", d)}'
            f'{tex("mirror", "specular", sp)}</bsdf>')


def mask_xml(out_dir, stem, alpha_file, cutoff, bsdf, encoded=None):
    """A cut-out as Mitsuba's `mask` BSDF: opacity 1 where the coverage reaches the cutoff, 0
    where vlf sees a hole. The opacity is the thresholded texture read by nearest texel: for a
    two-level coverage (0 / 1) at cutoff 0.5 that is exactly vlf's bilinear lookup compared with
    the cutoff (both change at the texel boundary); elsewhere it differs within a texel.
    `encoded`: a glTF image's bytes (its alpha channel, else opaque), instead of an MTL map_d
    file (its alpha, else its grey level)."""
    if encoded is not None:
        alpha = decode_alpha(encoded, f"{stem} base colour", grey=False)
    else:
        alpha = decode_alpha(Path(alpha_file).read_bytes(), alpha_file, grey=True)
    opacity = (alpha >= cutoff).astype(np.float32)
    (out_dir / "textures").mkdir(exist_ok=True)
    file = f"textures/{stem}-opacity.exr"
    write_exr(out_dir / file, np.repeat(opacity[:, :, None], 3, axis=2))
    texture = _texture_xml("opacity", file).replace('value="bilinear"', 'value="nearest"')
    return f'<bsdf type="mask">{texture}{bsdf}</bsdf>'


def normal_values(normal):
    """A material's normal map as float (h, w, 3) texture values 0.5 + 0.5 n, read by this
    file itself: `norm` its raw pixels (n = 2 v - 1; with -bm s != 1, (s x, s y, z) normalised),
    `bump` a height map (its first channel, 0..1) by central differences with wrapping,
    n = normalize(-bm dh/dx, -bm dh/dy, 1), x right and y up the image, in texel units."""
    kind, path, bm = normal
    a = _bitmap_array(Path(path).read_bytes(), str(path))
    scale = 65535.0 if a.dtype == np.uint16 else (255.0 if a.dtype == np.uint8 else 1.0)
    a = a.astype(np.float64) / scale
    if a.shape[2] in (1, 2):
        a = np.repeat(a[:, :, :1], 3, axis=2)
    a = a[:, :, :3]
    if kind == "normals":
        if bm == 1.0:
            return a
        n = 2.0 * a - 1.0
        n[:, :, :2] *= bm
    else:
        h = a[:, :, 0]
        dx = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) * 0.5
        # rows run down the image: up is the previous row
        dy = (np.roll(h, 1, axis=0) - np.roll(h, -1, axis=0)) * 0.5
        n = np.stack([-bm * dx, -bm * dy, np.ones_like(h)], axis=2)
    n /= np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-12)
    return 0.5 + 0.5 * n


def normalmap_xml(out_dir, stem, normal, bsdf):
    """A normal map as Mitsuba's `normalmap` BSDF around the material's. Its frame is dp/du
    (made orthogonal to the normal) and n x that, vlf's frame wherever the texture coordinates
    are not mirrored; the texture is read raw (no sRGB curve), bilinear and repeating. Mitsuba
    3.9's default multiplies the BSDF by Estevez et al.'s shadowing term for the bump
    terminator (0.89 for a 30 degree tilt under light 75 degrees off the normal); vlf shades
    with the mapped normal alone, so the export turns it off (`use_shadowing_function`)."""
    (out_dir / "textures").mkdir(exist_ok=True)
    file = f"textures/{stem}-normals.exr"
    write_exr(out_dir / file, normal_values(normal).astype(np.float32))
    return (f'<bsdf type="normalmap"><boolean name="use_shadowing_function" value="false"/>'
            f'{_texture_xml("normalmap", file)}{bsdf}</bsdf>')


def sensor_xml(cam, width, height, spp, clip):
    near, far = clip
    return f"""<sensor type="perspective" id="{cam['name']}">
    <string name="fov_axis" value="y"/>
    <float name="fov" value="{cam['fov_y_deg']!r}"/>
    <float name="near_clip" value="{near!r}"/>
    <float name="far_clip" value="{far!r}"/>
    <transform name="to_world"><lookat origin="{_v(cam['eye'])}" target="{_v(cam['target'])}" up="{_v(cam['up'])}"/></transform>
    <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
    <film type="hdrfilm">
      <integer name="width" value="{width}"/>
      <integer name="height" value="{height}"/>
      <rfilter type="box"/>
      <string name="pixel_format" value="rgb"/>
      <string name="component_format" value="float32"/>
    </film>
  </sensor>"""


def clip_range(scene, built):
    lo, hi = built["bounds"]
    diag = float(np.linalg.norm(hi - lo)) or 1.0
    far = diag
    for cam in scene["cameras"]:
        far = max(far, float(np.linalg.norm(np.array(cam["eye"]) - 0.5 * (lo + hi))) + diag)
    return (1e-5 * diag, 4.0 * far)


def safe_name(s):
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in s)


def export(scene, built, out_dir, spp=256):
    """Write DIR/geometry.xml (integrator, shapes, sky), DIR/<camera>.xml per [[camera]] (it
    includes geometry.xml), DIR/meshes/*.ply, DIR/textures/*.exr. Returns ({camera name: XML
    path}, notes)."""
    out_dir = Path(out_dir)
    (out_dir / "meshes").mkdir(parents=True, exist_ok=True)
    head = f'<scene version="3.0.0">\n  <!-- vlf scene "{scene["name"]}", written by tools/mitsuba/reference.py -->'
    # a cut-out (mask BSDF): volpath, whose shadow rays pass a mask's null part (path's stop at
    # every surface, and light through the holes then arrives only by hitting the emitter)
    masked = any(m.get("alpha_tex") for m in built["materials"].values())
    integrator = "volpath" if masked else "path"
    parts = [head, f'  <integrator type="{integrator}"><integer name="max_depth" value="-1"/></integrator>']
    clip = clip_range(scene, built)
    cameras = {}
    for cam in scene["cameras"]:
        path = out_dir / f"{safe_name(cam['name'])}.xml"
        path.write_text("\n".join([
            head,
            f'  <default name="spp" value="{spp}"/>',
            f'  <default name="width" value="{cam["size"][0]}"/>',
            f'  <default name="height" value="{cam["size"][1]}"/>',
            '  <include filename="geometry.xml"/>',
            "  " + sensor_xml(cam, "$width", "$height", "$spp", clip),
            "</scene>\n"]))
        cameras[cam["name"]] = path
    notes = []
    safe = safe_name
    textures = Textures(out_dir, built.get("images", {}))
    for gi, ((mname, uv), (corners, tex_uv)) in enumerate(sorted(built["groups"].items(), key=lambda kv: (kv[0][0], kv[0][1]))):
        m = built["materials"][mname]
        stem = f"{gi:03d}-{safe(mname)}"
        write_ply(out_dir / "meshes" / f"{stem}.ply", corners, tex_uv)
        d = np.array(m["diffuse"], dtype=np.float64)
        s = np.array(m["mirror"], dtype=np.float64)
        e = np.array(m["emission"], dtype=np.float64)
        # diffuse reflectance: constant, or Kd x map_Kd (base colour factor x texture)
        dkey = m["diffuse_tex"] if uv else None
        if dkey is not None:
            tmax, tmean = textures.linear_stats(dkey)
            dmax, dmean = tmax * d, tmean * d
        else:
            dmax = dmean = d
        has_d, has_s = bool(dmax.max() > 0), bool(s.max() > 0)

        def color_xml(name, value, suffix):
            # Mitsuba refuses an <rgb> reflectance above 1; a 1x1 raw bitmap carries it as is
            if value.max() <= 1.0:
                return f'<rgb name="{name}" value="{_v(value)}"/>'
            (out_dir / "textures").mkdir(exist_ok=True)
            write_exr(out_dir / "textures" / f"{stem}-{suffix}.exr", value.reshape(1, 1, 3))
            return _texture_xml(name, f"textures/{stem}-{suffix}.exr")

        def diffuse_xml(scale):
            if dkey is not None:  # scale is 1 here (blendbsdf is used for untextured ones only)
                return f'<bsdf type="diffuse">{textures.xml("reflectance", dkey, d * scale)}</bsdf>'
            return f'<bsdf type="diffuse">{color_xml("reflectance", d * scale, "kd")}</bsdf>'

        alpha = float(m.get("roughness", 0.0))

        def mirror_xml(scale):
            if alpha > 0:
                # the glossy lobe: GGX with Smith masking, no Fresnel (material "none")
                return (f'<bsdf type="roughconductor"><string name="material" value="none"/>'
                        f'<string name="distribution" value="ggx"/><float name="alpha" value="{alpha!r}"/>'
                        f'{color_xml("specular_reflectance", s * scale, "ks")}</bsdf>')
            return (f'<bsdf type="conductor"><string name="material" value="none"/>'
                    f'{color_xml("specular_reflectance", s * scale, "ks")}</bsdf>')

        if uv and m.get("split") is not None:
            bsdf = split_bsdf_xml(out_dir, stem, m["split"])
            if m["split"]["has_diffuse"] and m["split"]["has_specular"] and m["split"]["alpha"] is None:
                notes.append(f"{mname}: diffuse + mirror textures: `vlf_mix` BSDF (registered by "
                             "tools/mitsuba/reference.py; the plain mitsuba CLI cannot load this scene)")
        elif has_d and has_s and alpha > 0:
            # rho_d Lambert + rho_s glossy lobe: blendbsdf is exact for two non-delta lobes
            bsdf = (f'<bsdf type="blendbsdf"><float name="weight" value="0.5"/>'
                    f'<bsdf type="diffuse">{textures.xml("reflectance", dkey, d * 2.0) if dkey is not None else color_xml("reflectance", d * 2.0, "kd")}</bsdf>'
                    f'{mirror_xml(2.0)}</bsdf>')
        elif has_d and has_s:
            # rho_d Lambert + rho_s mirror. Mitsuba 3.9's blendbsdf, asked for a sample of its
            # delta lobe, divides by w + (1-w) pdf_diffuse(wo) and adds the diffuse value there
            # (pdf of a delta taken as 1): exact only when both parts have the same colour.
            # With rho_s = k rho_d (one chromaticity, untextured) w = k/(1+k) gives both parts
            # rho_d + rho_s: exact, and plain Mitsuba. Otherwise vlf_mix, this file's plugin.
            k = s / np.where(d > 0, d, np.inf)
            if dkey is None and d.min() > 0 and np.allclose(k, k.mean(), rtol=1e-6, atol=0):
                w = float(k.mean() / (1 + k.mean()))
                bsdf = (f'<bsdf type="blendbsdf"><float name="weight" value="{w!r}"/>'
                        f'{diffuse_xml(1 / (1 - w))}{mirror_xml(1 / w)}</bsdf>')
            else:
                p = mirror_probability(s, dmean)
                inner = diffuse_xml(1.0)[len('<bsdf type="diffuse">'):-len("</bsdf>")].replace('name="reflectance"', 'name="diffuse"', 1)
                bsdf = (f'<bsdf type="vlf_mix"><float name="mirror_prob" value="{p!r}"/>{inner}'
                        f'{color_xml("mirror", s, "ks")}</bsdf>')
                notes.append(f"{mname}: diffuse + mirror of different colours: `vlf_mix` BSDF (registered by "
                             "tools/mitsuba/reference.py; the plain mitsuba CLI cannot load this scene)")
        elif has_s:
            bsdf = mirror_xml(1.0)
        else:
            bsdf = diffuse_xml(1.0)
        if uv and m.get("normal_tex"):
            bsdf = normalmap_xml(out_dir, stem, m["normal_tex"], bsdf)
        if m["two_sided"]:
            bsdf = f'<bsdf type="twosided">{bsdf}</bsdf>'
        if uv and m.get("alpha_tex"):
            from_gltf = built.get("alpha_bytes", {}).get(m["alpha_tex"])
            bsdf = mask_xml(out_dir, stem, m["alpha_tex"], m["alpha_cutoff"], bsdf,
                            encoded=from_gltf() if from_gltf else None)
        emitter = ""
        if e.max() > 0:
            if uv and m["emission_tex"]:
                rad = textures.xml("radiance", m["emission_tex"], e)
            else:
                rad = f'<rgb name="radiance" value="{_v(e)}"/>'
            # Mitsuba's area emitter radiates from the front side only, like vlf's
            emitter = f'\n    <emitter type="area">{rad}</emitter>'
        parts.append(f'  <shape type="ply" id="{stem}">\n    <string name="filename" value="meshes/{stem}.ply"/>\n'
                     f'    <boolean name="face_normals" value="true"/>\n    {bsdf}{emitter}\n  </shape>')
    if scene["sky"] is not None:
        parts.append(f'  <emitter type="constant"><rgb name="radiance" value="{_v(scene["sky"])}"/></emitter>')
    parts.append("</scene>\n")
    (out_dir / "geometry.xml").write_text("\n".join(parts))
    return cameras, notes



# ---------------------------------------------------------------------------------------------
# vlf_mix: rho_d Lambert + rho_s ideal mirror, exactly (Mitsuba has no additive BSDF, and its
# blendbsdf is exact for a delta + diffuse blend only when both have the same colour)


def register_plugins():
    import mitsuba as mi
    import drjit as dr

    def lookup(v, si, active):
        # a texture, or a constant colour (an <rgb> property reaches Python as a colour)
        return v.eval(si, active) if hasattr(v, "eval") else mi.Color3f(v[0], v[1], v[2])

    class VlfMix(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.diffuse = props["diffuse"]
            self.mirror = props["mirror"]
            self.p = float(props["mirror_prob"]) if "mirror_prob" in props else 0.5
            diffuse = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            delta = mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.FrontSide
            self.m_components = [diffuse, delta]
            self.m_flags = diffuse | delta

        def sample(self, ctx, si, sample1, sample2, active=True):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            active = active & (cos_i > 0)
            pick_mirror = sample1 < self.p
            wo_d = mi.warp.square_to_cosine_hemisphere(sample2)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = dr.select(pick_mirror, mi.reflect(si.wi), wo_d)
            bs.pdf = dr.select(pick_mirror, self.p, (1 - self.p) * mi.warp.square_to_cosine_hemisphere_pdf(wo_d))
            bs.eta = 1.0
            bs.sampled_type = dr.select(pick_mirror, mi.UInt32(+mi.BSDFFlags.DeltaReflection),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            bs.sampled_component = dr.select(pick_mirror, mi.UInt32(1), mi.UInt32(0))
            value = dr.select(pick_mirror, lookup(self.mirror, si, active) / self.p,
                              lookup(self.diffuse, si, active) / (1 - self.p))
            active = active & (bs.pdf > 0) & (mi.Frame3f.cos_theta(bs.wo) > 0)
            return bs, dr.select(active, value, 0.0)

        def eval(self, ctx, si, wo, active=True):
            cos_o = mi.Frame3f.cos_theta(wo)
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (cos_o > 0)
            return dr.select(ok, lookup(self.diffuse, si, ok) * dr.inv_pi * cos_o, 0.0)

        def pdf(self, ctx, si, wo, active=True):
            cos_o = mi.Frame3f.cos_theta(wo)
            ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (cos_o > 0)
            return dr.select(ok, (1 - self.p) * dr.inv_pi * cos_o, 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def traverse(self, callback):
            pass

        def to_string(self):
            return f"VlfMix[mirror_prob={self.p}]"

    mi.register_bsdf("vlf_mix", lambda props: VlfMix(props))

# ---------------------------------------------------------------------------------------------
# rendering


def render(xml, width, height, spp, seed, variant, progress=True):
    """Render the exported camera file `xml` (as `mitsuba xml -D width=.. -D height=..` would)."""
    import mitsuba as mi
    import drjit as dr
    mi.set_variant(variant)
    register_plugins()
    ms = mi.load_file(str(xml), spp=str(spp), width=str(width), height=str(height))
    sensor = ms.sensors()[0]
    # LLVM renders a pass as one wavefront: keep a pass near 4M samples
    per_pass = spp if variant.startswith("scalar") else max(1, min(spp, (1 << 22) // (width * height)))
    # at least 8 passes where spp allows, for the variance estimate
    per_pass = max(1, min(per_pass, spp // 8)) if spp >= 8 else per_pass
    s1 = s2 = None  # sums over passes of n x and n x^2 (x: a pass's mean image)
    done, index = 0, 0
    t0 = time.time()
    while done < spp:
        n = min(per_pass, spp - done)
        s = (seed * 1000003 + index) & 0xFFFFFFFF
        if not variant.startswith("scalar"):
            s = dr.opaque(mi.UInt32, s)  # no recompilation per pass
        x = np.array(mi.render(ms, sensor=sensor, seed=s, spp=n), dtype=np.float64)[:, :, :3]
        s1 = n * x if s1 is None else s1 + n * x
        s2 = n * x * x if s2 is None else s2 + n * x * x
        done += n
        index += 1
        if progress:
            el = time.time() - t0
            print(f"\r  {done}/{spp} spp  {el:.1f} s  (eta {el / done * (spp - done):.0f} s)", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    mean = s1 / spp
    variance = None
    if index > 1:
        # Var(pass mean) = sigma^2 / n: sum n (x - mean)^2 estimates (passes - 1) sigma^2;
        # the variance of the final mean is sigma^2 / spp
        sigma2 = np.maximum(s2 - spp * mean * mean, 0.0) / (index - 1)
        variance = sigma2 / spp
    return mean, variance, time.time() - t0


def dump_json(scene, built, path):
    """The scene as built, for tests: materials (colours as float32 values, texture image keys
    or null), per group its
    triangles (9 floats each: the corners) and texture coordinates (6 floats, v = 0 at the
    image's bottom row), the cameras and the sky."""
    f32 = lambda v: [float(np.float32(x)) for x in np.asarray(v, dtype=np.float64).ravel()]
    doc = {"materials": {}, "groups": [], "cameras": scene["cameras"], "sky": scene["sky"]}
    for name, m in built["materials"].items():
        split = m.get("split")
        if split is not None:
            # a material split per texel: its parts' means (what vlf's factors hold), a texture key
            # where it has a diffuse part, and the alpha where every metal texel has the same one
            # (vlf's mean-albedo alpha is not this file's to compute otherwise)
            a = split["alpha"]
            metal = split["specular"].max(axis=2) > 0
            same = a is None or (metal.any() and np.ptp(a[metal]) == 0)
            m = dict(m, diffuse=split["diffuse"].reshape(-1, 3).astype(np.float64).mean(axis=0),
                     mirror=split["specular"].reshape(-1, 3).astype(np.float64).mean(axis=0),
                     roughness=(0.0 if a is None else float(a[metal][0])) if same else None,
                     diffuse_tex="split" if split["has_diffuse"] else None)
        doc["materials"][name] = {"diffuse": f32(m["diffuse"]), "mirror": f32(m["mirror"]),
                                  "roughness": None if m.get("roughness", 0.0) is None else float(np.float32(m.get("roughness", 0.0))),
                                  "emission": f32(m["emission"]), "two_sided": bool(m["two_sided"]),
                                  "diffuse_texture": m["diffuse_tex"], "emission_texture": m["emission_tex"],
                                  "cutoff": m.get("alpha_cutoff") if m.get("alpha_tex") else None}
    for (name, textured), (corners, uv) in sorted(built["groups"].items()):
        c = np.asarray(corners, dtype=np.float32).reshape(-1, 9)
        doc["groups"].append({"material": name, "textured": textured,
                              "corners": [[float(x) for x in row] for row in c],
                              "uv": None if uv is None else [[float(x) for x in row] for row in np.asarray(uv, dtype=np.float32).reshape(-1, 6)]})
    Path(path).write_text(json.dumps(doc))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--camera", help="camera name (default: the first)")
    ap.add_argument("--size", help="WxH (default: the camera's size)")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("-o", "--output", help="linear RGB EXR")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", default="llvm_ad_rgb", help="llvm_ad_rgb (default) or scalar_rgb")
    ap.add_argument("--variance", help="also write the per-pixel variance of the mean (EXR)")
    ap.add_argument("--png", help="also write a tonemapped PNG (sRGB, clamp)")
    ap.add_argument("--exposure", type=float, default=1.0)
    ap.add_argument("--export", metavar="DIR", help="write a standalone Mitsuba scene: DIR/<camera>.xml, geometry.xml, meshes/, textures/")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--extra-obj", metavar="OBJ", help="add this OBJ (with its MTL) as ordinary geometry: "
                    "the moving objects at a frozen pose, as `vlf export mitsuba --objects` writes them")
    ap.add_argument("--dump-json", metavar="FILE", help="write the scene as built (materials, triangles, cameras) as JSON, "
                    "for comparing with vlf's importer (tests/mitsuba.rs)")
    a = ap.parse_args(argv)
    if not a.output and not a.export and not a.dump_json:
        ap.error("give -o OUT.exr and/or --export DIR (or --dump-json FILE)")

    try:
        import mitsuba as mi
    except ImportError:
        sys.exit("error: Mitsuba 3 is not installed for this Python (" + sys.executable + "): pip install mitsuba numpy")
    mi.set_variant(a.variant)
    scene = load_scene_toml(a.scene)
    built = build(scene)
    if a.extra_obj:
        merge_extra_obj(built, a.extra_obj)
    for w in built["warnings"]:
        print(f"warning: {w}", file=sys.stderr)

    if a.dump_json:
        dump_json(scene, built, a.dump_json)
    if a.export:
        files, notes = export(scene, built, a.export, spp=a.spp)
        for n in notes:
            print(f"note: {n}", file=sys.stderr)
        for name, xml in files.items():
            print(f"camera {name}: mitsuba {xml} -D spp=N [-D width=W -D height=H]", file=sys.stderr)
    if not a.output:
        return 0

    if not scene["cameras"]:
        sys.exit("scene has no [[camera]]")
    cam = scene["cameras"][0] if a.camera is None else next((c for c in scene["cameras"] if c["name"] == a.camera), None)
    if cam is None:
        sys.exit(f"no camera {a.camera!r}; have: {', '.join(c['name'] for c in scene['cameras'])}")
    width, height = cam["size"]
    if a.size:
        width, height = (int(x) for x in a.size.lower().split("x"))

    with tempfile.TemporaryDirectory(prefix="vlf-mitsuba-") as tmp:
        files, notes = export(scene, built, tmp, spp=a.spp)
        for n in notes:
            print(f"note: {n}", file=sys.stderr)
        mean, variance, seconds = render(files[cam["name"]], width, height, a.spp, a.seed, a.variant, not a.quiet)
    Path(a.output).parent.mkdir(parents=True, exist_ok=True)
    write_exr(a.output, mean)
    if a.variance and variance is not None:
        write_exr(a.variance, variance)
    if a.png:
        srgb_png(a.png, mean, a.exposure)
    print(f"{scene['name']} camera {cam['name']}: {width}x{height}, {a.spp} spp, {a.variant}, {seconds:.1f} s -> {a.output}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except SceneError as e:
        sys.exit(f"error: {e}")
    except (OSError, tomllib.TOMLDecodeError) as e:
        sys.exit(f"error: {e}")
