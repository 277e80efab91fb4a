#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: hitches over many long runs (issue 32, item 4). The 4-wall
# stereo CAVE of config/displays/cave-4wall-walk.toml (8 views of 1920x1200, 120 Hz) walks a
# shipped walk of config/paths/ paced, with edge antialiasing (1 eye ray per pixel, 8 at edges;
# the default of tools/gpu-edges.sh's paced-edges8), RUNS times (10) of FRAMES frames (3000) on
# each of SCENES (classroom-100k classroom-1m), each run a fresh `vlf cave` process. Prints and
# writes (tools/hitches.py) per run the frame's CPU+GPU median, p99 and max, max/median and the
# views' worst GPU p99/p50, and the slowest frames over all runs with what each waited on; the
# reports go into OUT_DIR/hitches.tar.
#   tools/gpu-hitches.sh VLF_BINARY OUT_DIR
set -uo pipefail
vlf=$1; out=$2; work=${WORK:-$(mktemp -d)}; mkdir -p "$work" "$out"
runs=${RUNS:-10}; frames=${FRAMES:-3000}
quiet() { grep -v XDG_RUNTIME_DIR; }
source "$(dirname "$0")/walk-scenes.sh"
for scene in ${SCENES:-classroom-100k classroom-1m}; do
  if [ ! -f "$work/$scene.vlf" ]; then
    "$vlf" generate $(generate $scene) -o "$work/$scene" | quiet | tail -1
    "$vlf" propagate "$work/$scene/scene.toml" -o "$work/$scene.vlf" 2>&1 | quiet | grep -E "^  propagation  "
  fi
  sed -e "s|^path = .*|path = \"$(walk_path $scene)\"|" -e "s|^fit_frame_time = .*|fit_frame_time = true|" \
      config/displays/cave-4wall-walk.toml |
    awk '{print} /^refresh_hz/ {print "antialiasing = 4\nedge_antialiasing = { samples = 8 }"}' \
      > "$work/cave-$scene.toml"
  for run in $(seq 1 "$runs"); do
    name=$scene-run$run
    "$vlf" cave "$work/cave-$scene.toml" --scene "$work/$scene.vlf" --headless --frames "$frames" \
      --out "$work/out-$name" --json "$work/cave-$name.json" 2>&1 | quiet > "$work/cave-$name.txt"
    grep -E "limit (met|missed): frame CPU\+GPU max " "$work/cave-$name.txt" | sed "s/^/$name: /"
    rm -rf "$work/out-$name"
  done
done
python3 "$(dirname "$0")/hitches.py" "$work" | tee "$work/hitches.md"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$work/gpu.txt"
echo "${VLF_COMMIT:-unknown}" > "$work/commit.txt"
date -u +%Y-%m-%dT%H:%M:%SZ > "$work/date.txt"
(cd "$work" && tar cf - gpu.txt commit.txt date.txt hitches.md hitches.json cave-*.toml cave-*.txt cave-*.json | xz -T0 -6 > "$out/hitches.tar.xz")
