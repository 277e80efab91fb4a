#!/usr/bin/env python3
"""Hitches over many long CAVE runs (tools/gpu-hitches.sh, issue 32 item 4): reads every
WORK/cave-<scene>-run<N>.json and prints a Markdown table per scene (each run's frame CPU+GPU
median, p99, max, max/median and the views' worst GPU p99/p50), then the slowest frames over all
of a scene's runs with what each waited on (the reports' `slowest_frames`); writes the same
figures to WORK/hitches.json.

  python3 tools/hitches.py WORK
"""
import json
import re
import sys
from pathlib import Path


def run_row(report):
    cpu = report["cpu_frame_ms"]
    return {
        "frames": cpu["samples"],
        "median_ms": cpu["median"],
        "p99_ms": cpu["p99"],
        "max_ms": cpu["max"],
        "max_over_median": cpu["max"] / cpu["median"],
        "views_worst_p99_over_p50": report["worst_p99_over_p50"],
        "slowest_frames": report.get("slowest_frames", []),
    }


def main(work):
    runs = {}
    for path in sorted(work.glob("cave-*-run*.json")):
        m = re.fullmatch(r"cave-(.+)-run(\d+)\.json", path.name)
        if m:
            report = json.loads(path.read_text())
            runs.setdefault(m.group(1), []).append((int(m.group(2)), run_row(report)))
    summary = {}
    for scene, rows in runs.items():
        rows.sort()
        print(f"### {scene}: {len(rows)} runs\n")
        print("| run | frames | CPU+GPU median | p99 | max | max/median | views' worst GPU p99/p50 |")
        print("|---|---|---|---|---|---|---|")
        for n, r in rows:
            print(f"| {n} | {r['frames']} | {r['median_ms']:.2f} ms | {r['p99_ms']:.2f} ms | "
                  f"{r['max_ms']:.2f} ms | {r['max_over_median']:.3f} | {r['views_worst_p99_over_p50']:.3f} |")
        slow = sorted(((f["cpu_gpu_ms"], n, f) for n, r in rows for f in r["slowest_frames"]),
                      key=lambda x: -x[0])[:10]
        worst = max(r["max_ms"] for _, r in rows)
        ratio = max(r["max_over_median"] for _, r in rows)
        print(f"\nWorst frame of all runs {worst:.2f} ms, worst max/median {ratio:.3f}. "
              "The ten slowest frames of all runs:\n")
        for ms, n, f in slow:
            print(f"- run {n}, frame {f['frame']}: {ms:.2f} ms, waited on {f['waited_on']}")
        print()
        summary[scene] = {"runs": [dict(r, run=n) for n, r in rows],
                          "worst_frame_ms": worst, "worst_max_over_median": ratio}
    (work / "hitches.json").write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
