#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: what a propagation's setup costs at scale (issue 32, item 5).
# `vlf propagate` at default settings of Cornell, the generated 1M and 5M mirror classrooms
# (`vlf generate classroom --size N --mirrors`; the 5M one RUNS_5M times, 3 by default, for the
# spread) and, when models/staircase exists (bash tools/get-models.sh staircase), the Wooden
# Staircase: each run's
# report (JSON and text: the setup split by step, visibility, propagation, GPU memory) and the
# command's wall time and peak host memory (/usr/bin/time), into OUT/setup.tar.
# With VLF_BEFORE=another build, the classrooms are propagated with it too (before-*; the 5M one
# twice).
#   tools/gpu-setup.sh VLF_BINARY OUT
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2")
cd "$(dirname "$0")/.."
work=$(mktemp -d)/setup; mkdir -p "$work"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$work/gpu.txt" 2>/dev/null
date -u +%FT%TZ >> "$work/gpu.txt"
for s in 1000000 5000000; do "$vlf" generate classroom --size $s --mirrors -o "$work/../c$s" 2>&1 | tail -1; done
run() { # NAME SCENE [BINARY]
  local bin=${3:-$vlf}
  /usr/bin/time -f "wall %e s, max RSS %M KB" "$bin" propagate "$2" -o "$work/../$1.vlf" \
    --report "$work/$1.json" > "$work/$1.txt" 2>&1
  echo "$1: $(grep -E '^ *(setup|visibility|propagation) ' "$work/$1.txt" | tr -s ' ' | tr '\n' ';') $(tail -1 "$work/$1.txt")"
  rm -f "$work/../$1.vlf"
}
run cornell scenes/cornell/scene.toml
run classroom-1m "$work/../c1000000/scene.toml"
run classroom-5m "$work/../c5000000/scene.toml"
run classroom-5m-again "$work/../c5000000/scene.toml"
for i in $(seq 3 "${RUNS_5M:-3}"); do run "classroom-5m-$i" "$work/../c5000000/scene.toml"; done
[ -f models/staircase/scene.toml ] && run staircase models/staircase/scene.toml
if [ -n "${VLF_BEFORE:-}" ]; then
  run before-classroom-1m "$work/../c1000000/scene.toml" "$(realpath "$VLF_BEFORE")"
  run before-classroom-5m "$work/../c5000000/scene.toml" "$(realpath "$VLF_BEFORE")"
  run before-classroom-5m-again "$work/../c5000000/scene.toml" "$(realpath "$VLF_BEFORE")"
fi
tar -C "$work/.." -cf "$out/setup.tar" setup
