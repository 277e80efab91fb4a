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
"$vlf" bench --scene scenes/cornell/scene.toml --frames 300 --config config/propagation/paper.toml --size 256x192 2>&1 | grep "render "
"$vlf" bench --scene scenes/cornell/scene.toml --frames 300 --config config/propagation/paper.toml --size 2048x1536 2>&1 | grep "render "
# BENCHMARKS.md: the fixed preamble, then the generated sections
{
  cat <<'HEAD'
# Benchmarks

Every figure below is produced by `vlf bench` (see `tools/gpu-bench.sh`, which runs it on the
lent GPU machine and assembles this file); none is typed by hand. Timings on a software
adapter (lavapipe) are never reported here. The paper's column is Mortensen, Khanna & Slater
(2007), Table 1, Cornell box row (GeForce 8800 GTX, 512 directions, 3 iterations).

Two runs: our default settings, converged to a residual of 1e-3 (unshot / emitted power), and
the paper's settings (about 512 directions, 64x64 cells, 8x8-cell tiles, 3 iterations, which
leave about 10% of the light unshot). Memory while propagating is dominated by the visibility
lists, built once and kept for all iterations (8 bytes per cell and per layer); rendering keeps
only the face table, the converged radiance atlas and the render mesh.

HEAD
  echo "### Default settings"; echo; sed 1d "$out/bench-default.md"; echo
  echo "### The paper's settings (config/propagation/paper.toml)"; echo; sed 1d "$out/bench-paper.md"
} > "$out/BENCHMARKS.md"
