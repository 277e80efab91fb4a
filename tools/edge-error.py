#!/usr/bin/env python3
"""Edge antialiasing's runs of one scene (tools/gpu-edges.sh): per variant the views' GPU times
from the run's JSON report and the edge error, the display MSE of each view's last frame
(`vlf compare` on the EXRs) against the same view of the 16-eye-ray run (aa16), averaged over
the views. Prints a table and writes WORK/edges-SCENE.json.

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


def edge_error(vlf, work, scene, variant):
    """The views' display MSE against aa16's (None for aa16 itself, or without its images)."""
    reference_dir = f"{work}/out-{scene}-aa16"
    if variant == "aa16" or not os.path.isdir(reference_dir):
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
    print(f"{scene}: 8-view 1920x1200 walk CAVE, unpaced; edge error = display MSE of the last "
          f"frame's views against 16 eye rays per pixel")
    print(f"{'variant':<9} {'quality':<40} {'view p50':>9} {'view p99':>9} "
          f"{'frame p50':>10} {'frame p99':>10} {'edge error':>11}")
    for v in variants:
        report = json.load(open(f"{work}/cave-{scene}-{v}.json"))
        views = [x["gpu_ms"] or {} for x in report["views"]]
        frame = report["all_views_gpu_ms"] or {}
        errors = edge_error(vlf, work, scene, v)
        mean_error = sum(errors.values()) / len(errors) if errors else None
        rows[v] = {
            "quality": report["quality"],
            "frames": report["frames"],
            "view_gpu_ms_median": max(d.get("median", 0.0) for d in views),
            "view_gpu_ms_p99": max(d.get("p99", 0.0) for d in views),
            "frame_gpu_ms": frame,
            "edge_error_per_view": errors,
            "edge_error": mean_error,
        }
        r = rows[v]
        q = report["quality"]
        r["quality"] = (f"{q['eye_rays_per_pixel']} eye ray(s), {q.get('edge_samples') or '-'} at "
                        f"edges, {q['mirror_bounces']} reflection(s)")
        error = f"{mean_error:.3e}" if mean_error is not None else "reference"
        print(f"{v:<9} {r['quality']:<40} {r['view_gpu_ms_median']:9.3f} "
              f"{r['view_gpu_ms_p99']:9.3f} {frame.get('median', float('nan')):10.3f} "
              f"{frame.get('p99', float('nan')):10.3f} {error:>11}")
    json.dump(rows, open(f"{work}/edges-{scene}.json", "w"), indent=1)


if __name__ == "__main__":
    main()
