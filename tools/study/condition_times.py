#!/usr/bin/env python3
"""Frame times per condition and around each switch, from a session log's frames.csv (`vlf cave
--log DIR` on a display with [[condition]] tables; tools/gpu-conditions.sh). Standard library
only. Prints JSON:

- per condition: the timed frames' count, and `gpu_ms` / `cpu_ms` median, p99 and max;
- per switch (a frame whose condition differs from the frame before's): its frame, from and to,
  and the max GPU and CPU time of that frame and the `--around` frames after it, against the
  median of the condition switched to (`max_over_median`);
- the worst of those ratios over all switches, beside the worst ratio of any same-length run of
  frames away from the switches (what the frame time does without a switch).

    python3 tools/study/condition_times.py LOG_DIR [--around 3]
"""

import argparse
import csv
import json
import statistics
from pathlib import Path


def percentile(values, q):
    values = sorted(values)
    if not values:
        return None
    k = min(len(values) - 1, max(0, round(q / 100 * (len(values) - 1))))
    return values[k]


def summary(values):
    return {
        "frames": len(values),
        "median": statistics.median(values) if values else None,
        "p99": percentile(values, 99),
        "max": max(values) if values else None,
    }


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("log", type=Path)
    parser.add_argument("--around", type=int, default=3)
    args = parser.parse_args()
    rows = list(csv.DictReader(open(args.log / "frames.csv", newline="")))
    timed = [r for r in rows if r["drawn"] == "timed" and r["gpu_ms"] and r["cpu_ms"]]
    by_condition = {}
    for r in timed:
        by_condition.setdefault(r["condition"], []).append(r)
    conditions = {
        name: {k: summary([float(r[k]) for r in rs]) for k in ("gpu_ms", "cpu_ms")}
        for name, rs in by_condition.items()
    }
    index = {int(r["frame"]): r for r in timed}
    switches, near = [], set()
    for before, r in zip(rows, rows[1:]):
        if r["condition"] == before["condition"]:
            continue
        frame = int(r["frame"])
        window = [index[f] for f in range(frame, frame + args.around + 1) if f in index]
        near.update(range(frame - 1, frame + args.around + 1))
        entry = {"frame": frame, "from": before["condition"], "to": r["condition"]}
        for k in ("gpu_ms", "cpu_ms"):
            median = conditions.get(r["condition"], {}).get(k, {}).get("median")
            worst = max((float(w[k]) for w in window), default=None)
            entry[k] = {
                "max": worst,
                "median_of_condition": median,
                "max_over_median": worst / median if worst and median else None,
            }
        switches.append(entry)

    def worst(k, entries):
        ratios = [e[k]["max_over_median"] for e in entries if e[k]["max_over_median"]]
        return max(ratios, default=None)

    # the same measure on runs of frames away from any switch: what the frame time does anyway
    quiet_runs = []
    frames = sorted(f for f in index if f not in near)
    for start in frames[:: args.around + 1]:
        run = [index[f] for f in range(start, start + args.around + 1) if f in index and f not in near]
        if len(run) == args.around + 1:
            entry = {}
            for k in ("gpu_ms", "cpu_ms"):
                median = conditions[run[0]["condition"]][k]["median"]
                entry[k] = {"max_over_median": max(float(w[k]) for w in run) / median}
            quiet_runs.append(entry)
    print(
        json.dumps(
            {
                "log": str(args.log),
                "timed_frames": len(timed),
                "conditions": conditions,
                "switches": switches,
                "worst_switch_max_over_median": {k: worst(k, switches) for k in ("gpu_ms", "cpu_ms")},
                "worst_run_without_switch_max_over_median": {
                    k: worst(k, quiet_runs) for k in ("gpu_ms", "cpu_ms")
                },
                "runs_without_switch": len(quiet_runs),
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
