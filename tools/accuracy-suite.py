#!/usr/bin/env python3
"""The accuracy suite on models made by other people: every view rendered from vlf's light field
at default settings (16 eye rays per pixel, as stills) and compared with Mitsuba 3 (>= 4096 spp,
`tools/mitsuba/reference.py`: its own glTF/OBJ import and ray casting, no vlf code), with vlf's own
path tracer (`vlf verify`, same spp) beside it.

    python3 tools/accuracy-suite.py list                       # the views, one per line (for the
                                                               # GPU script)
    bash tools/gpu-accuracy-suite.sh VLF OUT [NAME...]         # on the lent GPU: verify + Mitsuba
                                                               # + this script's `measure`
    python3 tools/accuracy-suite.py measure OUT --vlf VLF      # OUT/suite.json, pictures (runs on
                                                               # the GPU machine, after the renders)
    python3 tools/accuracy-suite.py report [RESULTS]           # the guide's block from RESULTS
                                                               # (default docs/results/h100/
                                                               # accuracy-suite/suite.json)
    python3 tools/accuracy-suite.py report --check             # fail if the block is stale

Targets (issue "real models as right as the Cornell box"), on every view at default settings:
image mean within 1% of the reference, display MSE <= 1e-4, away from edges <= 5e-5, relMSE <=
2e-3. The reference's own noise (from its per-pixel variance) is listed beside each figure: it
adds to what a comparison measures. A missed target names where the error sits: the materials
(Mitsuba's per-material shapes) that hold most of the squared error.

Models (README of tools/models/ and tools/get-models.sh say where each comes from and its licence):
the Space Ship Hallway (shipped, CC-BY 4.0), the generated classroom (`vlf generate classroom`),
scenes/small-things (tools/make-small-things.py: detail below a texel and a grid cell), Bitterli's
classroom, breakfast room, living room and staircase (CC-BY 3.0, fetched into models/), and
Khronos Sponza (tools/get-sponza.sh) where present.
"""
import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools" / "mitsuba"))
sys.path.insert(0, str(ROOT / "tools"))
from accuracy import read_exr, reference_noise, srgb, vlf_compare  # noqa: E402  (one definition of each)

SIZE = (640, 360)
SPP = 4096
TARGETS = {"mean_off": 0.01, "display_mse": 1e-4, "display_mse_away": 5e-5, "rel_mse": 2e-3}
# name, scene (relative to the repository), cameras (None: every camera of the scene)
MODELS = [
    ("space-ship-hallway", "scenes/space-ship-hallway/scene.toml", ["hallway", "corner"]),
    ("generated-classroom", "models/generated-classroom/scene.toml", ["front"]),
    ("small-things", "scenes/small-things/scene.toml", ["table", "room", "handle"]),
    ("bitterli-classroom", "models/classroom/scene.toml", None),
    ("bitterli-dining-room", "models/dining-room/scene.toml", None),
    ("bitterli-living-room", "models/living-room/scene.toml", None),
    ("bitterli-staircase", "models/staircase/scene.toml", None),
    ("sponza", "models/sponza/scene.toml", None),
]
GENERATED = {"generated-classroom": "vlf generate classroom --size 10000 --out models/generated-classroom",
             "sponza": "bash tools/get-sponza.sh"}
RESULTS = ROOT / "docs/results/h100/accuracy-suite"
PICTURES = ROOT / "docs/images"
PAGE = ROOT / "docs/guide/accuracy.md"
BEGIN, END = "<!-- accuracy-suite:begin (tools/accuracy-suite.py) -->", "<!-- accuracy-suite:end -->"


def scene_cameras(scene):
    import tomllib
    doc = tomllib.loads(Path(scene).read_text())
    return [c["name"] for c in doc.get("camera", [])]


def cmd_list(args):
    """NAME SCENE CAMERA per line, for the models present (generated ones always)."""
    for name, scene, cameras in MODELS:
        if args.names and name not in args.names:
            continue
        if not (ROOT / scene).exists():
            how = GENERATED.get(name, "bash tools/get-models.sh")
            print(f"# {name}: {scene} missing: {how}", file=sys.stderr)
            continue
        cams = cameras or scene_cameras(ROOT / scene)
        for cam in cams:
            print(name, scene, cam)


def where_error_sits(image, ref, shape_ids, names, top=4):
    """The materials that hold the most squared display error, with their share and mean ratio."""
    import numpy as np
    err = ((srgb(image) - srgb(ref)) ** 2).sum(axis=2)
    total = err.sum() + 1e-30
    rows = []
    for sid in np.unique(shape_ids):
        m = shape_ids == sid
        share = float(err[m].sum() / total)
        ratio = float(image[m].mean() / max(ref[m].mean(), 1e-30))
        rows.append({"surface": names.get(int(sid), "sky" if sid < 0 else str(sid)), "error_share": share,
                     "pixels": int(m.sum()), "mean_ratio": ratio})
    rows.sort(key=lambda r: -r["error_share"])
    return rows[:top]


def write_picture(path, image, ref):
    """vlf | Mitsuba | the light field's error relative to Mitsuba (red brighter, blue darker,
    full colour at 20%), each at half the compared size."""
    import numpy as np
    half = lambda a: a[: a.shape[0] // 2 * 2, : a.shape[1] // 2 * 2].reshape(a.shape[0] // 2, 2, a.shape[1] // 2, 2, -1).mean(axis=(1, 3))
    rel = (image.mean(axis=2) + 1e-3) / (ref.mean(axis=2) + 1e-3) - 1.0
    t = np.clip(rel / 0.2, -1.0, 1.0)
    err = np.stack([np.clip(t, 0, 1), np.zeros_like(t), np.clip(-t, 0, 1)], axis=-1) ** 2.2  # linear for srgb_png
    import mitsuba as mi
    x = srgb(np.concatenate([half(image), half(ref), half(err)], axis=1))
    path.parent.mkdir(parents=True, exist_ok=True)
    mi.Bitmap((x * 255 + 0.5).astype(np.uint8), mi.Bitmap.PixelFormat.RGB).write(str(path), quality=85)


def cmd_pack(args):
    """One view's Mitsuba renders in one small file: mean and standard deviation of the mean as
    float16 (rounding adds < 1e-7 to any display MSE here), the edge mask, the surfaces seen."""
    import numpy as np
    import mitsuba as mi
    prefix = Path(args.prefix)
    mean = read_exr(f"{prefix}.exr")
    std = np.sqrt(np.maximum(read_exr(f"{prefix}-var.exr"), 0.0))
    keep = np.array(mi.Bitmap(f"{prefix}-edges.png"), dtype=np.float64)[:, :, 0] > 127
    surfaces = json.loads(Path(f"{prefix}-surfaces.json").read_text())
    ids = np.array(surfaces["ids"], dtype=np.int32).reshape(mean.shape[:2])
    np.savez_compressed(args.out, mean=mean.astype(np.float16), std=std.astype(np.float16), keep=keep, ids=ids,
                        names=json.dumps(surfaces["names"]), seconds=float(args.seconds or 0.0))


def measure_view(vlf, refs, lf_dir, name, scene, cam, tmp):
    import numpy as np
    import reference as mref
    tag = f"{name}-{cam}"
    packed = np.load(refs / f"{tag}.npz")
    ref = packed["mean"].astype(np.float64)
    var = packed["std"].astype(np.float64) ** 2
    keep = packed["keep"]
    lf = lf_dir / name / f"{cam}-lightfield.exr"
    image = read_exr(lf)
    ref_exr, mask = tmp / f"{tag}-mitsuba.exr", tmp / f"{tag}-edges.png"
    mref.write_exr(ref_exr, ref)
    mref.srgb_png(mask, np.stack([keep.astype(np.float64)] * 3, axis=-1))
    all_px = vlf_compare(vlf, lf, ref_exr)
    away = vlf_compare(vlf, lf, ref_exr, mask=mask)
    write_picture(PICTURES / f"suite-{tag}.jpg", image, ref)
    verify = json.loads((lf_dir / name / "verify.json").read_text())
    vview = next(v for v in verify["views"] if v["camera"] == cam)
    everywhere = np.ones(keep.shape, dtype=bool)
    row = {
        "model": name, "scene": scene, "camera": cam, "size": [image.shape[1], image.shape[0]],
        "reference_spp": SPP, "reference_seconds": float(packed["seconds"]),
        "mean_ratio": float(image.mean() / ref.mean()),
        "all_pixels": all_px, "away_from_edges": away,
        "edge_free_share": float(keep.mean()),
        "reference_noise_all": reference_noise(ref, var, everywhere[:, :, None].repeat(3, 2)),
        "reference_noise_away": reference_noise(ref, var, keep[:, :, None].repeat(3, 2)),
        # vlf's own path tracer at the same spp, against the light field (vlf verify) and its
        # mean against Mitsuba's: the two references agree where this is 1
        "vlf_verify": {"mean_ratio": vview["mean_ratio"], "display_mse": vview["comparison"]["display_mse"],
                       "rel_mse": vview["comparison"]["rel_mse"]},
        "vlf_reference_mean_ratio": float(vview["mean_ratio"] ** -1 * image.mean() / ref.mean()),
    }
    names = {int(k): re.sub(r"^\d+-", "", v) for k, v in json.loads(str(packed["names"])).items()}
    row["error_by_surface"] = where_error_sits(image, ref, packed["ids"], names)
    row["missed"] = missed(row)
    return row


def missed(row):
    out = []
    off = row["mean_ratio"] - 1.0
    if abs(off) > TARGETS["mean_off"]:
        out.append(f"{abs(off) * 100:.1f}% {'darker' if off < 0 else 'brighter'} than the reference")
    checks = [(row["all_pixels"]["display_mse"], TARGETS["display_mse"], row["reference_noise_all"]["display_mse"], "display MSE"),
              (row["away_from_edges"]["display_mse"], TARGETS["display_mse_away"], row["reference_noise_away"]["display_mse"], "display MSE away from edges"),
              (row["all_pixels"]["rel_mse"], TARGETS["rel_mse"], row["reference_noise_all"]["rel_mse"], "relMSE")]
    for value, target, noise, what in checks:
        if value > target and value - noise > target:
            out.append(f"{what} {value:.1e} > {target:.0e}")
    return out


def cmd_measure(args):
    import tempfile
    refs, lf_dir = Path(args.references), Path(args.lightfield)
    rows = []
    with tempfile.TemporaryDirectory(prefix="vlf-suite-") as tmp:
        for line in (lf_dir / "views.txt").read_text().splitlines():
            name, scene, cam = line.split()
            if not (refs / f"{name}-{cam}.npz").exists() or not (lf_dir / name / f"{cam}-lightfield.exr").exists():
                print(f"{name} {cam}: a render is missing (references in {refs}, light field in {lf_dir})", file=sys.stderr)
                continue
            row = measure_view(args.vlf, refs, lf_dir, name, scene, cam, Path(tmp))
            rows.append(row)
            print(f"{name:22} {cam:8} mean {row['mean_ratio']:.4f}  display MSE {row['all_pixels']['display_mse']:.2e}"
                  f"  away {row['away_from_edges']['display_mse']:.2e}  relMSE {row['all_pixels']['rel_mse']:.2e}"
                  f"  {'; '.join(row['missed']) or 'all targets met'}")
    meta = {k: (lf_dir / f"{k}.txt").read_text().strip() for k in ["gpu", "commit"] if (lf_dir / f"{k}.txt").exists()}
    meta["mitsuba_variant"] = (refs / "variant.txt").read_text().strip() if (refs / "variant.txt").exists() else "?"
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "suite.json").write_text(json.dumps({**meta, "targets": TARGETS, "views": rows}, indent=1) + "\n")
    print(f"{RESULTS / 'suite.json'}: {len(rows)} views")


def fmt_verdict(value, target, noise):
    if value <= target:
        return f"{value:.1e}"
    if value - noise <= target:
        return f"{value:.1e} (met without the reference's noise)"
    return f"**{value:.1e}**"


def block(saved):
    t = saved["targets"]
    lines = [BEGIN, "",
             f"Default settings (`vlf render`: 16 eye rays per pixel), {saved['views'][0]['size'][0]}x{saved['views'][0]['size'][1]}, "
             f"on {saved.get('gpu', 'the lent GPU')} at commit {saved.get('commit', '?')}, against Mitsuba 3 at "
             f"{saved['views'][0]['reference_spp']} spp (`tools/mitsuba/reference.py`: its own glTF/OBJ import, no vlf code). "
             f"Targets: mean within {t['mean_off'] * 100:.0f}%, display MSE <= {t['display_mse']:.0e}, away from edges <= "
             f"{t['display_mse_away']:.0e}, relMSE <= {t['rel_mse']:.0e}; a figure in bold misses its target after the "
             f"reference's own noise (listed) is taken out. `vlf reference` (vlf's path tracer, same spp) against Mitsuba in "
             f"the last column. Generated by `python3 tools/accuracy-suite.py report` from "
             f"`docs/results/h100/accuracy-suite/suite.json` (made by `bash tools/gpu-accuracy-suite.sh`).", "",
             "| model | view | mean ratio | display MSE | away from edges | relMSE | reference noise (display MSE) | where the error sits | vlf reference / Mitsuba |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in saved["views"]:
        a, e = r["all_pixels"], r["away_from_edges"]
        off = abs(r["mean_ratio"] - 1.0) > t["mean_off"]
        mean = f"**{r['mean_ratio']:.4f}**" if off else f"{r['mean_ratio']:.4f}"
        sits = ", ".join(f"{s['surface']} {s['error_share'] * 100:.0f}% ({s['mean_ratio']:.2f})" for s in r.get("error_by_surface", [])[:3])
        lines.append(
            f"| {r['model']} | {r['camera']} | {mean} | {fmt_verdict(a['display_mse'], t['display_mse'], r['reference_noise_all']['display_mse'])} "
            f"| {fmt_verdict(e['display_mse'], t['display_mse_away'], r['reference_noise_away']['display_mse'])} "
            f"| {fmt_verdict(a['rel_mse'], t['rel_mse'], r['reference_noise_all']['rel_mse'])} "
            f"| {r['reference_noise_all']['display_mse']:.1e} | {sits or '-'} | {r['vlf_reference_mean_ratio']:.4f} |")
    lines += ["", "Where the error sits: the surfaces (materials) holding the largest share of the squared display error, "
              "with the light field's mean ratio to Mitsuba on them in brackets. Each picture: vlf | Mitsuba | the light "
              "field's error relative to Mitsuba (red brighter, blue darker, full colour at 20%).", "",
              "| model | views |", "|---|---|"]
    by_model = {}
    for r in saved["views"]:
        by_model.setdefault(r["model"], []).append(r["camera"])
    for model, cams in by_model.items():
        pics = " ".join(f"![{model} {c}](../images/suite-{model}-{c}.jpg)" for c in cams)
        lines.append(f"| {model} | {pics} |")
    lines += ["", END]
    return "\n".join(lines)


def cmd_report(args):
    results = Path(args.results)
    saved = json.loads(results.read_text())
    text = PAGE.read_text()
    new = block(saved)
    if args.check:
        if new not in text:
            sys.exit(f"{PAGE.name}'s accuracy-suite block is stale: run python3 tools/accuracy-suite.py report")
        print(f"{PAGE.name}'s accuracy-suite block matches {results}")
        return
    if BEGIN in text:
        text = text[:text.index(BEGIN)] + new + text[text.index(END) + len(END):]
    else:
        text += "\n" + new + "\n"
    PAGE.write_text(text)
    print(new)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("list")
    p.add_argument("names", nargs="*")
    p = sub.add_parser("pack")
    p.add_argument("prefix")
    p.add_argument("out")
    p.add_argument("--seconds")
    p = sub.add_parser("measure")
    p.add_argument("references", help="the folder of <model>-<camera>.npz (gpu-accuracy-suite.sh references)")
    p.add_argument("lightfield", help="the folder of gpu-accuracy-suite.sh lightfield")
    p.add_argument("--vlf", default=str(ROOT / "target/release/vlf"))
    p = sub.add_parser("report")
    p.add_argument("results", nargs="?", default=str(RESULTS / "suite.json"))
    p.add_argument("--check", action="store_true")
    args = ap.parse_args()
    {"list": cmd_list, "pack": cmd_pack, "measure": cmd_measure, "report": cmd_report}[args.cmd](args)


if __name__ == "__main__":
    main()
