#!/usr/bin/env bash
# Runs on the lent NVIDIA machine (see DEVELOPERS.md): `vlf bench` on the Cornell box at our
# defaults and at the paper's settings, and the README image, everything into OUT_DIR.
#   tools/gpu-bench.sh VLF_BINARY OUT_DIR
set -uo pipefail
vlf=$1; out=$2
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader > "$out/gpu.txt" 2>&1
"$vlf" bench --scene scenes/cornell/scene.toml --frames 300 \
  --json "$out/bench-default.json" --markdown "$out/bench-default.md" 2>&1 | grep -v XDG
"$vlf" bench --scene scenes/cornell/scene.toml --frames 300 --config config/propagation/paper.toml \
  --json "$out/bench-paper.json" --markdown "$out/bench-paper.md" 2>&1 | grep -v XDG
"$vlf" render scenes/cornell/scene.toml --camera front -o "$out/cornell.png" 2>&1 | grep -v XDG
"$vlf" render scenes/cornell/scene.toml --camera front -o "$out/cornell.exr" 2>&1 | grep -v XDG
# frame time against pixel count (is there a fixed floor?)
for size in 256x192 1024x768 2048x1536; do
  "$vlf" bench --scene scenes/cornell/scene.toml --frames 300 --config config/propagation/paper.toml --size $size 2>&1 | grep "render "
done | sed 's/^ *//' > "$out/render-scaling.txt"
bash "$(dirname "$0")/benchmarks-md.sh" "$out" > "$out/BENCHMARKS.md"
