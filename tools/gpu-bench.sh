#!/usr/bin/env bash
# Runs on the lent NVIDIA machine (see DEVELOPERS.md): the Cornell benchmark at default
# settings plus renders at other settings, everything into $OUT. Usage:
#   tools/gpu-bench.sh VLF_BINARY OUT_DIR [extra settings "label:flags" ...]
set -uo pipefail
vlf=$1; out=$2; shift 2
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader > "$out/gpu.txt" 2>&1
"$vlf" bench --scene scenes/cornell/scene.toml --frames 300 --json "$out/bench.json" --markdown "$out/bench.md" 2>&1 | tee "$out/bench.txt"
for spec in "$@"; do
  label=${spec%%:*}; flags=${spec#*:}
  echo "== $label: $flags"
  /usr/bin/time -f "$label wall %e s" "$vlf" render scenes/cornell/scene.toml $flags -o "$out/cornell-$label.png" 2>&1 | grep -v XDG
done
