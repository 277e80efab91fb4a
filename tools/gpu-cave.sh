#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the 4-wall stereo CAVE (8 views of 1920x1200) headless,
# static on Cornell and walking into Cornell-mirror; reports and overviews into OUT_DIR.
#   tools/gpu-cave.sh VLF_BINARY OUT_DIR
set -uo pipefail
vlf=$1; out=$2
"$vlf" propagate scenes/cornell-mirror/scene.toml -o /tmp/mirror.vlf 2>&1 | grep -E "iterations|propagation  "
"$vlf" cave config/displays/cave-4wall.toml --scene /tmp/mirror.vlf --headless --frames 120 --out /tmp/cave-static --json "$out/cave-static.json" 2>&1 | grep -v XDG
"$vlf" cave config/displays/cave-4wall-walk.toml --scene /tmp/mirror.vlf --headless --frames 120 --out /tmp/cave-walk --json "$out/cave-walk.json" 2>&1 | grep -v XDG
cp /tmp/cave-walk/overview.png "$out/cave-walk-overview.png"
