#!/usr/bin/env python3
"""Geometric edges of a vlf scene's view, from Mitsuba 3 (no vlf code): a mask PNG that is white
where a pixel lies more than --radius pixels from an edge, black near one.

    python3 tools/mitsuba/edges.py SCENE.toml --camera NAME --size WxH [--radius 2] -o mask.png

The view is ray cast with Mitsuba at --oversample x the resolution, one ray per sub-pixel
centre, reflected through ideal mirrors to the first surface that is not one (so the edges of
what a mirror shows count too). A sub-pixel is on an edge where a neighbour ends on another
shape (Mitsuba meshes are per material), a face of another orientation, a jump in path length
(silhouettes), or where one sees the sky and the other does not. A pixel is near an edge
when an edge sub-pixel lies within `radius` pixels of it (Chebyshev distance). `vlf compare
--mask mask.png` then measures only the pixels away from edges: where ripple and smear would
show, not the antialiasing of edges.
"""
import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference  # noqa: E402  (the exporter: same scene semantics, same camera)


def first_diffuse_hits(xml, width, height, variant, bounces=4, merge=True):
    """Per sub-pixel: the shape, geometric normal and path length where the eye ray, reflected
    through ideal mirrors, first meets a surface that is not a pure mirror (or leaves: sky)."""
    import mitsuba as mi
    import drjit as dr
    mi.set_variant(variant)
    reference.register_plugins()
    # merge=False keeps one shape per material (Mitsuba merges identical ones by default)
    scene = mi.load_file(str(xml), optimize=merge, spp="1", width=str(width), height=str(height))
    sensor = scene.sensors()[0]
    idx = dr.arange(mi.UInt32, width * height)
    pos = mi.Point2f((mi.Float(idx % width) + 0.5) / width, (mi.Float(idx // width) + 0.5) / height)
    ray, _ = sensor.sample_ray(0.0, 0.0, pos, mi.Point2f(0.5, 0.5))
    ray = mi.Ray3f(ray)
    length = mi.Float(0.0)
    alive = mi.Bool(True)
    for _ in range(bounces + 1):
        si = scene.ray_intersect(ray, alive)
        length = dr.select(alive & si.is_valid(), length + si.t, length)
        mirror = si.is_valid() & ~mi.has_flag(si.bsdf().flags(), mi.BSDFFlags.Diffuse) \
            & mi.has_flag(si.bsdf().flags(), mi.BSDFFlags.DeltaReflection) & alive
        shape_id = dr.reinterpret_array(mi.UInt32, si.shape) if hasattr(dr, "reinterpret_array") else mi.UInt32(0)
        if _ == 0:
            final_shape, final_n, final_valid = shape_id, si.n, si.is_valid()
        else:
            final_shape = dr.select(alive, shape_id, final_shape)
            final_n = dr.select(alive, si.n, final_n)
            final_valid = dr.select(alive, si.is_valid(), final_valid)
        d = ray.d - 2.0 * dr.dot(ray.d, si.n) * si.n
        ray = mi.Ray3f(dr.select(mirror, si.spawn_ray(d).o, ray.o), dr.select(mirror, d, ray.d))
        alive = mirror
    shape = np.array(final_shape).reshape(height, width)
    normal = np.array(final_n).reshape(3, -1).T.reshape(height, width, 3) if np.array(final_n).ndim == 2 and np.array(final_n).shape[0] == 3 else np.array(final_n).reshape(height, width, 3)
    valid = np.array(final_valid).reshape(height, width)
    depth = np.array(length).reshape(height, width)
    shapes = scene.shapes()
    ids = np.array(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shapes))) if hasattr(dr, "reinterpret_array") else []
    names = {int(i): s.id() for i, s in zip(ids, shapes)}
    return shape, normal, np.where(valid, depth, 0.0), names


def surfaces(xml, width, height, variant, path):
    """Per pixel (its centre): which material's surface the eye sees first past ideal mirrors,
    -1 for the sky, as JSON {"ids": [...row-major...], "names": {id: material}}."""
    import json
    sid, _, depth, names = first_diffuse_hits(xml, width, height, variant, merge=False)
    ids = np.where(depth > 0.0, sid.astype(np.int64), -1)
    names = {k: v[len("mesh-"):] if v.startswith("mesh-") else v for k, v in names.items()}
    Path(path).write_text(json.dumps({"width": width, "height": height, "ids": ids.ravel().tolist(), "names": names}))


def edge_map(xml, width, height, variant):
    sid, normal, depth, _ = first_diffuse_hits(xml, width, height, variant)
    sky = depth <= 0.0
    edge = np.zeros(sid.shape, dtype=bool)
    for axis in (0, 1):
        a = [slice(None)] * 2
        b = [slice(None)] * 2
        a[axis], b[axis] = slice(1, None), slice(None, -1)
        a, b = tuple(a), tuple(b)
        differ = (sid[a] != sid[b]) | (sky[a] != sky[b])
        differ |= np.linalg.norm(normal[a] - normal[b], axis=-1) > 0.05
        near = np.minimum(depth[a], depth[b])
        differ |= (np.abs(depth[a] - depth[b]) > 0.02 * np.maximum(near, 1e-6)) & ~sky[a] & ~sky[b]
        edge[a] |= differ
        edge[b] |= differ
    return edge


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--camera")
    ap.add_argument("--size", required=True, help="WxH of the images to compare")
    ap.add_argument("--radius", type=int, default=2, help="pixels from an edge that count as near it")
    ap.add_argument("--oversample", type=int, default=4)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--surfaces", help="also write the material each pixel sees (JSON), for error maps by surface")
    a = ap.parse_args(argv)
    import mitsuba as mi
    mi.set_variant(a.variant)
    scene = reference.load_scene_toml(a.scene)
    built = reference.build(scene)
    cam = scene["cameras"][0] if a.camera is None else next((c for c in scene["cameras"] if c["name"] == a.camera), None)
    if cam is None:
        sys.exit(f"no camera {a.camera!r}")
    width, height = (int(x) for x in a.size.lower().split("x"))
    k = a.oversample
    with tempfile.TemporaryDirectory(prefix="vlf-edges-") as tmp:
        files, _ = reference.export(scene, built, tmp, spp=1)
        fine = edge_map(files[cam["name"]], width * k, height * k, a.variant)
        if a.surfaces:
            surfaces(files[cam["name"]], width, height, a.variant, a.surfaces)
    coarse = fine.reshape(height, k, width, k).any(axis=(1, 3))
    near = np.zeros_like(coarse)
    r = a.radius
    padded = np.pad(coarse, r)
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            near |= padded[r + dy:r + dy + height, r + dx:r + dx + width]
    keep = np.where(near, 0.0, 1.0)
    reference.srgb_png(a.output, np.stack([keep] * 3, axis=-1))
    print(f"{a.output}: {int((~near).sum())} of {width * height} pixels more than {r} px from an edge", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
