#!/usr/bin/env bash
# BENCHMARKS.md's CAVE cluster section from what tools/gpu-cluster.sh wrote into DIR
# (cluster-2ranks.json, cave-1process.json, gpu.txt, commit.txt). Usage: tools/cluster-md.sh DIR
set -euo pipefail
python3 - "$1" <<'PY'
import json, os, sys
d = sys.argv[1]
read = lambda name: open(os.path.join(d, name)).read().strip() if os.path.exists(os.path.join(d, name)) else "?"
r = json.load(open(os.path.join(d, "cluster-2ranks.json")))
frames = len(r["per_rank"][0]["shown"]) if r["per_rank"] else 0
print(f"### CAVE cluster: {r['ranks']} MPI ranks, frame lock\n")
print(f"`tools/gpu-cluster.sh` on **{read('gpu.txt')}**, commit {read('commit.txt')}: `mpirun -np 2 vlf cave config/displays/cave-4wall.toml --headless --frames {frames}` "
      f"(8 views of 1920x1200, Cornell-mirror at default settings loaded from one .vlf by both ranks; front and left walls on rank 0, right and floor on rank 1). "
      f"**Both ranks share the one GPU** (a 2-GPU machine was not available), so the frame time is two processes' work on one GPU, not a node per wall. "
      f"Frame time is present to present on each rank; the swap barrier wait is the time a rank waits for the other before presenting; GPU time per view from timestamp queries. "
      f"Frame lock: {'every rank presented the same frames with the same poses' if r['same_frames_and_poses'] else '**NOT OK**'} ({r['check']}).\n")
print("| rank | frame time p50 (ms) | p99 | CPU frame p50 (ms) | p99 | swap barrier wait p50 (ms) | p99 | frames presented |")
print("|---|---|---|---|---|---|---|---|")
for p in r["per_rank"]:
    f, c, w = p.get("frame_ms") or {}, p.get("cpu_frame_ms") or {}, p.get("swap_wait_ms") or {}
    g = lambda s, k: f"{s[k]:.3f}" if k in s else "-"
    print(f"| {p['rank']} | {g(f,'p50')} | {g(f,'p99')} | {g(c,'p50')} | {g(c,'p99')} | {g(w,'p50')} | {g(w,'p99')} | {len(p['shown'])} |")
print()
print("| rank | wall | eye | pixels | GPU p50 (ms) | p99 |\n|---|---|---|---|---|---|")
for p in r["per_rank"]:
    for v in p["views"]:
        gm = v["gpu_ms"] or {}
        print(f"| {p['rank']} | {v['wall']} | {v['eye']} | {v['pixels'][0]}x{v['pixels'][1]} | {gm.get('median', float('nan')):.3f} | {gm.get('p99', float('nan')):.3f} |")
one = os.path.join(d, "cave-1process.json")
if os.path.exists(one):
    o = json.load(open(one))
    c = o["cpu_frame_ms"]
    a = o.get("all_views_gpu_ms") or {}
    print(f"\nThe same 8 views in one process (`vlf cave --headless`, no MPI): CPU frame time p50 {c['median']:.3f} ms, p99 {c['p99']:.3f} ms; all views' GPU time p50 {a.get('median', float('nan')):.3f} ms, p99 {a.get('p99', float('nan')):.3f} ms.")
print()
PY
