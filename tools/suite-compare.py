#!/usr/bin/env python3
"""Two builds' `vlf bench --suite` side by side (tools/gpu-identity.sh): each build ran the suite
several times, taking turns. Per scene and per stage (setup, visibility, propagation) the median
of each build, NEW/OLD, and OLD's own spread (its slowest over its fastest run); NEW's median is
within noise when it lies inside the range of OLD's runs widened by 5% (or the two ranges
overlap).     python3 tools/suite-compare.py DIR > DIR/suite-compare.md"""

import json
import statistics
import sys
from pathlib import Path

d = Path(sys.argv[1])
runs = {b: [json.loads(p.read_text()) for p in sorted(d.glob(f"suite-{b}-*.json"))] for b in ("old", "new")}
gpu = (d / "gpu.txt").read_text().strip() if (d / "gpu.txt").exists() else "?"
stages = [("setup_seconds", "setup"), ("visibility_seconds", "visibility"), ("propagation_seconds", "propagation"), ("total_seconds", "total")]
print(f"`vlf bench --suite` of two builds on **{gpu}**, {len(runs['old'])} runs each, taking turns: per scene the median "
      "milliseconds of each build per stage as old / new, and the verdict on the total (new's median inside old's own range, widened by 5%).\n")
print("| scene | " + " | ".join(f"{label} old / new (ms)" for _, label in stages) + " | old's own spread (total) | new/old (total) | verdict |")
print("|---|" + "---|" * (len(stages) + 3))
outside = 0
names = [e["name"] for e in runs["old"][0]["entries"]]
for i, name in enumerate(names):
    cells, verdict = [], ""
    for key, label in stages:
        old = [r["entries"][i][key] * 1e3 for r in runs["old"]]
        new = [r["entries"][i][key] * 1e3 for r in runs["new"]]
        cells.append(f"{statistics.median(old):.1f} / {statistics.median(new):.1f}")
        if key == "total_seconds":
            lo, hi = min(old) / 1.05, max(old) * 1.05
            m = statistics.median(new)
            within = lo <= m <= hi or (min(new) <= max(old) and min(old) <= max(new))
            outside += not within
            spread = max(old) / max(min(old), 1e-9)
            ratio = m / max(statistics.median(old), 1e-9)
            verdict = f"{spread:.3f} | {ratio:.3f} | {'within noise' if within else '**OUTSIDE NOISE**'}"
    print(f"| {name} | " + " | ".join(cells) + f" | {verdict} |")
print(f"\n{outside} scene(s) outside the noise.")

# the walks (tools/gpu-identity.sh): all 8 views' GPU milliseconds per frame, median and p99 of
# each run, per build
walks = sorted({p.name.split("-", 2)[2].rsplit("-", 1)[0] for p in d.glob("walk-old-*.json")})
if walks:
    print("\nThe drawing: the 4-wall CAVE (8 views of 1920x1200) walking each scene at a fixed 4 eye rays "
          "per pixel, the builds taking turns; all views' GPU ms per frame (median of the runs' medians, "
          "and of their p99s), and the verdict on the median (new's inside old's range of runs widened by 5%).\n")
    print("| walk | runs | median old / new (ms) | p99 old / new (ms) | old's own spread | new/old | verdict |")
    print("|---|---|---|---|---|---|---|")
    for walk in walks:
        med, p99 = {}, {}
        for b in ("old", "new"):
            rs = [json.loads(p.read_text()) for p in sorted(d.glob(f"walk-{b}-{walk}-*.json"))]
            med[b] = [r["all_views_gpu_ms"]["median"] for r in rs]
            p99[b] = [r["all_views_gpu_ms"]["p99"] for r in rs]
        lo, hi = min(med["old"]) / 1.05, max(med["old"]) * 1.05
        m = statistics.median(med["new"])
        within = lo <= m <= hi or (min(med["new"]) <= max(med["old"]) and min(med["old"]) <= max(med["new"]))
        outside += not within
        print(f"| {walk} | {len(med['old'])} | {statistics.median(med['old']):.3f} / {m:.3f} | "
              f"{statistics.median(p99['old']):.3f} / {statistics.median(p99['new']):.3f} | "
              f"{max(med['old']) / min(med['old']):.3f} | {m / statistics.median(med['old']):.3f} | "
              f"{'within noise' if within else '**OUTSIDE NOISE**'} |")
    print(f"\n{outside} scene(s) or walk(s) outside the noise.")
