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
