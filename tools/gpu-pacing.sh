#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: frame pacing of the 4-wall stereo CAVE (8 views of 1920x1200,
# headless) on the scripted walks of config/paths/ through the generated 100K- and 1M-triangle
# classrooms with a mirror and through the mirror gallery (frames spread evenly over each walk).
# Reports (JSON + table) and the last frame's overview into OUT_DIR/pacing.tar.
# With XR_RUNTIME_LIBRARY set (tests/xr-runtime's library), also the headset at 2064x2208 per eye
# (Meta Quest 3's recommended size) on vlf's test runtime, 900 frames at 90 Hz, on the same walks' scenes, paced (--fit-frame-time):
# the array swapchain (default), and on the 100K classroom also a swapchain per eye (xr-*-per-eye).
# XR_OBJECTS=FILE.toml (e.g. config/headset/body.toml) gives the headset runs `--objects FILE`:
# the participant's body on the tracked head (reports named xr-<scene>-body).
# SCENES (default "classroom-100k classroom-1m gallery") picks the walks; AA=N draws N eye rays per
# pixel instead of the configuration's 4 (reports named cave-<scene>-aaN). TAG=name adds -name to
# the reports and names the archive pacing-name.tar; WORK=dir keeps the generated scenes and light
# fields there and reuses them (several builds or shader variants on the same light fields).
#   tools/gpu-pacing.sh VLF_BINARY OUT_DIR [FRAMES]
set -uo pipefail
vlf=$1; out=$2; frames=${3:-300}; work=${WORK:-$(mktemp -d)}; mkdir -p $work
quiet() { grep -v XDG_RUNTIME_DIR; }
# generate SCENE: the walk's scene as `vlf generate` makes it
source "$(dirname "$0")/walk-scenes.sh"
suffix=${AA:+-aa$AA}${TAG:+-$TAG}
xr_suffix=$suffix${XR_OBJECTS:+-body}
for scene in ${SCENES:-classroom-100k classroom-1m gallery}; do
  if [ ! -f $work/$scene.vlf ]; then
    "$vlf" generate $(generate $scene) -o $work/$scene | quiet | tail -1
    "$vlf" propagate $work/$scene/scene.toml -o $work/$scene.vlf 2>&1 | quiet | grep -E "iterations|propagation  |triangles"
  fi
  # the walk CAVE (config/displays/cave-4wall-walk.toml) on this scene's path
  sed "s|^path = .*|path = \"$(walk_path $scene)\"|" config/displays/cave-4wall-walk.toml > $work/cave-$scene.toml
  [ -n "${AA:-}" ] && sed -i "s/^refresh_hz.*/&\nantialiasing = $AA/" $work/cave-$scene.toml
  "$vlf" cave $work/cave-$scene.toml --scene $work/$scene.vlf --headless --frames $frames --out $work/out-$scene \
    --json $work/cave-$scene$suffix.json 2>&1 | quiet | tee $work/cave-$scene$suffix.txt | tail -16
  cp $work/out-$scene/overview.png $work/cave-$scene$suffix-overview.png
  if [ -n "${XR_RUNTIME_LIBRARY:-}" ]; then
    manifest=$work/runtime.json
    printf '{"file_format_version": "1.0.0", "runtime": {"name": "vlf headless test runtime", "library_path": "%s"}}\n' "$(realpath "$XR_RUNTIME_LIBRARY")" > $manifest
    XR_RUNTIME_JSON=$manifest VLF_TEST_XR_EYE_PIXELS=2064x2208 VLF_TEST_XR_REPORT=$work/xr-$scene$xr_suffix-runtime.txt \
      "$vlf" xr --scene $work/$scene.vlf --frames 900 --fit-frame-time ${XR_OBJECTS:+--objects "$XR_OBJECTS"} \
      --json $work/xr-$scene$xr_suffix.json 2>&1 | quiet | tee $work/xr-$scene$xr_suffix.txt | tail -12
    # the fallback beside it on the first walk's scene: a swapchain per eye (the default above
    # takes the array swapchain, one multiview pass where the device's multiview passes vlf's check)
    if [ "$scene" = classroom-100k ] && [ -z "${XR_OBJECTS:-}" ]; then
      XR_RUNTIME_JSON=$manifest VLF_TEST_XR_EYE_PIXELS=2064x2208 VLF_TEST_XR_REPORT=$work/xr-$scene$suffix-per-eye-runtime.txt \
        "$vlf" xr --scene $work/$scene.vlf --frames 900 --fit-frame-time --swapchains per-eye \
        --json $work/xr-$scene$suffix-per-eye.json 2>&1 | quiet | tee $work/xr-$scene$suffix-per-eye.txt | tail -12
    fi
  fi
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar cf "$out/pacing${TAG:+-$TAG}.tar" gpu.txt commit.txt date.txt cave-*.json cave-*.txt cave-*-overview.png $(cd $work && ls xr-* 2>/dev/null))
