#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: raster first hits against ray-cast ones (issue 32). The 4-wall
# stereo CAVE of config/displays/cave-4wall-walk.toml (8 views of 1920x1200) walks the scripted
# walks of config/paths/ through the generated 100K- and 1M-triangle mirror classrooms at 4 eye
# rays per pixel, unpaced (fit_frame_time = false: every tile draws all 4), twice: first hits
# cast through the BVH ("rays", the default) and drawn by the rasteriser into a 4x MSAA
# visibility buffer ("raster", src/render/raster.rs). A raster view's GPU time spans its raster
# pass and its resolve. Prints each run's per-view GPU p50/p99 and the frame medians (all views'
# GPU time, CPU frame time) and the raster/rays ratio of the frame's GPU median; the reports
# (JSON + text, the last frame's overview) go into OUT_DIR/raster.tar.
# SCENES (default "classroom-100k classroom-1m") picks the walks; WORK=dir keeps the generated
# scenes and light fields there and reuses them.
#   tools/gpu-raster.sh VLF_BINARY OUT_DIR [FRAMES]
set -uo pipefail
vlf=$1; out=$2; frames=${3:-300}; work=${WORK:-$(mktemp -d)}; mkdir -p $work "$out"
quiet() { grep -v XDG_RUNTIME_DIR; }
# generate SCENE: the walk's scene as `vlf generate` makes it
source "$(dirname "$0")/walk-scenes.sh"
for scene in ${SCENES:-classroom-100k classroom-1m}; do
  if [ ! -f $work/$scene.vlf ]; then
    "$vlf" generate $(generate $scene) -o $work/$scene | quiet | tail -1
    "$vlf" propagate $work/$scene/scene.toml -o $work/$scene.vlf 2>&1 | quiet | grep -E "iterations|propagation  |triangles"
  fi
  for hits in rays raster; do
    # the walk CAVE on this scene's path, unpaced, 4 eye rays per pixel, first hits `hits`
    sed -e "s|^path = .*|path = \"$PWD/config/paths/$scene-walk.toml\"|" \
        -e "s|^fit_frame_time = .*|fit_frame_time = false|" \
        -e "s|^refresh_hz.*|&\nantialiasing = 4\nfirst_hits = \"$hits\"|" \
        config/displays/cave-4wall-walk.toml > $work/cave-$scene-$hits.toml
    "$vlf" cave $work/cave-$scene-$hits.toml --scene $work/$scene.vlf --headless --frames $frames \
      --out $work/out-$scene-$hits --json $work/cave-$scene-$hits.json 2>&1 | quiet > $work/cave-$scene-$hits.txt
    cp $work/out-$scene-$hits/overview.png $work/cave-$scene-$hits-overview.png
  done
done
python3 - $work ${SCENES:-classroom-100k classroom-1m} <<'PY'
import json, sys
work, scenes = sys.argv[1], sys.argv[2:]
for scene in scenes:
    frame = {}
    for hits in ("rays", "raster"):
        r = json.load(open(f"{work}/cave-{scene}-{hits}.json"))
        gpu = r["all_views_gpu_ms"] or {}
        frame[hits] = gpu.get("median")
        print(f"{scene} {hits}: {r['frames']} frames, {r['views_per_frame']} views, {r['quality']}")
        for v in r["views"]:
            d = v["gpu_ms"] or {}
            print(f"  {v['wall']:>6} {v['eye']:<5} {v['pixels'][0]}x{v['pixels'][1]}  GPU p50 {d.get('median', float('nan')):.3f} ms  p99 {d.get('p99', float('nan')):.3f} ms")
        print(f"  frame: all views GPU median {gpu.get('median', float('nan')):.3f} ms (p99 {gpu.get('p99', float('nan')):.3f}), CPU frame median {r['cpu_frame_ms']['median']:.3f} ms")
    if frame["rays"] and frame["raster"]:
        print(f"{scene}: raster / rays, frame GPU median {frame['raster'] / frame['rays']:.3f}")
PY
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar cf "$out/raster.tar" gpu.txt commit.txt date.txt cave-*.toml cave-*.json cave-*.txt cave-*-overview.png)
