#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: `vlf xr` through the Khronos OpenXR loader on vlf's headless
# test runtime (tests/xr-runtime: a simulated 90 Hz stereo headset; no display), at the per-eye
# sizes of two real headsets, on Cornell and Cornell-mirror. Reports (JSON + table) and the
# left eye's screenshots go to OUT_DIR.
#   tools/gpu-xr.sh VLF_BINARY RUNTIME_LIBRARY OUT_DIR
set -uo pipefail
vlf=$1; runtime=$2; out=$3
manifest=/tmp/vlf_xr_test_runtime.json
printf '{"file_format_version": "1.0.0", "runtime": {"name": "vlf headless test runtime", "library_path": "%s"}}\n' "$(realpath "$runtime")" > "$manifest"
export XR_RUNTIME_JSON=$manifest XDG_RUNTIME_DIR=/tmp
"$vlf" propagate scenes/cornell/scene.toml -o /tmp/cornell.vlf 2>&1 | grep -E "iterations"
"$vlf" propagate scenes/cornell-mirror/scene.toml -o /tmp/mirror.vlf 2>&1 | grep -E "iterations"
# Valve Index (1440x1600 per eye) and Meta Quest 3 (2064x2208 per eye, its recommended size)
for eyes in 1440x1600 2064x2208; do
  for scene in cornell mirror; do
    name="xr-$scene-$eyes"
    VLF_TEST_XR_EYE_PIXELS=$eyes VLF_TEST_XR_REPORT="$out/$name-runtime.txt" \
      "$vlf" xr --scene /tmp/$scene.vlf --frames 900 --screenshot "$out/$name-left.png" --screenshot-frame 450 \
      --json "$out/$name.json" 2>&1 | grep -v XDG | tee "$out/$name.txt"
  done
done
# the device returns a handful of files: everything in one archive
tar -C "$out" -cf /tmp/xr.tar . && rm -f "$out"/xr-* && mv /tmp/xr.tar "$out/xr.tar"
