#!/usr/bin/env python3
"""Where an image is brighter or darker than its reference: a signed ratio map and the means.

    python3 tools/mitsuba/ratio-map.py IMAGE.exr REFERENCE.exr OUT.png [--json OUT.json]
        [--block 4] [--stops 0.5]

Both images linear RGB EXR of one size (e.g. a `vlf render` or `vlf verify` light field image
and a Mitsuba reference from tools/mitsuba/reference.py). The map: the luminance ratio of
BLOCKxBLOCK blocks, red where IMAGE is brighter, blue where darker, full colour at STOPS stops
(0.5: 41%), over the reference's grey picture for orientation. Printed (and in the JSON): the
image mean ratio, per channel, and per third of the picture (left, centre, right, top, middle,
bottom), which says where the difference sits. Needs Mitsuba 3 (its Bitmap reads and writes
the files) and numpy.
"""
import argparse
import json

import mitsuba as mi
import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def read(path):
    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[:, :, :3]


def thirds(image, reference):
    h, w = reference.shape[:2]
    parts = {
        "left": np.s_[:, : w // 3], "centre": np.s_[:, w // 3 : 2 * w // 3], "right": np.s_[:, 2 * w // 3 :],
        "top": np.s_[: h // 3], "middle": np.s_[h // 3 : 2 * h // 3], "bottom": np.s_[2 * h // 3 :],
    }
    return {name: float(image[s].mean() / max(reference[s].mean(), 1e-300)) for name, s in parts.items()}


def ratio_map(image, reference, block, stops):
    a, b = image @ LUMINANCE, reference @ LUMINANCE
    h, w = (a.shape[0] // block) * block, (a.shape[1] // block) * block
    shrink = lambda x: x[:h, :w].reshape(h // block, block, w // block, block).mean((1, 3))
    r = np.log2(np.maximum(shrink(a), 1e-9) / np.maximum(shrink(b), 1e-9)) / stops
    r = np.clip(r, -1.0, 1.0)
    colour = np.zeros(r.shape + (3,))
    colour[..., 0], colour[..., 2] = np.clip(r, 0, 1), np.clip(-r, 0, 1)
    colour = np.repeat(np.repeat(colour, block, 0), block, 1)
    grey = np.clip(b[:h, :w] ** (1 / 2.2), 0, 1)[..., None]
    return (0.6 * colour + 0.4 * grey).astype(np.float32)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("image")
    p.add_argument("reference")
    p.add_argument("out")
    p.add_argument("--json")
    p.add_argument("--block", type=int, default=4)
    p.add_argument("--stops", type=float, default=0.5)
    a = p.parse_args()
    mi.set_variant("scalar_rgb")
    image, reference = read(a.image), read(a.reference)
    if image.shape != reference.shape:
        raise SystemExit(f"ratio-map.py: {a.image} is {image.shape[1]}x{image.shape[0]}, "
                         f"{a.reference} {reference.shape[1]}x{reference.shape[0]}: sizes differ")
    result = {
        "mean_ratio": float(image.mean() / reference.mean()),
        "channel_ratios": [float(image[..., c].mean() / reference[..., c].mean()) for c in range(3)],
        "thirds": thirds(image, reference),
    }
    out = ratio_map(image, reference, a.block, a.stops)
    mi.Bitmap(out).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=False).write(a.out)
    print(f"mean ratio {result['mean_ratio']:.4f} (channels "
          + ", ".join(f"{r:.4f}" for r in result["channel_ratios"]) + "); by third: "
          + ", ".join(f"{k} {v:.4f}" for k, v in result["thirds"].items()) + f"; map: {a.out}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
