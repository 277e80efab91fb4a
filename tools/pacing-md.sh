#!/usr/bin/env bash
# BENCHMARKS.md's frame-pacing section from what tools/gpu-pacing.sh wrote into DIR (cave-*.json,
# xr-*.json, gpu.txt, commit.txt): every limit of issue "constant frame time in real scenes" in
# its own row, met or ABOVE THE LIMIT; failing rows are kept. Usage: tools/pacing-md.sh DIR
set -euo pipefail
python3 - "$1" <<'PY'
import glob, json, os, sys
d = sys.argv[1]
read = lambda name: open(os.path.join(d, name)).read().strip() if os.path.exists(os.path.join(d, name)) else "?"
walks = {"classroom-100k": "the 100K-triangle classroom with a mirror (config/paths/classroom-100k-walk.toml)",
         "classroom-1m": "the 1M-triangle classroom with a mirror (config/paths/classroom-1m-walk.toml)",
         "gallery": "the mirror gallery (config/paths/gallery-walk.toml)"}
verdict = lambda met: "met" if met else "**ABOVE THE LIMIT**"
print("### Frame pacing on scripted walks through real scenes\n")
print(f"`tools/gpu-pacing.sh` on **{read('gpu.txt')}**, commit {read('commit.txt')}: the 4-wall stereo CAVE (8 views of 1920x1200, "
      "4 eye rays per pixel) headless along each walk, frames spread evenly over it, each frame's views submitted back to back and "
      "waited for (CPU+GPU frame time); GPU time per view from timestamp queries. Limits: every view's GPU p99/p50 <= 1.10, the frame's "
      "CPU+GPU p99/p50 <= 1.15 and max <= 1.5x its median, every frame under 8.3 ms (120 Hz). Rows above a limit stay in the table.\n")
for scene, title in walks.items():
    f = os.path.join(d, f"cave-{scene}.json")
    if not os.path.exists(f):
        print(f"#### {title}\n\n(not run in this batch)\n")
        continue
    r = json.load(open(f))
    a, c = r.get("all_views_gpu_ms") or {}, r["cpu_frame_ms"]
    print(f"#### {title}\n")
    print(f"{r['frames']} frames: all views' GPU time p50 {a.get('median', float('nan')):.3f} ms, p99 {a.get('p99', float('nan')):.3f}; "
          f"CPU+GPU frame p50 {c['median']:.3f} ms, p99 {c['p99']:.3f}, max {c['max']:.3f}.\n")
    print("| limit | measured | limit | verdict |\n|---|---|---|---|")
    for l in r.get("limits", []):
        print(f"| {l['what']} | {l['measured']:.3f} | {l['limit']:.3f} | {verdict(l['met'])} |")
    print("\n| wall | eye | GPU p50 (ms) | p99 | max | p99/p50 | verdict |\n|---|---|---|---|---|---|---|")
    for v in r["views"]:
        g = v["gpu_ms"] or {}
        flag = verdict(not v.get("above_limit")) if v.get("above_limit") is not None else "-"
        print(f"| {v['wall']} | {v['eye']} | {g.get('median', float('nan')):.3f} | {g.get('p99', float('nan')):.3f} | {g.get('max', float('nan')):.3f} | {v.get('p99_over_p50') or float('nan'):.3f} | {flag} |")
    print()
fewer = sorted(glob.glob(os.path.join(os.path.dirname(d.rstrip("/")), "pacing-aa", "cave-*-aa*.json")))
if fewer:
    print("The same walks with fewer eye rays per pixel (`AA=N tools/gpu-pacing.sh`, `antialiasing = N` in the display configuration; 150 frames):\n")
    print("| walk | eye rays per pixel | all views' GPU p50 (ms) | p99 | frame CPU+GPU max (ms) | limits above |\n|---|---|---|---|---|---|")
    for f in fewer:
        r = json.load(open(f))
        name = os.path.basename(f)[5:-5]
        scene, aa = name.rsplit("-aa", 1)
        a = r.get("all_views_gpu_ms") or {}
        bad = [l["what"] for l in r.get("limits", []) if not l["met"]]
        print(f"| {scene} | {aa} | {a.get('median', float('nan')):.3f} | {a.get('p99', float('nan')):.3f} | {r['cpu_frame_ms']['max']:.3f} | {', '.join(bad) or 'none'} |")
    print()
aa = os.path.join(d, "render-aa.txt")
if os.path.exists(aa):
    print("Where the time goes: one 1920x1200 view of the 100K classroom (`vlf bench --size 1920x1200 --aa N`). Eye rays go in pairs "
          "that share one traced reflection, so 1 and 2 rays per pixel cost the same and 4 cost twice that: the frame time is the "
          "number of ray pairs, and 8 views at 4 rays per pixel need about three times faster rays to fit 8.3 ms.\n")
    print("```"); print(open(aa).read().strip()); print("```\n")
xr = sorted(glob.glob(os.path.join(d, "xr-*.json")))
if xr:
    print("#### The headset on the same scenes\n")
    print("`vlf xr` on vlf's headless test runtime (tests/xr-runtime: 90 Hz, 2064x2208 per eye, Meta Quest 3's recommended size), 900 frames, "
          "frames in flight (the CPU records frame N+1 while the GPU draws frame N). Limits: per-eye GPU p99/p50 <= 1.10, no missed refresh, no late frame. "
          "Where the report has no `dropped_frames` it was measured before the headset's account was matched to the compositor's: a missed refresh was then a gap "
          "between consecutive predicted display times, a late frame one whose xrEndFrame came after its predicted display time.\n")
    print("| scene | eye | GPU p50 (ms) | p99 | p99/p50 | missed refreshes | late frames | dropped frames | CPU began while GPU busy | waited for GPU | verdict |\n|---|---|---|---|---|---|---|---|---|---|---|")
    for f in xr:
        r = json.load(open(f))
        scene = os.path.basename(f)[3:-5]
        bad = [l["what"] for l in r.get("limits", []) if not l["met"]]
        for e in r["eyes"]:
            g = e["gpu_ms"] or {}
            print(f"| {scene} | {e['eye']} | {g.get('median', float('nan')):.3f} | {g.get('p99', float('nan')):.3f} | {e.get('p99_over_p50') or float('nan'):.3f} | "
                  f"{r['missed_frames']} | {r.get('late_frames')} | {r.get('dropped_frames', '-')} | {r.get('overlapped_frames')} of {r['frames']} | {r.get('waited_for_gpu')} | "
                  f"{'met' if not bad else '**ABOVE THE LIMIT**: ' + ', '.join(bad)} |")
    print()
PY
