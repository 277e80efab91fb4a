#!/usr/bin/env python3
"""Alpha cut-outs against Mitsuba 3 (issue 29, items 2 and 4: a fence or foliage cut-out scene,
display MSE <= 4e-5 at 512x512 with a reference of >= 4096 spp).

    python3 tools/fence-accuracy.py VLF OUT [--scene scenes/fence/scene.toml] [--camera NAME]
        [--size 512x512] [--spp 4096] [--variant scalar_rgb] [--vlf-arg ARG ...] [--vlf-exr FILE]

Renders the scene twice: vlf from its light field (`vlf render`, the cut-outs' holes in the
visibility lists, shadow rays and eye rays) and Mitsuba 3 path tracing the scene as
tools/mitsuba/reference.py reads it on its own (the cut-out as a `mask` BSDF over a thresholded
opacity texture). Writes OUT/vlf.exr, OUT/mitsuba.exr (+ its variance), OUT/error.png (|sRGB
difference| x 10) and OUT/fence-accuracy.json: display MSE (sRGB, clamped, as vlf compare) and
relMSE over the image, with the reference's own noise (its variance, through the sRGB curve for
display MSE), the bound and whether it is met, the times.
"""

import argparse
import importlib.util
import json
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
# the helpers of the moving objects' comparison (run, mitsuba, figures, srgb, exr and png I/O)
_spec = importlib.util.spec_from_file_location("body_accuracy", HERE / "body-accuracy.py")
body = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(body)

# the bound for a fence or foliage cut-out scene
DISPLAY_MSE_BOUND = 4e-5


def main(doc=__doc__, scene="fence", bound=DISPLAY_MSE_BOUND, name="fence-accuracy", size="512x512", spp=4096):
    """The comparison of scenes/SCENE/ with Mitsuba 3 against BOUND, into OUT/NAME.json (also
    tools/normalmap-accuracy.py's, with its own scene, bound and defaults)."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("vlf")
    ap.add_argument("out")
    ap.add_argument("--scene", default=str(HERE.parent / "scenes" / scene / "scene.toml"))
    ap.add_argument("--camera")
    ap.add_argument("--size", default=size)
    ap.add_argument("--spp", type=int, default=spp)
    ap.add_argument("--variant", default="scalar_rgb", help="scalar_rgb (default: no LLVM needed), llvm_ad_rgb or cuda_ad_rgb")
    ap.add_argument("--vlf-arg", action="append", default=[], help="passed on to vlf render (e.g. --quality=draft)")
    ap.add_argument("--vlf-exr", help="vlf's image made elsewhere by the same `vlf render` command")
    ap.add_argument("--machine", default="", help="where the figures were made, recorded in the JSON")
    x = ap.parse_args()
    out = Path(x.out)
    out.mkdir(parents=True, exist_ok=True)
    cam = ["--camera", x.camera] if x.camera else []
    seconds = {}
    if x.vlf_exr:
        shutil.copy(x.vlf_exr, out / "vlf.exr")
    else:
        seconds["vlf_render"] = body.run([x.vlf, "render", x.scene, "--size", x.size, *cam, *x.vlf_arg,
                                          "-o", out / "vlf.exr"])
    seconds["mitsuba"] = body.mitsuba(x.scene, None, out / "mitsuba.exr", x.camera, x.size, x.spp, x.variant)
    a, b = body.read_exr(out / "vlf.exr"), body.read_exr(out / "mitsuba.exr")
    var_b = body.read_exr(out / "mitsuba-var.exr")
    whole = body.figures(a, b, var_b, (a[:, :, 0] == a[:, :, 0]))
    # the reference's own noise in display terms: its variance through the sRGB curve's slope
    slope = (body.srgb(b + 1e-4) - body.srgb(b)) / 1e-4
    whole["display_mse_noise"] = float((slope * slope * var_b).mean())
    report = {
        "scene": x.scene, "camera": x.camera, "size": x.size, "spp": x.spp, "variant": x.variant,
        "vlf_args": x.vlf_arg, "machine": x.machine, "seconds": seconds, "whole": whole,
        "display_mse_bound": bound, "within_bound": whole["display_mse"] <= bound,
    }
    (out / f"{name}.json").write_text(json.dumps(report, indent=2) + "\n")
    err = abs(body.srgb(a) - body.srgb(b)).mean(axis=-1)
    body.write_png(out / "error.png", (err * 10)[:, :, None].repeat(3, axis=-1))
    body.write_png(out / "vlf.png", body.srgb(a))
    body.write_png(out / "mitsuba.png", body.srgb(b))
    print(f"display MSE {whole['display_mse']:.2e} (bound {bound:.0e}: "
          f"{'met' if report['within_bound'] else 'NOT met'}; the reference's noise "
          f"{whole['display_mse_noise']:.1e})  relMSE {whole['rel_mse']:.2e} "
          f"(reference noise {whole['rel_mse_noise']:.1e})  mean ratio {whole['mean_ratio']:.4f}")
    print("seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in seconds.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
