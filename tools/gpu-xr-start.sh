#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the headset's start, repeated. RUNS sessions of the paced headset
# (2064x2208 per eye, 90 Hz, vlf's test runtime, --fit-frame-time) on each of SCENES (default
# classroom-100k-glossy; names as in tools/walk-scenes.sh), FRAMES frames each (default 900); each
# run's report (JSON, with its first frames one by one, and the printed table) into
# OUT_DIR/xr-start[-TAG].tar, and a line per run: late and dropped frames, and the first frames'
# wake and GPU completion before their display time. XR_RUNTIME_LIBRARY: tests/xr-runtime's library.
#   tools/gpu-xr-start.sh VLF_BINARY OUT_DIR [RUNS] [FRAMES]
set -uo pipefail
vlf=$1; out=$2; runs=${3:-5}; frames=${4:-900}; work=${WORK:-$(mktemp -d)}; mkdir -p $work
: "${XR_RUNTIME_LIBRARY:?set XR_RUNTIME_LIBRARY to the library tests/xr-runtime builds}"
quiet() { grep -v XDG_RUNTIME_DIR; }
source "$(dirname "$0")/walk-scenes.sh"
manifest=$work/runtime.json
printf '{"file_format_version": "1.0.0", "runtime": {"name": "vlf headless test runtime", "library_path": "%s"}}\n' \
  "$(realpath "$XR_RUNTIME_LIBRARY")" > $manifest
names=()
for scene in ${SCENES:-classroom-100k-glossy}; do
  if [ ! -f $work/$scene.vlf ]; then
    "$vlf" generate $(generate $scene) -o $work/$scene | quiet | tail -1
    "$vlf" propagate $work/$scene/scene.toml -o $work/$scene.vlf 2>&1 | quiet | grep -E "propagation  "
  fi
  for run in $(seq 1 $runs); do
    name=xr-$scene${TAG:+-$TAG}-run$run
    XR_RUNTIME_JSON=$manifest VLF_TEST_XR_EYE_PIXELS=2064x2208 VLF_TEST_XR_REPORT=$work/$name-runtime.txt \
      "$vlf" xr --scene $work/$scene.vlf --frames $frames --fit-frame-time ${XR_ARGS:-} \
      --json $work/$name.json > $work/$name.txt 2>&1
    python3 "$(dirname "$0")/xr-start-line.py" $work/$name.json
    names+=($name.json $name.txt $name-runtime.txt)
  done
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar cf "$out/xr-start${TAG:+-$TAG}.tar" gpu.txt commit.txt date.txt "${names[@]}")
