#!/usr/bin/env python3
"""The accuracy figures of the user guide's docs/guide/accuracy.md, from committed data only: vlf's default renders (from
tools/gpu-quality.sh on the lent GPU), the independent Mitsuba 3 references and their edge
masks (tools/mitsuba/), compared by `vlf compare`.

    python3 tools/accuracy.py [--vlf target/release/vlf]            # docs/results/accuracy.json,
                                                                     # docs/images/accuracy-*.png,
                                                                     # the page's block rewritten
    python3 tools/accuracy.py --check                                # fail if the page's block is stale
    python3 tools/accuracy.py --combine OUT.exr A.exr B.exr ...      # mean of references (and of
                                                                     # their -var.exr, divided by n^2)

Every metric is given twice: over all pixels, and over the pixels more than 2 px from a geometric
edge of the reference (edges seen in mirrors included), where ripple and smear would show. The
references are Monte Carlo estimates: their own noise, estimated from their per-pixel variance
(relMSE of the noise; display MSE through the sRGB curve's slope), is listed beside each figure,
because it adds to what the comparison measures.
"""
import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools" / "mitsuba"))

VIEWS = [
    # (view, scene, camera, targets: all-pixel relMSE, all-pixel display MSE, away-from-edges display MSE)
    ("cornell-front", "scenes/cornell/scene.toml", "front", (2e-4, 2e-5, 1e-5)),
    ("cornell-mirror-front", "scenes/cornell-mirror/scene.toml", "front", (4e-4, 4e-5, 1e-5)),
    ("cornell-mirror-side", "scenes/cornell-mirror/scene.toml", "side", (4e-4, 4e-5, 1e-5)),
]
RESULTS = ROOT / "docs/results/h100/quality"
REFERENCES = ROOT / "docs/results/reference"
# the page the block is in; its images are in docs/images/ (relative to the page: ../images/)
PAGE = "docs/guide/accuracy.md"
BEGIN, END = "<!-- accuracy:begin (tools/accuracy.py) -->", "<!-- accuracy:end -->"


def read_exr(path):
    import numpy as np
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[:, :, :3]


def srgb(x):
    import numpy as np
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 1e-12), 1 / 2.4) - 0.055)


def reference_noise(ref, var, keep):
    """relMSE and display MSE that the reference's own noise contributes (its variance of the
    mean, propagated to first order)."""
    rel = var / (ref * ref + 0.01)  # numpy arrays
    h = 1e-4
    slope = (srgb(ref + h) - srgb(ref - h)) / (2 * h)
    display = var * slope * slope
    return {"rel_mse": float(rel[keep].mean()), "display_mse": float(display[keep].mean())}


def vlf_compare(vlf, image, reference, mask=None, diff=None):
    cmd = [vlf, "compare", str(image), str(reference), "--json"]
    if mask:
        cmd += ["--mask", str(mask)]
    if diff:
        cmd += ["--diff", str(diff)]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def measure(vlf):
    import numpy as np
    import reference as mref
    rows = []
    for view, scene, camera, targets in VIEWS:
        image = RESULTS / f"vlf-{view}-512.exr"
        ref = REFERENCES / f"mitsuba-{view}-512.exr"
        var = REFERENCES / f"mitsuba-{view}-512-var.exr"
        mask = REFERENCES / f"edges-{view}-512.png"
        if not mask.exists():
            subprocess.run([sys.executable, str(ROOT / "tools/mitsuba/edges.py"), scene, "--camera", camera, "--size", "512x512", "-o", str(mask)], check=True)
        spp = json.loads((REFERENCES / f"mitsuba-{view}-512.json").read_text())["spp"] if (REFERENCES / f"mitsuba-{view}-512.json").exists() else 4096
        all_px = vlf_compare(vlf, image, ref, diff=ROOT / f"docs/images/accuracy-diff-{view}.png")
        away = vlf_compare(vlf, image, ref, mask=mask)
        r, v = read_exr(ref), read_exr(var)
        keep_mask = read_exr(mask)[:, :, 0] > 0.5 if mask.suffix == ".exr" else None
        if keep_mask is None:
            import mitsuba as mi
            keep_mask = np.array(mi.Bitmap(str(mask)), dtype=np.float64)[:, :, 0] > 127
        everywhere = np.ones(keep_mask.shape, dtype=bool)
        mref.srgb_png(ROOT / f"docs/images/accuracy-vlf-{view}.png", read_exr(image))
        mref.srgb_png(ROOT / f"docs/images/accuracy-mitsuba-{view}.png", r)
        rows.append({
            "view": view, "scene": scene, "camera": camera, "reference_spp": spp,
            "all_pixels": all_px, "away_from_edges": away,
            "reference_noise_all": reference_noise(r, v, everywhere[:, :, None].repeat(3, 2)),
            "reference_noise_away": reference_noise(r, v, keep_mask[:, :, None].repeat(3, 2)),
            "targets": {"rel_mse": targets[0], "display_mse": targets[1], "display_mse_away_from_edges": targets[2]},
        })
    return rows


def verdict(measured, noise, target):
    own = measured - noise
    if measured <= target:
        return "met"
    if own <= target:
        return f"met after the reference's noise ({noise:.1e}) is taken out"
    return "**not met**"


def block(rows, meta):
    lines = [BEGIN, "",
             f"Default settings, no flags (`vlf render SCENE --camera C --size 512x512`: 16 eye rays per pixel), "
             f"on {meta['gpu']} at commit {meta['commit']}, against Mitsuba 3 path-traced references "
             f"(`tools/mitsuba/reference.py`: its own scene import and ray casting, box filter); "
             f"\"away from edges\" keeps the pixels more than 2 px from a geometric edge of the reference, "
             f"edges seen in the mirror included (`tools/mitsuba/edges.py`). The references' own noise adds to "
             f"every figure and is listed beside it. Generated by `python3 tools/accuracy.py` from "
             f"`docs/results/h100/quality/` and `docs/results/reference/`.", "",
             "| view | reference | relMSE (target) | display MSE (target) | away from edges: relMSE | away from edges: display MSE (target) | FLIP | reference noise: relMSE / display MSE (all; away) |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        a, e, t = r["all_pixels"], r["away_from_edges"], r["targets"]
        na, ne = r["reference_noise_all"], r["reference_noise_away"]
        lines.append(
            f"| {r['view']} | {r['reference_spp']} spp | {a['rel_mse']:.2e} ({t['rel_mse']:.0e}: {verdict(a['rel_mse'], na['rel_mse'], t['rel_mse'])}) "
            f"| {a['display_mse']:.2e} ({t['display_mse']:.0e}: {verdict(a['display_mse'], na['display_mse'], t['display_mse'])}) "
            f"| {e['rel_mse']:.2e} | {e['display_mse']:.2e} ({t['display_mse_away_from_edges']:.0e}: {verdict(e['display_mse'], ne['display_mse'], t['display_mse_away_from_edges'])}) "
            f"| {a['flip_mean']:.4f} | {na['rel_mse']:.1e} / {na['display_mse']:.1e}; {ne['rel_mse']:.1e} / {ne['display_mse']:.1e} |")
    lines += ["", "| view | vlf (default settings) | Mitsuba 3 reference | FLIP difference |", "|---|---|---|---|"]
    for r in rows:
        v = r["view"]
        lines.append(f"| {v} | ![vlf](../images/accuracy-vlf-{v}.png) | ![Mitsuba](../images/accuracy-mitsuba-{v}.png) | ![FLIP](../images/accuracy-diff-{v}.png) |")
    lines += ["", END]
    return "\n".join(lines)


def combine(out, inputs):
    import reference as mref
    means = [read_exr(p) for p in inputs]
    mref.write_exr(out, sum(means) / len(means))
    variances = [Path(str(p).replace(".exr", "-var.exr")) for p in inputs]
    if all(v.exists() for v in variances):
        mref.write_exr(str(out).replace(".exr", "-var.exr"), sum(read_exr(v) for v in variances) / len(inputs) ** 2)
    spp = 4096 * len(inputs)
    Path(str(out).replace(".exr", ".json")).write_text(json.dumps({"spp": spp, "combined_from": [Path(p).name for p in inputs]}, indent=1) + "\n")
    print(f"{out}: mean of {len(inputs)} references ({spp} spp)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vlf", default=str(ROOT / "target/release/vlf"))
    ap.add_argument("--check", action="store_true", help="fail if docs/guide/accuracy.md's block differs from docs/results/accuracy.json")
    ap.add_argument("--combine", nargs="+", metavar=("OUT", "IN"))
    a = ap.parse_args()
    if a.combine:
        combine(a.combine[0], a.combine[1:])
        return 0
    readme = ROOT / PAGE
    text = readme.read_text()
    if a.check:
        saved = json.loads((ROOT / "docs/results/accuracy.json").read_text())
        expected = block(saved["views"], saved)
        if expected not in text:
            sys.exit(f"{PAGE}'s accuracy block is stale: run python3 tools/accuracy.py")
        print(f"{PAGE}'s accuracy block matches docs/results/accuracy.json")
        return 0
    meta = {"gpu": (RESULTS / "gpu.txt").read_text().strip().split(",")[0], "commit": (RESULTS / "commit.txt").read_text().strip()}
    rows = measure(a.vlf)
    (ROOT / "docs/results/accuracy.json").write_text(json.dumps({**meta, "views": rows}, indent=1) + "\n")
    new = block(rows, meta)
    if BEGIN in text:
        start, end = text.index(BEGIN), text.index(END) + len(END)
        text = text[:start] + new + text[end:]
    else:
        text += "\n" + new + "\n"
    readme.write_text(text)
    print(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
