#!/usr/bin/env python3
"""Compare two independent Monte Carlo renders and say whether they differ by more than noise.

    python3 tools/mitsuba/compare.py A.exr B.exr [--var-a VA.exr] [--var-b VB.exr] [--json]

relMSE is vlf's (`vlf compare`): mean over pixels and channels of (a-b)^2 / (b^2 + 0.01).
With the variance images (variance of each pixel's mean: `vlf reference --variance`,
`reference.py --variance`) it also gives the relMSE that noise alone would produce, the
chi-square per pixel-channel of the differences (about 1 when the renders agree up to noise),
and the mean of each channel over the image with its standard error (a bias of the whole
picture shows up here long before it does in relMSE).
"""

import argparse
import json
import sys

import numpy as np


def read(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    bmp = mi.Bitmap(path)
    a = np.array(bmp, dtype=np.float64)
    return a[:, :, :3]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a")
    ap.add_argument("b", help="the reference in vlf's relMSE")
    ap.add_argument("--var-a")
    ap.add_argument("--var-b")
    ap.add_argument("--json", action="store_true")
    x = ap.parse_args()
    a, b = read(x.a), read(x.b)
    if a.shape != b.shape:
        sys.exit(f"sizes differ: {a.shape} vs {b.shape}")
    d = a - b
    out = {
        "relmse": float(np.mean(d * d / (b * b + 0.01))),
        "mse": float(np.mean(d * d)),
        "mean_a": a.reshape(-1, 3).mean(axis=0).tolist(),
        "mean_b": b.reshape(-1, 3).mean(axis=0).tolist(),
    }
    out["mean_ratio_a_over_b"] = (np.array(out["mean_a"]) / np.array(out["mean_b"])).tolist()
    if x.var_a and x.var_b:
        v = read(x.var_a) + read(x.var_b)
        out["relmse_expected_from_noise"] = float(np.mean(v / (b * b + 0.01)))
        ok = v > 0
        out["chi2_per_sample"] = float(np.mean(d[ok] ** 2 / v[ok]))
        # image mean per channel: difference and its standard error (pixels independent)
        n = d.shape[0] * d.shape[1]
        diff = d.reshape(-1, 3).mean(axis=0)
        se = np.sqrt(v.reshape(-1, 3).sum(axis=0)) / n
        out["mean_diff"] = diff.tolist()
        out["mean_diff_stderr"] = se.tolist()
        out["mean_diff_z"] = (diff / se).tolist()
        # the same per block of 16x16 pixels: a local bias (a misplaced edge, a wrong
        # reflection) shows as |z| well above what 3 x blocks tests give by chance (~3-4)
        bs = 16
        h, w = (d.shape[0] // bs) * bs, (d.shape[1] // bs) * bs
        if h and w:
            blk = lambda t: t[:h, :w].reshape(h // bs, bs, w // bs, bs, 3).sum(axis=(1, 3))
            z = blk(d) / np.sqrt(np.maximum(blk(v), 1e-30))
            out["block16_max_abs_z"] = float(np.abs(z).max())
            out["block16_frac_abs_z_gt_3"] = float(np.mean(np.abs(z) > 3))
    if x.json:
        print(json.dumps(out, indent=1))
    else:
        for k, val in out.items():
            if isinstance(val, list):
                val = "  ".join(f"{c:.5g}" for c in val)
            else:
                val = f"{val:.4g}"
            print(f"{k:28s} {val}")


if __name__ == "__main__":
    main()
