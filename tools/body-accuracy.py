#!/usr/bin/env python3
"""Moving objects against an independent reference (issue "a body in the light field", item 5).

    python3 tools/body-accuracy.py VLF SCENE OBJECTS OUT [--camera NAME] [--size WxH] [--spp N]
        [--variant scalar_rgb|llvm_ad_rgb|cuda_ad_rgb] [--vlf-arg ARG ...]

Freezes the objects of OBJECTS (a file of [[object]] tables, posed with the camera as the head)
and renders the scene with them twice:
  - vlf: `vlf render SCENE --objects OBJECTS` (the light field, the objects lit by its probes,
    their shadows subtracted per pixel, their reflections traced);
  - Mitsuba 3: `vlf export mitsuba SCENE --objects OBJECTS` (the objects as ordinary geometry:
    the full solution, with the light they block and the light they reflect), path traced.
(--vlf-exr takes vlf's image made on a GPU.) Two more Mitsuba renders at a quarter of the samples find where the error is: the objects
painted black (their pixels, seen directly or in a mirror, are where the black render is under
half the full one) and the scene without them (their shadow: where the black render is more
than 8% under the empty scene, in 5x5 means). Writes OUT/vlf.exr, OUT/mitsuba.exr, OUT/masks.png,
OUT/error.png and OUT/body-accuracy.json: display MSE (sRGB, clamped, as vlf compare) and
relMSE ((a-b)^2/(b^2+0.01)) over the whole image, the objects' pixels, their shadow and
elsewhere, with the reference's own noise (its variance) and the times.
"""

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REFERENCE_PY = HERE / "mitsuba" / "reference.py"


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def read_exr(path):
    import mitsuba as mi
    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[:, :, :3]


def write_png(path, rgb):
    import mitsuba as mi
    img = (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8)
    mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(path))


def run(cmd):
    start = time.time()
    out = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"error: {' '.join(map(str, cmd))}\n{out.stderr[-2000:]}")
    return time.time() - start


def mitsuba(scene, extra_obj, out, camera, size, spp, variant, seed=1):
    """Path trace SCENE (with EXTRA_OBJ as geometry, if given) with reference.py; returns the
    seconds taken. Writes OUT and OUT's variance beside it."""
    cmd = [sys.executable, REFERENCE_PY, scene, "--size", size, "--spp", spp, "--variant", variant,
           "--seed", seed, "-o", out, "--variance", str(out).replace(".exr", "-var.exr"), "--quiet"]
    if camera:
        cmd += ["--camera", camera]
    if extra_obj:
        cmd += ["--extra-obj", extra_obj]
    return run(cmd)


def blacken(obj, out_dir):
    """A copy of the exported objects with every material black (Kd 0, Ke 0)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    shutil.copy(obj, out_dir / "objects.obj")
    mtl = (obj.parent / "objects.mtl").read_text().splitlines()
    mtl = ["Kd 0 0 0" if l.startswith("Kd ") else "Ke 0 0 0" if l.startswith("Ke ") else l for l in mtl]
    (out_dir / "objects.mtl").write_text("\n".join(mtl) + "\n")
    return out_dir / "objects.obj"


def box5(img):
    """The mean over each pixel's 5 x 5 neighbourhood (clamped at the borders)."""
    padded = np.pad(img, 2, mode="edge")
    h, w = img.shape
    return sum(padded[dy:dy + h, dx:dx + w] for dy in range(5) for dx in range(5)) / 25.0


def figures(a, b, var_b, mask):
    """display MSE, relMSE and the reference noise's share of relMSE over the pixels of MASK."""
    if not mask.any():
        return {"pixels": 0}
    d = srgb(a[mask]) - srgb(b[mask])
    rel = (a[mask] - b[mask]) ** 2 / (b[mask] ** 2 + 0.01)
    noise = var_b[mask] / (b[mask] ** 2 + 0.01)
    return {"pixels": int(mask.sum()), "display_mse": float(np.mean(d * d)), "rel_mse": float(np.mean(rel)),
            "rel_mse_noise": float(np.mean(noise)), "mean_ratio": float(a[mask].mean() / max(b[mask].mean(), 1e-30))}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("vlf")
    ap.add_argument("scene")
    ap.add_argument("objects")
    ap.add_argument("out")
    ap.add_argument("--camera")
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("--variant", default="scalar_rgb", help="scalar_rgb (default: no LLVM needed), llvm_ad_rgb or cuda_ad_rgb")
    ap.add_argument("--vlf-arg", action="append", default=[], help="passed on to vlf render (e.g. --quality=draft)")
    ap.add_argument("--vlf-exr", help="vlf's image made elsewhere (e.g. on a GPU, by the same `vlf render` command) "
                    "instead of rendering it here")
    ap.add_argument("--reuse-references", action="store_true",
                    help="keep OUT's Mitsuba images where they exist (the same scene, objects, size and spp)")
    x = ap.parse_args()
    out = Path(x.out)
    out.mkdir(parents=True, exist_ok=True)
    cam = ["--camera", x.camera] if x.camera else []
    seconds = {}
    if x.vlf_exr:
        shutil.copy(x.vlf_exr, out / "vlf.exr")
    else:
        seconds["vlf_render"] = run([x.vlf, "render", x.scene, "--objects", x.objects, "--size", x.size, *cam,
                                     *x.vlf_arg, "-o", out / "vlf.exr"])
    seconds["export"] = run([x.vlf, "export", "mitsuba", x.scene, "--objects", x.objects, *cam, "-o", out / "export"])
    obj = out / "export" / "objects.obj"
    black = blacken(obj, out / "black")
    quarter = max(x.spp // 4, 16)
    for name, extra, spp, seed in (("mitsuba", obj, x.spp, 1), ("black", black, quarter, 2), ("empty", None, quarter, 3)):
        if not (x.reuse_references and (out / f"{name}.exr").exists()):
            seconds[name] = mitsuba(x.scene, extra, out / f"{name}.exr", x.camera, x.size, spp, x.variant, seed)
    a, b = read_exr(out / "vlf.exr"), read_exr(out / "mitsuba.exr")
    var_b = read_exr(out / "mitsuba-var.exr")
    black_img, empty = read_exr(out / "black.exr"), read_exr(out / "empty.exr")
    lum = lambda img: img @ np.array([0.2126, 0.7152, 0.0722])
    full_l, black_l, empty_l = lum(b), lum(black_img), lum(empty)
    figure = black_l < 0.5 * full_l
    # the shadow from 5x5 means (the two quarter-sample renders' noise would scatter it)
    smooth_black, smooth_empty = box5(black_l), box5(empty_l)
    shadow = ~figure & (smooth_black < 0.92 * smooth_empty) & (smooth_empty - smooth_black > 0.002)
    elsewhere = ~figure & ~shadow
    every = np.ones_like(figure)
    report = {
        "scene": x.scene, "objects": x.objects, "camera": x.camera, "size": x.size, "spp": x.spp,
        "variant": x.variant, "vlf_args": x.vlf_arg, "seconds": seconds,
        "whole": figures(a, b, var_b, every), "figure": figures(a, b, var_b, figure),
        "shadow": figures(a, b, var_b, shadow), "elsewhere": figures(a, b, var_b, elsewhere),
    }
    (out / "body-accuracy.json").write_text(json.dumps(report, indent=2) + "\n")
    masks = np.stack([figure, shadow, np.zeros_like(figure)], axis=-1).astype(np.float64)
    write_png(out / "masks.png", masks)
    err = np.abs(srgb(a) - srgb(b)).mean(axis=-1)
    write_png(out / "error.png", np.repeat((err * 10)[:, :, None], 3, axis=-1))
    for part in ("whole", "figure", "shadow", "elsewhere"):
        f = report[part]
        if f["pixels"]:
            print(f"{part:10s} {f['pixels']:7d} px  display MSE {f['display_mse']:.2e}  relMSE {f['rel_mse']:.2e} "
                  f"(noise {f['rel_mse_noise']:.1e})  mean ratio {f['mean_ratio']:.4f}")
    print("seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in seconds.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
