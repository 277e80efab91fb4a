#!/usr/bin/env bash
# Assembles BENCHMARKS.md from the Markdown sections `vlf bench --markdown` wrote into DIR
# (bench-{default,paper,mirror,mirror-paper,perturb4}.md). Usage: tools/benchmarks-md.sh DIR > BENCHMARKS.md
set -euo pipefail
dir=$1
cat <<'HEAD'
# Benchmarks

Every figure below is produced by `vlf bench` (`tools/gpu-bench.sh` runs it on the lent GPU
machine; `tools/benchmarks-md.sh` assembles this file from its Markdown output); none is typed
by hand. Timings on a software adapter (lavapipe) are never reported here. The paper's column
is Mortensen, Khanna & Slater (2007), Table 1, Cornell box row (GeForce 8800 GTX, 512
directions, 3 iterations), which included 931,136 mirror (non-diffuse) elements: compare it
with our Cornell-mirror rows (the tall box an ideal mirror of reflectance 0.8); the plain
Cornell rows are diffuse-only.

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
section() {  # title file
  if [ -f "$dir/$2" ]; then echo "### $1"; echo; sed 1d "$dir/$2"; echo; fi
}
section "Cornell, default settings" bench-default.md
section "Cornell, the paper's settings (config/propagation/paper.toml)" bench-paper.md
section "Cornell-mirror, default settings" bench-mirror.md
section "Cornell-mirror, the paper's settings" bench-mirror-paper.md
section "Cornell, default settings with 4 perturbed direction sets (--perturb 4)" bench-perturb4.md
