#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the body's shadows in the shipped walk CAVE (issue 28 item 6).
# The 8-view 1920x1200 walk CAVE (config/displays/cave-4wall-walk.toml, 120 Hz, paced) walks the
# 100K and 1M classrooms with the shipped avatar on the walking head three ways: its shadows from
# the shadow atlas (the default, once per frame for all views), per pixel of every view (as
# before), and without shadows. Each report gives every view's GPU p50/p99, the frame's max, the
# eye rays per pixel and the moving objects' update (skin, refit and the shadow atlas). About
# 3 minutes on an H100 (two scenes generated and propagated, six runs of FRAMES frames).
# Reports (JSON + text + overview) into OUT_DIR/body.tar, as tools/gpu-body.sh writes them.
#   tools/gpu-shadow.sh VLF_BINARY OUT_DIR [FRAMES]
set -uo pipefail
VARIANTS="body body-perpixel body-noshadow" exec bash "$(dirname "$0")/gpu-body.sh" "$1" "$2" "${3:-300}"
