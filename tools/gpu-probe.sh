#!/usr/bin/env bash
# Quick render-cost probe on the lent GPU (design decisions, not published figures):
# view times of Cornell-mirror at 1, 2 and 4 eye rays per pixel side, and the 8-view CAVE walk.
#   tools/gpu-probe.sh VLF_BINARY
vlf=${1:-.bin/vlf}; w=$(mktemp -d)
$vlf propagate scenes/cornell-mirror/scene.toml -o $w/m.vlf 2>&1 | grep -E "setup|visibility  |propagation  "
$vlf propagate scenes/cornell-mirror/scene.toml -o $w/m.vlf 2>&1 | grep -E "setup|visibility  |propagation  "
for aa in 1 2 4; do $vlf bench --scene scenes/cornell-mirror/scene.toml --aa $aa --frames 100 2>&1 | grep -E "render "; done
$vlf bench --scene scenes/cornell/scene.toml --aa 2 --frames 100 2>&1 | grep -E "render "
$vlf cave config/displays/cave-4wall-walk.toml --scene $w/m.vlf --headless --frames 60 --out $w/cw 2>&1 | grep -E "all views|constant"
