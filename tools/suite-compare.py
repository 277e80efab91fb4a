#!/usr/bin/env python3
"""Two builds' `vlf bench --suite` side by side (tools/gpu-identity.sh): per scene the total
time (setup + visibility + propagation) of OLD, NEW and OLD run again, NEW/OLD and the noise
between OLD's two runs; a scene whose NEW/OLD falls outside OLD's own spread (widened by 5%)
is flagged.   python3 tools/suite-compare.py DIR > DIR/suite-compare.md"""

import json
import sys
from pathlib import Path

d = Path(sys.argv[1])
runs = {k: json.loads((d / f"suite-{k}.json").read_text()) for k in ("old", "new", "old-again")}
gpu = (d / "gpu.txt").read_text().strip() if (d / "gpu.txt").exists() else "?"
print(f"`vlf bench --suite` of two builds on **{gpu}**: total seconds per scene (setup, visibility, propagation).\n")
print("| scene | old (s) | new (s) | old again (s) | new/old | old again/old | verdict |")
print("|---|---|---|---|---|---|---|")
flagged = 0
for e_old, e_new, e_again in zip(*(runs[k]["entries"] for k in ("old", "new", "old-again"))):
    a, b, c = e_old["total_seconds"], e_new["total_seconds"], e_again["total_seconds"]
    noise = abs(c / a - 1.0)
    ratio = b / a
    within = abs(ratio - 1.0) <= noise + 0.05
    flagged += not within
    print(f"| {e_old['name']} | {a:.3f} | {b:.3f} | {c:.3f} | {ratio:.3f} | {c / a:.3f} | {'within noise' if within else '**OUTSIDE NOISE**'} |")
print(f"\n{flagged} scene(s) outside the noise (old's two runs differ by the 'old again/old' column; 5% added).")
