#!/usr/bin/env bash
# Assembles BENCHMARKS.md from the Markdown sections `vlf bench --markdown` wrote into DIR
# (bench-default.md, bench-paper.md). Usage: tools/benchmarks-md.sh DIR > BENCHMARKS.md
set -euo pipefail
dir=$1
cat <<'HEAD'
# Benchmarks

Every figure below is produced by `vlf bench` (`tools/gpu-bench.sh` runs it on the lent GPU
machine; `tools/benchmarks-md.sh` assembles this file from its Markdown output); none is typed
by hand. Timings on a software adapter (lavapipe) are never reported here. The paper's column
is Mortensen, Khanna & Slater (2007), Table 1, Cornell box row (GeForce 8800 GTX, 512
directions, 3 iterations). That row includes 931,136 mirror (non-diffuse) elements; ours is
the diffuse-only Cornell box, so it does less work per iteration. The Cornell-mirror row comes
with the non-diffuse light field.

Two runs: our default settings, converged to a residual of 1e-3 (unshot / emitted power), and
the paper's settings (about 512 directions, 64x64 cells, 8x8-cell tiles, 3 iterations, which
leave about 10% of the light unshot). Memory while propagating is dominated by the visibility
lists, built once and kept for all iterations (8 bytes per cell and per layer); rendering keeps
only the face table, the converged radiance atlas and the render mesh.

Frame time grows with the pixel count, so the H200's fixed-function graphics path (weak on this
data-centre chip) is the limit, not the light field lookup:

HEAD
if [ -f "$dir/render-scaling.txt" ]; then
  echo '```'; cat "$dir/render-scaling.txt"; echo '```'
else
  echo "(no scaling run in this batch)"
fi
echo
echo "### Default settings"; echo; sed 1d "$dir/bench-default.md"; echo
echo "### The paper's settings (config/propagation/paper.toml)"; echo; sed 1d "$dir/bench-paper.md"
