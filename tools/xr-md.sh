#!/usr/bin/env bash
# The OpenXR section of BENCHMARKS.md from what tools/gpu-xr.sh wrote into DIR (xr-*.json,
# xr-*-runtime.txt, gpu.txt, commit.txt). Usage: tools/xr-md.sh DIR
set -euo pipefail
python3 - "$1" <<'PY'
import glob, json, os, sys
d = sys.argv[1]
read = lambda name: open(os.path.join(d, name)).read().strip() if os.path.exists(os.path.join(d, name)) else "?"
print("### OpenXR headset: `vlf xr` per eye\n")
print(f"`tools/gpu-xr.sh` on **{read('gpu.txt')}** (driver), commit {read('commit.txt')}: `vlf xr` through the Khronos OpenXR loader 1.0.20 on vlf's headless test runtime "
      "(tests/xr-runtime: a simulated 90 Hz stereo headset with asymmetric fields of view and a swaying head, that creates the Vulkan instance and device and "
      "allocates the swapchains as a runtime does, and checks every frame's calls and layer; it shows nothing). No hardware headset or vendor runtime was available. "
      "Per-eye sizes of two headsets: Valve Index (1440x1600) and Meta Quest 3 (2064x2208); 900 frames each (10 s); the light field of each scene at default settings, loaded from .vlf. "
      "GPU time is the eye's render pass (timestamp queries); CPU frame is xrBeginFrame to xrEndFrame including the present pass and the wait for the GPU; "
      "a missed refresh is a display period between consecutive predicted display times that no frame was submitted for; a late frame is one whose xrEndFrame came after its predicted display time (runtime clock): "
      "the definitions of the time of this run (the report now replays the compositor's display instead: docs/guide/headset.md).\n")
print("| scene | eye | pixels | GPU p50 (ms) | p99 | max | p99/p50 | CPU frame p50 / p99 / max (ms) | frames | missed refreshes | late frames | runtime's checks |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for f in sorted(glob.glob(os.path.join(d, "xr-*.json"))):
    r = json.load(open(f))
    scene = "Cornell-mirror" if "mirror" in os.path.basename(f) else "Cornell"
    rt = dict(l.split("=", 1) for l in open(f[:-5] + "-runtime.txt").read().split("\n") if "=" in l)
    checks = f"{rt['layers_checked']} layers, violations: {rt['violation']}"
    c = r["cpu_frame_ms"]
    for e in r["eyes"]:
        g = e["gpu_ms"]
        print(f"| {scene} | {e['eye']} | {e['pixels'][0]}x{e['pixels'][1]} | {g['median']:.3f} | {g['p99']:.3f} | {g['max']:.3f} | {e['p99_over_p50']:.3f} | "
              f"{c['median']:.2f} / {c['p99']:.2f} / {c['max']:.2f} | {r['frames']} | {r['missed_frames']} | {r.get('late_frames', '-')} | {checks} |")
print("\nThe frames are paced by the runtime at 90 Hz, so the GPU idles most of each period; that likely keeps it off its boost clock, which would explain why the per-eye times here are not proportional to the pixel count (compare the CAVE's back-to-back frames above).")
print("\n![left eye, Cornell-mirror at 2064x2208, frame 450 (scaled to 40%)](docs/images/xr-left-eye.png)\n")
PY
