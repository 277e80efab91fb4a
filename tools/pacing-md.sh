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
      "config/displays/cave-4wall-walk.toml: `refresh_hz = 120`, `fit_frame_time = true`) headless along each walk, frames spread evenly over it, "
      "each frame's views submitted back to back and waited for (CPU+GPU frame time); GPU time per view from timestamp queries. "
      "Before the first frame the views are probed at 1 eye ray per pixel and at the configured 4, from the configured mirror reflections down, "
      "and each frame every view draws 1 to 16 eye rays per pixel by 8x8 tile, the pacer holding its GPU time at 75% of the period "
      "(src/render/budget.rs). Limits: every view's GPU p99/p50 <= 1.10, the frame's "
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
    fit, pacer = r.get("fit"), r.get("pacer")
    if fit:
        probes = ", ".join(f"{p['eye_rays_per_pixel']} ray(s)/{p['mirror_bounces']} reflection(s) {p['frame_gpu_ms']:.2f} ms" for p in fit["probes"])
        print(f"Probed at the walk's start: {probes}; drawn with {fit['mirror_bounces']} reflection(s)" + ("." if fit["fits"] else ", **nothing fitted**.") + "\n")
    if pacer:
        rays = pacer["eye_rays_per_pixel"]
        med = sorted(d["median"] for d in rays)
        print(f"What constancy costs: eye rays per pixel, averaged over a view's tiles, median per view {med[0]:.2f} to {med[-1]:.2f} "
              f"(the configuration asks for 4; range over all frames {min(d['min'] for d in rays):.2f} to {max(d['max'] for d in rays):.2f}).\n")
    print("| limit | measured | limit | verdict |\n|---|---|---|---|")
    for l in r.get("limits", []):
        print(f"| {l['what']} | {l['measured']:.3f} | {l['limit']:.3f} | {verdict(l['met'])} |")
    print("\n| wall | eye | GPU p50 (ms) | p99 | max | p99/p50 | verdict |\n|---|---|---|---|---|---|---|")
    for v in r["views"]:
        g = v["gpu_ms"] or {}
        flag = verdict(not v.get("above_limit")) if v.get("above_limit") is not None else "-"
        print(f"| {v['wall']} | {v['eye']} | {g.get('median', float('nan')):.3f} | {g.get('p99', float('nan')):.3f} | {g.get('max', float('nan')):.3f} | {v.get('p99_over_p50') or float('nan'):.3f} | {flag} |")
    print()
trav = os.path.join(os.path.dirname(d.rstrip("/")), "traversal")
if os.path.isdir(trav):
    print("#### Where the time went: the ray cast\n")
    print(f"Before frame pacing, the same walks (100 frames, 4 eye rays per pixel on every tile, every reflection traced) with builds and "
          f"shader variants of the renderer (docs/results/h100/traversal/: {open(os.path.join(trav, 'commit.txt')).read().strip()}). "
          "The stack of the BVH traversal is local memory, one per thread: at 64 entries it is what a cast waits on, and it also hides "
          "what a view sees (every view costs about the same). The renderer now sizes it to the scene's tree (24 entries for the 100K "
          "classroom, 32 for 1M): faster, but a view's cost follows its content (0.54 to 0.97 ms a view at 2 eye rays), which the pacer "
          "then holds.\n")
    names = {"old": "before (BVH nodes, stack 64, Moller-Trumbore)", "new": "child pairs, stack 64, affine triangle test",
             "mt": "child pairs, stack 64, Moller-Trumbore", "wg": "child pairs, stack 32 in workgroup memory",
             "s48": "child pairs, stack 48", "s32": "child pairs, stack 32", "s24": "child pairs, stack 24", "s16": "child pairs, stack 16",
             "s32-noentry": "child pairs, stack 32 without entry distances", "norefl": "child pairs, stack 64, no reflection traced (diagnostic)"}
    print("| renderer | 100K classroom: all views' GPU p50 (ms) | p99 | gallery: p50 (ms) | p99 |\n|---|---|---|---|---|")
    for tag, what in names.items():
        row = []
        for scene in ["classroom-100k", "gallery"]:
            f = os.path.join(trav, f"cave-{scene}-{tag}.json")
            a = json.load(open(f)).get("all_views_gpu_ms") or {} if os.path.exists(f) else {}
            row += [f"{a.get('median', float('nan')):.2f}", f"{a.get('p99', float('nan')):.2f}"]
        print(f"| {what} | " + " | ".join(row) + " |")
    print()
xr = sorted(glob.glob(os.path.join(d, "xr-*.json")))
if xr:
    print("#### The headset on the same scenes\n")
    print("`vlf xr --fit-frame-time` on vlf's headless test runtime (tests/xr-runtime: 90 Hz, 2064x2208 per eye, Meta Quest 3's recommended size), 900 frames, "
          "frames in flight (the CPU records frame N+1 while the GPU draws frame N); the first frame probes both eyes against the runtime's period and shows "
          "nothing, then the pacer holds both eyes at 75% of it. Missed, late and dropped frames as the compositor shows them (each frame must be done "
          "4 ms + 20% of the period before its refresh). Limits: per-eye GPU p99/p50 <= 1.10, no missed refresh, no late frame. "
          "By default both eyes go on one array swapchain (a layer per eye), put there in one multiview pass where the device's multiview passes vlf's "
          "check, with a depth swapchain and XR_KHR_composition_layer_depth; rows named per-eye ran the fallback (`--swapchains per-eye`: a colour and "
          "a depth swapchain per eye).\n")
    print("| scene | eyes on the runtime | eye | GPU p50 (ms) | p99 | p99/p50 | eye rays per pixel (median) | missed refreshes | late frames | dropped frames | CPU began while GPU busy | waited for GPU | verdict |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for f in xr:
        r = json.load(open(f))
        scene = os.path.basename(f)[3:-5]
        bad = [l["what"] for l in r.get("limits", []) if not l["met"]]
        rays = (r.get("pacer") or {}).get("eye_rays_per_pixel") or []
        shape = {"array": "array swapchain", "per-eye": "per-eye swapchains"}.get(r.get("swapchains"), r.get("swapchains") or "?")
        shape += ", multiview" if r.get("multiview") else ""
        shape += ", depth" if r.get("depth_submitted") else ", no depth"
        for i, e in enumerate(r["eyes"]):
            g = e["gpu_ms"] or {}
            ray = f"{rays[i]['median']:.2f}" if i < len(rays) else "-"
            print(f"| {scene} | {shape} | {e['eye']} | {g.get('median', float('nan')):.3f} | {g.get('p99', float('nan')):.3f} | {e.get('p99_over_p50') or float('nan'):.3f} | {ray} | "
                  f"{r['missed_frames']} | {r.get('late_frames')} | {r.get('dropped_frames', '-')} | {r.get('overlapped_frames')} of {r['frames']} | {r.get('waited_for_gpu')} | "
                  f"{'met' if not bad else '**ABOVE THE LIMIT**: ' + ', '.join(bad)} |")
    print()
    print("The test runtime's own account (its report, `xr-*-runtime.txt`): it checks every layer, sub-image and depth info at xrEndFrame and "
          "reads both eyes' depth back after the last frame; a right layer given the left eye (or none) would show as no difference.\n")
    print("| run | violation | layers checked | swapchains | views with depth | right eye's depth differs from the left's in |\n|---|---|---|---|---|---|")
    for f in xr:
        rt = f[:-5] + "-runtime.txt"
        if not os.path.exists(rt):
            continue
        kv = dict(l.split("=", 1) for l in open(rt).read().splitlines() if "=" in l)
        differ = kv.get("depth_eyes_differ_share")
        differ = f"{float(differ) * 100:.1f}% of pixels" if differ else "-"
        print(f"| {os.path.basename(f)[3:-5]} | {kv.get('violation')} | {kv.get('layers_checked')} | {kv.get('swapchains')} | {kv.get('depth_views')} | {differ} |")
    print()
    earlier = sorted(glob.glob(os.path.join(d, "earlier", "*-xr-*.json")))
    if earlier:
        print("Earlier runs kept (`earlier/`, the same command at the commit each is named by), for what they missed:\n")
        notes = os.path.join(d, "earlier", "notes.md")
        if os.path.exists(notes):
            print(open(notes).read().strip() + "\n")
        for f in earlier:
            r = json.load(open(f))
            name = os.path.basename(f)[:-5]
            print(f"- {name}: {r['missed_frames']} missed refreshes (after frames {', '.join(map(str, r.get('missed_after_frames', [])))}), "
                  f"{r.get('late_frames')} late, {r.get('dropped_frames')} dropped; GPU done before the predicted display time: "
                  f"min {r['gpu_done_before_display_ms']['min']:.2f} ms, p50 {r['gpu_done_before_display_ms']['median']:.2f} ms.")
        print()
PY
