#!/usr/bin/env bash
# BENCHMARKS.md's CAVE cluster section from what tools/gpu-cluster.sh wrote into DIR
# (cluster-<scene>.json, one-process-<scene>.json, lose.json, gpus.txt, gpu-utilization.csv,
# gpu.txt, commit.txt). Usage: tools/cluster-md.sh DIR
set -euo pipefail
python3 - "$1" <<'PY'
import csv, glob, json, os, statistics, sys
d = sys.argv[1]
read = lambda name: open(os.path.join(d, name)).read().strip() if os.path.exists(os.path.join(d, name)) else "?"
gpus = [l.strip() for l in read("gpus.txt").splitlines() if l.strip()]
names = [os.path.basename(p)[len("cluster-"):-len(".json")] for p in glob.glob(os.path.join(d, "cluster-*.json"))]
scenes = sorted((n for n in names if not n.endswith("-fixed")),
                key=lambda s: ["classroom-100k", "classroom-1m", "gallery"].index(s) if s in ["classroom-100k", "classroom-1m", "gallery"] else 9)
walks = {"classroom-100k": "the 100K-triangle classroom with a mirror", "classroom-1m": "the 1M-triangle classroom with a mirror", "gallery": "the mirror gallery"}
first = json.load(open(os.path.join(d, f"cluster-{scenes[0]}.json")))
frames = len(first["per_rank"][0]["shown"]) if first["per_rank"] else 0
print(f"### CAVE cluster: {first['ranks']} MPI ranks, {len(gpus)} GPU(s), frame lock\n")
print(f"`tools/gpu-cluster.sh` on **{len(gpus)}x {read('gpu.txt')}** ({'; '.join(gpus)}), commit {read('commit.txt')}, {read('date.txt')}: "
      f"`mpirun -np 2 vlf cave <walk CAVE> --headless --frames {frames}` with `[cluster] gpu = \"local-rank\"`, so rank 0 draws on GPU 0 and rank 1 on GPU 1. "
      "The 4-wall stereo CAVE (8 views of 1920x1200, config/displays/cave-4wall-walk.toml, paced as shipped: `refresh_hz = 120`, `fit_frame_time = true`) on each shipped walk; "
      "no `[[cluster.node]]`, so the walls split in order: front and left (4 views) on rank 0, right and floor (4 views) on rank 1. Both ranks load one .vlf. "
      "Against it: the same 8 views in one process on GPU 0 (`VLF_GPU=0 vlf cave ... --headless`). "
      "Frame time is present to present on each rank (the cluster's frame: propagation of state from rank 0, drawing, the swap barrier); in one process it is the frame's CPU+GPU time. "
      "The swap-barrier wait is the time a rank waits for the other before presenting. GPU time per view from timestamp queries. "
      "Eye rays per pixel: what the frame pacer gave each view (median over frames of the average over a view's tiles), the pacer holding each rank's views at 75% of the 8.33 ms period.\n")

def util_by_phase():
    """Mean GPU utilisation per GPU between each run's start and end (marks.csv)."""
    from datetime import datetime
    path, marks_path = os.path.join(d, "gpu-utilization.csv"), os.path.join(d, "marks.csv")
    if not (os.path.exists(path) and os.path.exists(marks_path)):
        return {}
    when = lambda t: datetime.strptime(t.strip(), "%Y/%m/%d %H:%M:%S.%f")
    spans = {}
    for line in open(marks_path):
        what, t = line.rsplit(",", 1)
        phase, edge = what.rsplit(" ", 1)
        spans.setdefault(phase, {})[edge] = when(t)
    rows = []
    for row in csv.reader(open(path)):
        try:
            rows.append((when(row[0]), int(row[1]), float(row[3].split()[0])))
        except (ValueError, IndexError):
            continue
    out = {}
    for phase, span in spans.items():
        if "start" in span and "end" in span:
            per = {}
            for t, g, u in rows:
                if span["start"] <= t <= span["end"]:
                    per.setdefault(g, []).append(u)
            out[phase] = {g: statistics.mean(v) for g, v in sorted(per.items())}
    return out

util_by = util_by_phase()
def util_text(phase):
    u = util_by.get(phase)
    return ", ".join(f"GPU {g} {v:.0f}%" for g, v in u.items()) if u else "-"

def rays(pacer):
    if not pacer or not pacer.get("eye_rays_per_pixel"):
        return "-"
    m = [x["median"] for x in pacer["eye_rays_per_pixel"]]
    return f"{min(m):.2f} to {max(m):.2f}"

def f3(s, k):
    return f"{s[k]:.3f}" if s and k in s else "-"

def table(name, heading):
    r = json.load(open(os.path.join(d, f"cluster-{name}.json")))
    one_path = os.path.join(d, f"one-process-{name}.json")
    o = json.load(open(one_path)) if os.path.exists(one_path) else None
    lock = "every rank presented the same frames with the same poses" if r["same_frames_and_poses"] else "**NOT OK**"
    util = f" Mean GPU utilisation (nvidia-smi, every 0.5 s) during the cluster run: {util_text(name + ' cluster')}; during the one-process run: {util_text(name + ' one process')}." if util_by else ""
    print(f"{heading} Frame lock: {lock} ({r['check']}).{util}\n")
    print("| run | GPU | frame time p50 (ms) | p99 | max | swap-barrier wait p50 (ms) | p99 | views' GPU p50 (ms) | p99 | eye rays per pixel (median per view) | frames |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for p in r["per_rank"]:
        g = p.get("gpu") or {}
        gpu = f"{g.get('index', '?')} ({g.get('pci_bus_id') or g.get('name', '?')})" if g else "?"
        f, w = p.get("frame_ms") or {}, p.get("swap_wait_ms") or {}
        views = [v["gpu_ms"] for v in p["views"] if v.get("gpu_ms")]
        walls = list(dict.fromkeys(v["wall"] for v in p["views"]))
        print(f"| rank {p['rank']}: {', '.join(walls)} | {gpu} | {f3(f,'p50')} | {f3(f,'p99')} | {f3(f,'max')} | {f3(w,'p50')} | {f3(w,'p99')} | "
              f"{sum(v['median'] for v in views):.3f} | {sum(v['p99'] for v in views):.3f} | {rays(p.get('pacer'))} | {len(p['shown'])} |")
    if o:
        c, a = o["cpu_frame_ms"], o.get("all_views_gpu_ms") or {}
        print(f"| one process: all 8 views | 0 | {c['median']:.3f} | {c['p99']:.3f} | {c['max']:.3f} | - | - | {a.get('median', float('nan')):.3f} | {a.get('p99', float('nan')):.3f} | {rays(o.get('pacer'))} | {o['frames']} |")
    print()
    worst = max((v["p99_over_p50"], p["rank"], v["wall"], v["eye"]) for p in r["per_rank"] for v in p["views"] if v.get("p99_over_p50"))
    where = ""
    series = [(t, i, p["rank"]) for p in r["per_rank"] for i, t in enumerate(p.get("frame_ms_series") or [])]
    if series:
        t, i, rank = max(series)
        where = f" Slowest cluster frame: {t:.2f} ms, the interval ending at frame {i + 1} (rank {rank})" + (" (start-up: the first timed interval, just after the untimed first frame)" if i == 0 else "") + "."
    else:
        where = " (This run kept no per-frame series; the cluster report has them since commit 467513f.)"
    print(f"Worst view GPU p99/p50 in the cluster: {worst[0]:.3f} (rank {worst[1]}, {worst[2]} {worst[3]}; limit 1.10: {'met' if worst[0] <= 1.10 else '**above the limit**'}).{where}\n")

for scene in scenes:
    print(f"#### {walks.get(scene, scene)} (config/paths/{scene}-walk.toml)\n")
    table(scene, "**Paced, as shipped** (the pacer holds each rank's views at 75% of the period and spends the rest on eye rays).")
    if scene + "-fixed" in names:
        table(scene + "-fixed", "**Fixed at 4 eye rays per pixel** (`fit_frame_time = false`: the time the drawing itself takes).")

lose = os.path.join(d, "lose.json")
if os.path.exists(lose):
    print("#### A rank lost mid-run\n")
    print("Rank 1 sent a signal 6 s into a run of the 100K classroom walk; how long until the run ended and whether rank 0 named rank 1 as lost (the lost-rank timeout `[cluster] timeout_s` is 10 s):\n")
    print("| signal | run ended | seconds to end | rank 0 named rank 1 |\n|---|---|---|---|")
    for x in json.load(open(lose)):
        print(f"| SIG{x['signal']} | {'yes' if x['ended'] else '**no**'} | {x['seconds_to_end']:.2f} | {'yes' if x['rank_0_named_rank_1'] else '**no**'} |")
    print()
PY
