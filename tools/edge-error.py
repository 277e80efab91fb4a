#!/usr/bin/env python3
"""Edge antialiasing's runs of one scene (tools/gpu-edges.sh): per variant the views' GPU times
from the run's JSON report and the edge error, the display MSE of each view's last frame
(`vlf compare` on the EXRs) against the same view of the 16-eye-ray run (aa16) and of the
64-eye-ray run with a reflection per eye ray (ref64), averaged over the views. Prints a table and writes WORK/edges-SCENE.json.

    tools/edge-error.py VLF WORK SCENE VARIANT...
"""
import glob
import json
import os
import subprocess
import sys


def display_mse(vlf, image, reference):
    out = subprocess.run([vlf, "compare", "--json", image, reference], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out[out.index("{"):])["display_mse"]


def edge_error(vlf, work, scene, variant, against):
    """The views' display MSE against `against`'s (None for it, or without its images)."""
    reference_dir = f"{work}/out-{scene}-{against}"
    if variant == against or not os.path.isdir(reference_dir):
        return None
    errors = {}
    for image in sorted(glob.glob(f"{work}/out-{scene}-{variant}/*.exr")):
        name = os.path.basename(image)
        reference = f"{reference_dir}/{name}"
        if os.path.exists(reference):
            errors[name[:-4]] = display_mse(vlf, image, reference)
    return errors


def main():
    vlf, work, scene, variants = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
    rows = {}
    print(f"{scene}: 8-view 1920x1200 walk CAVE (paced-*: frame pacing on, else unpaced); edge "
          f"error = display MSE of the last frame's views against aa16's and ref64's; frame max = "
          f"the CPU frame time's")
    print(f"{'variant':<9} {'quality':<40} {'rays/px':>7} {'view p50':>9} {'view p99':>9} "
          f"{'frame p50':>10} {'frame p99':>10} {'p99/p50':>8} {'frame max':>10} {'vs aa16':>10} "
          f"{'vs ref64':>10}")
    for v in variants:
        report = json.load(open(f"{work}/cave-{scene}-{v}.json"))
        views = [x["gpu_ms"] or {} for x in report["views"]]
        frame = report["all_views_gpu_ms"] or {}
        errors = {a: edge_error(vlf, work, scene, v, a) for a in ("aa16", "ref64")}
        means = {a: (sum(e.values()) / len(e) if e else None) for a, e in errors.items()}
        rays = report.get("eye_rays_per_pixel_last_frame") or report["quality"]["eye_rays_per_pixel"]
        rows[v] = {
            "quality": report["quality"],
            "frames": report["frames"],
            "view_gpu_ms_median": max(d.get("median", 0.0) for d in views),
            "view_gpu_ms_p99": max(d.get("p99", 0.0) for d in views),
            "frame_gpu_ms": frame,
            "eye_rays_per_pixel_last_frame": rays,
            "refined_last_frame": report.get("refined_last_frame"),
            "edge_error_per_view": errors,
            "edge_error": means,
            "worst_p99_over_p50": report.get("worst_p99_over_p50"),
            "cpu_frame_ms_max": report["cpu_frame_ms"]["max"],
        }
        r = rows[v]
        q = report["quality"]
        r["quality"] = (f"{q['eye_rays_per_pixel']} eye ray(s), {q.get('edge_samples') or '-'} at "
                        f"edges, {q['mirror_bounces']} reflection(s)")
        shown = {a: (f"{m:.3e}" if m is not None else "-") for a, m in means.items()}
        print(f"{v:<9} {r['quality']:<40} {rays:7.2f} {r['view_gpu_ms_median']:9.3f} "
              f"{r['view_gpu_ms_p99']:9.3f} {frame.get('median', float('nan')):10.3f} "
              f"{frame.get('p99', float('nan')):10.3f} {r['worst_p99_over_p50'] or float('nan'):8.3f} "
              f"{r['cpu_frame_ms_max']:10.3f} {shown['aa16']:>10} {shown['ref64']:>10}")
    json.dump(rows, open(f"{work}/edges-{scene}.json", "w"), indent=1)


if __name__ == "__main__":
    main()
