#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the shipped Space Ship Hallway propagated at default settings,
# without and with rim rays, each with its report (the power balance per iteration and the
# materials where the loss concentrates: `power_balance` in the JSON).
# Writes OUT_DIR/hallway-default.{json,txt} and OUT_DIR/hallway-rim.{json,txt}.
#   tools/gpu-balance.sh VLF_BINARY OUT_DIR
set -euo pipefail
vlf=$1; out=$2; work=$(mktemp -d); mkdir -p "$out"
"$vlf" propagate scenes/space-ship-hallway/scene.toml -o "$work/h.vlf" \
  --report "$out/hallway-default.json" > "$out/hallway-default.txt" 2>&1
"$vlf" propagate scenes/space-ship-hallway/scene.toml --rim-rays -o "$work/h2.vlf" \
  --report "$out/hallway-rim.json" > "$out/hallway-rim.txt" 2>&1
rm -rf "$work"
grep -h "power balance " "$out"/hallway-*.txt
