"""BENCHMARKS.md's section on edge antialiasing, from what tools/gpu-edges.sh wrote into DIR
(docs/results/h200/edges/: a folder per build, each with `edges-<scene>.json` from
tools/edge-error.py): per scene and variant the eye rays per pixel the last frame drew, the
frame's GPU median and p99, the views' worst p99/p50, the CPU frame's maximum and the edge error
against 16 eye rays per pixel (and against 64 of their own reflection where the build ran them).
Called by tools/benchmarks-md.sh.   python3 tools/edges-md.py DIR"""
import json
import os
import sys

# the builds, newest first, and what each ran (DIR/README.md says more)
FOLDERS = [
    ("6da8314-gallery-3000", "the mirror gallery's walk, paced with 8 at edges; 3000 frames (its walk at "
     "about half its speed)"),
    ("6da8314-gallery", "the mirror gallery's walk; 150 frames a run"),
    ("e878842-3000", "paced, the pacer learning each view's cost of an eye ray; 3000 frames a run "
     "(the 12 s walk at 0.48x its speed)"),
    ("e878842", "the same, 150 frames a run (the walk at about 10x its speed)"),
    ("ff4f2c7", "a refined pixel's eye rays cast side by side; 150 frames a run"),
    ("aaafd6b", "paced, edges refined only in the tiles the pacer gives 2 eye rays or more"),
    ("5499b50", "unpaced and paced (`paced-*`: frame pacing on)"),
    ("5af0e9d", "unpaced, with 64 eye rays of their own reflection as a second reference"),
]
SCENES = [
    ("classroom-100k", "the 100K-triangle classroom with a mirror"),
    ("classroom-1m", "the 1M-triangle classroom with a mirror"),
    ("gallery", "the mirror gallery (mirrors facing each other, two reflections)"),
]


def error(value):
    return f"{value:.2e}" if value is not None else "-"


def drawn_with(q):
    """A run's quality, in words: its eye rays per pixel (a paced range), edges, reflections."""
    low, high = q["eye_rays_per_pixel"], q["paced_eye_rays_per_pixel"]
    rays = f"{low}" if low == high else f"{low}-{high} (paced)"
    edges = f", {q['edge_samples']} at edges" if q.get("edge_samples") else ""
    return f"{rays} eye rays{edges}, {q['mirror_bounces']} reflection(s)"


def table(rows, reports):
    lines = [
        "| variant | drawn with | eye rays per pixel | frame GPU p50 | p99 | views' p99/p50 "
        "| frame max (CPU) | edge error vs 16 | vs 64 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for variant, r in rows.items():
        report = reports[variant]
        frame = r["frame_gpu_ms"]
        ratio = report.get("worst_p99_over_p50")
        top = report["cpu_frame_ms"]["max"]
        lines.append(
            f"| {variant} | {drawn_with(report['quality'])} | {r['eye_rays_per_pixel_last_frame']:.2f} "
            f"| {frame['median']:.2f} ms | {frame['p99']:.2f} ms "
            f"| {f'{ratio:.3f}' if ratio is not None else '-'} "
            f"| {top:.2f} ms "
            f"| {error(r['edge_error'].get('aa16'))} | {error(r['edge_error'].get('ref64'))} |"
        )
    return "\n".join(lines)


def main():
    root = sys.argv[1]
    for folder, what in FOLDERS:
        d = os.path.join(root, folder)
        if not os.path.isdir(d):
            continue
        gpu = open(os.path.join(d, "gpu.txt")).read().strip()
        date = open(os.path.join(d, "date.txt")).read().strip()[:10]
        frames = next(json.load(open(os.path.join(d, f"edges-{scene}.json"))).popitem()[1]["frames"]
                      for scene, _ in SCENES
                      if os.path.exists(os.path.join(d, f"edges-{scene}.json")))
        print(f"### Edge antialiasing on the walk CAVE (issue 32), {folder}: {what} — {date}\n")
        print(f"{gpu}; `bash tools/gpu-edges.sh VLF OUT {frames}`, the 8-view 1920x1200 walk "
              f"CAVE, {frames} frames per run; eye rays per pixel and edge error from the last frame "
              "(display MSE against the same frame with 16 eye rays per pixel, and with 64 of "
              "their own reflection; paced runs counted as if every tile drew its low count, the "
              "pacer's shares are in each report's `pacer`); raw reports in "
              f"`docs/results/h200/edges/{folder}/`.\n")
        for scene, title in SCENES:
            path = os.path.join(d, f"edges-{scene}.json")
            if os.path.exists(path):
                rows = json.load(open(path))
                reports = {v: json.load(open(os.path.join(d, f"cave-{scene}-{v}.json")))
                           for v in rows}
                print(f"#### {title}\n")
                print(table(rows, reports))
                print()


if __name__ == "__main__":
    main()
