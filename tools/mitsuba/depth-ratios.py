#!/usr/bin/env python3
"""Where a light field's error sits by path depth: the renders of tools/gpu-depth-check.sh
against Mitsuba 3 (no vlf code), direct light alone and the whole.

    python3 tools/mitsuba/depth-ratios.py SCENE.toml DIR [--spp 256] [--variant llvm_ad_rgb] [--json out.json]

DIR holds <label>-it1-<camera>.exr (the light field after one iteration: paths of depth 2),
<label>-it2-<camera>.exr (two: depth 3), <label>-def-<camera>.exr (default settings),
<label>-plain-<camera>.exr (plain shooting, no tail) and reference-<camera>.exr (`vlf
reference` at 4096 spp, which agrees with Mitsuba on every model of the accuracy suite).
Mitsuba renders each camera at 320x180 with max_depth = 2 (direct light: what one iteration
holds) and 3 into DIR/mitsuba-d<depth>-<camera>.exr, reused when present; tools/mitsuba/edges.py gives each pixel's
distance class (within 2 px of a geometric edge or not) and material. Printed and written as
JSON, per label, camera and run: the mean ratio of the image, away from edges, near them, and
per material (the materials holding the most light).
"""
import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SIZE = (320, 180)


def load(path):
    import mitsuba as mi
    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[..., :3].mean(axis=-1)


def mitsuba_depth(scene, camera, depth, spp, variant, out):
    """Mitsuba's render of `camera` with max_depth = `depth` (2: emitters seen, and direct light)."""
    import mitsuba as mi
    mi.set_variant(variant)
    with tempfile.TemporaryDirectory(prefix="vlf-depth-") as tmp:
        subprocess.run([sys.executable, str(HERE / "reference.py"), str(scene), "--export", tmp], check=True,
                       stdout=subprocess.DEVNULL)
        geometry = Path(tmp, "geometry.xml")
        text = re.sub(r'name="max_depth" value="-?\d+"', f'name="max_depth" value="{depth}"', geometry.read_text())
        geometry.write_text(text)
        s = mi.load_file(str(Path(tmp, f"{camera}.xml")), spp=str(spp), width=str(SIZE[0]), height=str(SIZE[1]))
        mi.util.write_bitmap(str(out), mi.render(s, spp=spp), write_async=False)


def classes(scene, camera, variant, tmp):
    """(mask of pixels away from edges, material ids, id -> material name)."""
    import mitsuba as mi
    mask, surf = Path(tmp, f"{camera}-edges.png"), Path(tmp, f"{camera}-surfaces.json")
    subprocess.run([sys.executable, str(HERE / "edges.py"), str(scene), "--camera", camera, "--size",
                    f"{SIZE[0]}x{SIZE[1]}", "--variant", variant, "-o", str(mask), "--surfaces", str(surf)],
                   check=True, stderr=subprocess.DEVNULL)
    keep = np.array(mi.Bitmap(str(mask)), dtype=np.float64)[:, :, 0] > 127
    s = json.loads(surf.read_text())
    return keep, np.array(s["ids"]).reshape(SIZE[1], SIZE[0]), s["names"]


def ratios(image, ref, keep, ids, names):
    ratio = lambda m: float(image[m].sum() / max(ref[m].sum(), 1e-30))
    row = {"mean": ratio(np.ones_like(keep)), "away_from_edges": ratio(keep), "near_edges": ratio(~keep),
           "near_edges_light_share": float(ref[~keep].sum() / ref.sum()), "materials": []}
    for sid in np.unique(ids):
        m = ids == sid
        if m.sum() >= 30:
            row["materials"].append({"material": names.get(str(sid), "sky"), "light_share": float(ref[m].sum() / ref.sum()),
                                     "ratio": ratio(m)})
    row["materials"].sort(key=lambda r: -r["light_share"])
    row["materials"] = row["materials"][:6]
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("dir")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--json")
    a = ap.parse_args()
    import mitsuba as mi
    mi.set_variant(a.variant)
    d = Path(a.dir)
    labels = sorted({p.name.split("-")[0] for p in d.glob("*-def-*.exr")})
    cameras = sorted({p.stem.split("-def-")[1] for p in d.glob("*-def-*.exr")})
    result = {"scene": a.scene, "mitsuba_direct_spp": a.spp, "size": list(SIZE), "views": []}
    with tempfile.TemporaryDirectory(prefix="vlf-depth-classes-") as tmp:
        for cam in cameras:
            refs = {"whole": load(d / f"reference-{cam}.exr")}
            for depth in (2, 3):
                path = d / f"mitsuba-d{depth}-{cam}.exr"
                if not path.exists():
                    mitsuba_depth(a.scene, cam, depth, a.spp, a.variant, path)
                refs[f"depth {depth}"] = load(path)
            keep, ids, names = classes(a.scene, cam, a.variant, tmp)
            for label in labels:
                for depth, kind in (("depth 2", "it1"), ("depth 3", "it2"), ("whole", "def"), ("whole", "plain")):
                    row = ratios(load(d / f"{label}-{kind}-{cam}.exr"), refs[depth], keep, ids, names)
                    result["views"].append({"label": label, "camera": cam, "depth": depth, "run": kind, **row})
                    print(f"{label:7s} {cam:8s} {kind:5s} {depth:7s} mean {row['mean']:.4f}  away from edges "
                          f"{row['away_from_edges']:.4f}  near edges {row['near_edges']:.4f} "
                          f"({row['near_edges_light_share']:.0%} of the light)")
    if a.json:
        Path(a.json).write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
