#!/usr/bin/env python3
"""Independent Mitsuba 3 path-traced reference for vlf scenes (ARCHITECTURE.md, "Scene files: the contract").

Shares no code with vlf: scene.toml, OBJ and MTL are parsed here. The scene is written out
as a standalone Mitsuba XML scene (PLY meshes, one per material; textures premultiplied by
Kd / Ke as linear EXR) and that very file is what gets rendered, so `--export` produces
exactly what the reference renders.

    python3 tools/mitsuba/reference.py SCENE.toml --camera NAME --size WxH --spp N -o out.exr
        [--seed S] [--variant llvm_ad_rgb|scalar_rgb] [--variance var.exr] [--png out.png]
    python3 tools/mitsuba/reference.py SCENE.toml --export DIR     # DIR/<camera>.xml, geometry.xml, ...

Output: linear RGB radiance, float32 EXR (3 channels, ZIP compressed), row 0 = top.
"""

import argparse
import math
import os
import struct
import sys
import tempfile
import time
import tomllib
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
    path = Path(path)
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
        bad = set(o) - {"mirror", "diffuse", "emission", "two_sided"}
        if bad:
            raise SceneError(f"{path}: materials.{name}: unknown keys {sorted(bad)}")
        ov = {}
        for key, refl in (("mirror", True), ("diffuse", True), ("emission", False)):
            if key in o:
                ov[key] = _color(o[key], f"materials.{name}.{key}", refl)
        if "two_sided" in o:
            ov["two_sided"] = bool(o["two_sided"])
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
    """name -> {Kd, Ks, Ke, map_Kd, map_Ke} (paths resolved against the MTL's folder)."""
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
        elif key in ("map_Kd", "map_Ke"):
            cur[key] = (Path(path).parent / rest).resolve()
    return mats


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
# scene assembly (vlf semantics)


def build(scene):
    positions, texcoords, tris, mtllibs = load_obj(scene["mesh"])
    mtl = {}
    for lib in mtllibs:
        mtl.update(load_mtl(lib))
    warnings = []
    unknown = set(scene["overrides"]) - set(mtl)
    if unknown:
        raise SceneError(f"[materials.{sorted(unknown)[0]}] overrides a material the mesh's MTL does not define")

    materials = {}
    for name, m in mtl.items():
        o = scene["overrides"].get(name, {})
        mat = {
            "name": name,
            "diffuse": o.get("diffuse", m["Kd"]),
            "mirror": o.get("mirror", m["Ks"]),
            "emission": o.get("emission", m["Ke"]),
            "two_sided": o.get("two_sided", False),
            "map_Kd": m.get("map_Kd"),
            "map_Ke": m.get("map_Ke"),
        }
        for c in range(3):
            if mat["diffuse"][c] + mat["mirror"][c] > 1 + 1e-6:
                raise SceneError(f"material {name}: diffuse + mirror exceeds 1 in channel {c}")
        materials[name] = mat
    default = {"name": "(default)", "diffuse": [0.5] * 3, "mirror": [0.0] * 3, "emission": [0.0] * 3,
               "two_sided": False, "map_Kd": None, "map_Ke": None}

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
        textured = bool(mat["map_Kd"] or mat["map_Ke"])
        uv = ts is not None and textured
        if textured and ts is None:
            warnings.append(f"material {mname}: a triangle without vt; its textures are ignored there")
        groups.setdefault((mname, uv), []).append((vs, ts if uv else None))
    if dropped[0] or dropped[1]:
        warnings.append(f"dropped {dropped[0]} zero-area and {dropped[1]} duplicated triangle(s)")
    lo, hi = positions.min(axis=0), positions.max(axis=0)
    return {"positions": positions, "texcoords": texcoords, "materials": materials, "groups": groups,
            "warnings": sorted(set(warnings)), "bounds": (lo, hi)}


# ---------------------------------------------------------------------------------------------
# files: PLY meshes, EXR images


def write_ply(path, positions, texcoords, tri_list):
    """Binary PLY, three vertices of its own per triangle (flat faces, no shared normals).
    Mitsuba's bitmap texture puts uv (0,0) at the image's top-left and its PLY loader keeps
    uv as written; OBJ's v = 0 is the image's bottom row, so v is stored as 1 - v."""
    has_uv = tri_list and tri_list[0][1] is not None
    n = len(tri_list)
    verts = np.empty((3 * n, 5 if has_uv else 3), dtype="<f4")
    for i, (vs, ts) in enumerate(tri_list):
        for k in range(3):
            verts[3 * i + k, :3] = positions[vs[k]]
            if has_uv:
                u, v = texcoords[ts[k]]
                verts[3 * i + k, 3:] = (u, 1.0 - v)
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
        data = zlib.compress(pred.astype(np.uint8).tobytes(), 9)
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


def linear_texture(mi, path):
    """sRGB 8-bit image -> linear float RGB (exact sRGB curve), row 0 = top."""
    bmp = mi.Bitmap(str(path)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(bmp, dtype=np.float32).reshape(bmp.height(), bmp.width(), 3)


def _texture_xml(name, file):
    return (f'<texture type="bitmap" name="{name}"><string name="filename" value="{file}"/>'
            f'<boolean name="raw" value="true"/><string name="filter_type" value="bilinear"/>'
            f'<string name="wrap_mode" value="repeat"/></texture>')


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
    import mitsuba as mi
    out_dir = Path(out_dir)
    (out_dir / "meshes").mkdir(parents=True, exist_ok=True)
    head = f'<scene version="3.0.0">\n  <!-- vlf scene "{scene["name"]}", written by tools/mitsuba/reference.py -->'
    parts = [head, '  <integrator type="path"><integer name="max_depth" value="-1"/></integrator>']
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
    for gi, ((mname, uv), tri_list) in enumerate(sorted(built["groups"].items(), key=lambda kv: (kv[0][0], kv[0][1]))):
        m = built["materials"][mname]
        stem = f"{gi:03d}-{safe(mname)}"
        write_ply(out_dir / "meshes" / f"{stem}.ply", built["positions"], built["texcoords"], tri_list)
        d = np.array(m["diffuse"], dtype=np.float64)
        s = np.array(m["mirror"], dtype=np.float64)
        e = np.array(m["emission"], dtype=np.float64)
        # diffuse reflectance: constant, or Kd x map_Kd written premultiplied (linear EXR)
        dtex = None
        if uv and m["map_Kd"]:
            dtex = linear_texture(mi, m["map_Kd"]) * d.astype(np.float32)
        dmax = dtex.reshape(-1, 3).max(axis=0) if dtex is not None else d
        has_d, has_s = bool(dmax.max() > 0), bool(s.max() > 0)

        def color_xml(name, value, suffix):
            # Mitsuba refuses an <rgb> reflectance above 1; a 1x1 raw bitmap carries it as is
            if value.max() <= 1.0:
                return f'<rgb name="{name}" value="{_v(value)}"/>'
            (out_dir / "textures").mkdir(exist_ok=True)
            write_exr(out_dir / "textures" / f"{stem}-{suffix}.exr", value.reshape(1, 1, 3))
            return _texture_xml(name, f"textures/{stem}-{suffix}.exr")

        def diffuse_xml(scale):
            if dtex is not None:
                (out_dir / "textures").mkdir(exist_ok=True)
                write_exr(out_dir / "textures" / f"{stem}-kd.exr", dtex * scale)
                return f'<bsdf type="diffuse">{_texture_xml("reflectance", f"textures/{stem}-kd.exr")}</bsdf>'
            return f'<bsdf type="diffuse">{color_xml("reflectance", d * scale, "kd")}</bsdf>'

        def mirror_xml(scale):
            return (f'<bsdf type="conductor"><string name="material" value="none"/>'
                    f'{color_xml("specular_reflectance", s * scale, "ks")}</bsdf>')

        if has_d and has_s:
            # rho_d Lambert + rho_s mirror. Mitsuba 3.9's blendbsdf, asked for a sample of its
            # delta lobe, divides by w + (1-w) pdf_diffuse(wo) and adds the diffuse value there
            # (pdf of a delta taken as 1): exact only when both parts have the same colour.
            # With rho_s = k rho_d (one chromaticity, untextured) w = k/(1+k) gives both parts
            # rho_d + rho_s: exact, and plain Mitsuba. Otherwise vlf_mix, this file's plugin.
            k = s / np.where(d > 0, d, np.inf)
            if dtex is None and d.min() > 0 and np.allclose(k, k.mean(), rtol=1e-6, atol=0):
                w = float(k.mean() / (1 + k.mean()))
                bsdf = (f'<bsdf type="blendbsdf"><float name="weight" value="{w!r}"/>'
                        f'{diffuse_xml(1 / (1 - w))}{mirror_xml(1 / w)}</bsdf>')
            else:
                # probability of the mirror lobe (any value in (0,1) is unbiased): by luminance
                lum = lambda c: float(0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
                dmean = dtex.reshape(-1, 3).mean(axis=0) if dtex is not None else d
                p = min(max(lum(s) / max(lum(s) + lum(dmean), 1e-12), 0.01), 0.99)
                inner = diffuse_xml(1.0)[len('<bsdf type="diffuse">'):-len("</bsdf>")].replace('name="reflectance"', 'name="diffuse"', 1)
                bsdf = (f'<bsdf type="vlf_mix"><float name="mirror_prob" value="{p!r}"/>{inner}'
                        f'{color_xml("mirror", s, "ks")}</bsdf>')
                notes.append(f"{mname}: diffuse + mirror of different colours: `vlf_mix` BSDF (registered by "
                             "tools/mitsuba/reference.py; the plain mitsuba CLI cannot load this scene)")
        elif has_s:
            bsdf = mirror_xml(1.0)
        else:
            bsdf = diffuse_xml(1.0)
        if m["two_sided"]:
            bsdf = f'<bsdf type="twosided">{bsdf}</bsdf>'
        emitter = ""
        if e.max() > 0:
            if uv and m["map_Ke"]:
                (out_dir / "textures").mkdir(exist_ok=True)
                write_exr(out_dir / "textures" / f"{stem}-ke.exr", linear_texture(mi, m["map_Ke"]) * e.astype(np.float32))
                rad = _texture_xml("radiance", f"textures/{stem}-ke.exr")
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
    a = ap.parse_args(argv)
    if not a.output and not a.export:
        ap.error("give -o OUT.exr and/or --export DIR")

    try:
        import mitsuba as mi
    except ImportError:
        sys.exit("error: Mitsuba 3 is not installed for this Python (" + sys.executable + "): pip install mitsuba numpy")
    mi.set_variant(a.variant)
    scene = load_scene_toml(a.scene)
    built = build(scene)
    for w in built["warnings"]:
        print(f"warning: {w}", file=sys.stderr)

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
