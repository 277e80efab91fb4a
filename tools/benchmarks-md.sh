#!/usr/bin/env bash
# Assembles BENCHMARKS.md from what the lent GPU wrote into DIR: the suite (`vlf bench --suite
# --json suite.json`: its Markdown is regenerated here from the JSON), the per-scene sections
# `vlf bench --markdown` wrote (bench-{default,paper,mirror,mirror-paper,perturb4}.md) and the
# CAVE reports (cave-{static,walk}.json), then the OpenXR section from XR_DIR (tools/gpu-xr.sh's
# output, default docs/results/xr-h200). Usage: tools/benchmarks-md.sh DIR [VLF] [XR_DIR] > BENCHMARKS.md
set -euo pipefail
dir=$1
vlf=${2:-target/release/vlf}
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

`tools/gpu-bench.sh` runs the suite twice and reports the second run: on a fresh machine the
first also pays the driver's shader compilation in its setup times (up to 0.5 s a scene; kept
in docs/results/h100/bench/suite-cold.json).

HEAD
if [ -f "$dir/suite.json" ]; then
  "$vlf" bench --suite --from-json "$dir/suite.json" | sed 's/^## /### /'
  echo
  echo '![suite scaling](docs/images/suite-scaling.png)'
  echo
fi
cat <<'HEAD'
Rendering is one compute pass per view (eye rays, then the light field lookups), so frame time
grows with the pixel count:

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
# the CAVE (tools/gpu-cave.sh): vlf cave --headless --json reports, if present
for run in static walk; do
  f="$dir/cave-$run.json"
  [ -f "$f" ] || continue
  python3 - "$f" "$run" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
title = {"static": "static head", "walk": "scripted walk into the mirror (config/paths/cornell-walk.toml)"}[sys.argv[2]]
print(f"### CAVE: {r['display']}, {title}\n")
print(f"`vlf cave --headless` on **{r['adapter']}**, Cornell-mirror at default settings, {r['frames']} frames of {r['views_per_frame']} views submitted back to back (GPU timestamp queries). Target for 8 views of 1920x1200: under 8.3 ms (120 Hz).\n")
a = r["all_views_gpu_ms"]
print(f"All views of one frame: median {a['median']:.3f} ms, p99 {a['p99']:.3f} ms, max {a['max']:.3f} ms.\n")
if r.get("worst_p99_over_p50") is not None:
    verdict = "yes" if r["constant_frame_time"] else "**no**"
    print(f"Constant per-eye frame time (every view's GPU time p99/p50 <= 1.10): {verdict}, worst p99/p50 {r['worst_p99_over_p50']:.3f}.\n")
print("| wall | eye | pixels | GPU p50 (ms) | p95 | p99 | max | p99/p50 | verdict |\n|---|---|---|---|---|---|---|---|---|")
for v in r["views"]:
    d = v["gpu_ms"]
    flag = "**ABOVE THE LIMIT**" if v["p99_over_p50"] > 1.10 else "met"
    print(f"| {v['wall']} | {v['eye']} | {v['pixels'][0]}x{v['pixels'][1]} | {d['median']:.3f} | {d['p95']:.3f} | {d['p99']:.3f} | {d['max']:.3f} | {v['p99_over_p50']:.3f} | {flag} |")
print()
PY
done
# the CAVE as a 2-rank MPI cluster, one GPU per rank (tools/gpu-cluster.sh), if present: in DIR
# itself, or the 2-GPU machines' results beside DIR's machine (docs/results/h200x2/cluster and
# docs/results/h100x2/cluster beside docs/results/h100/bench)
results=$(dirname "$(dirname "$dir")")
for cluster_dir in "$dir" "$results/h200x2/cluster" "$results/h100x2/cluster"; do
  if compgen -G "$cluster_dir/cluster-*.json" > /dev/null; then
    bash "$(dirname "$0")/cluster-md.sh" "$cluster_dir"
  fi
done
# frame pacing on the walks through real scenes (tools/gpu-pacing.sh): DIR's sibling pacing/
pacing_dir=$(dirname "$dir")/pacing
if [ -f "$pacing_dir/gpu.txt" ]; then
  bash "$(dirname "$0")/pacing-md.sh" "$pacing_dir"
fi
# the headset's first frames (tools/gpu-xr-start.sh): DIR's h200 sibling headset-start/
if [ -d "$results/h200/headset-start" ]; then
  python3 "$(dirname "$0")/headset-start-md.py" "$results/h200/headset-start"
fi
# edge antialiasing on the walk CAVE (tools/gpu-edges.sh): DIR's h200 sibling edges/
if [ -d "$results/h200/edges" ]; then
  python3 "$(dirname "$0")/edges-md.py" "$results/h200/edges"
fi
# the body in the walk CAVE (tools/gpu-body.sh): the newest run (docs/results/h200/
# body-indirect/walks-7caab06/, the resolve without the per-point shadow rays; walks/, the shadow
# atlas's indirect rays and the fit's warm-up), then
# body-warm-up/ (a frame drawn unshown after the fit), the ones before (body-reserve/, the
# pacer's reserve made at the fit; body-vertex-light/, the vertices' light), then DIR's sibling
# body/
h200=$(dirname "$(dirname "$dir")")/h200
for body_dir in "$h200/body-indirect/walks-7caab06" "$h200/body-indirect/walks" "$h200/body-warm-up" "$h200/body-reserve" "$h200/body-vertex-light" "$(dirname "$dir")/body"; do
  if [ -f "$body_dir/gpu.txt" ]; then
    bash "$(dirname "$0")/body-md.sh" "$body_dir"
  fi
done
# behaviour unchanged across the refactors (tools/gpu-identity.sh): DIR's sibling identity/
identity_dir=$(dirname "$dir")/identity
if [ -f "$identity_dir/identity.txt" ]; then
  echo "### Two builds: the same light fields, the same speed"
  echo
  echo "\`tools/gpu-identity.sh\` ($(cat "$identity_dir/builds.txt")): the light fields of four scenes byte for byte, the suite of both builds and the 4-wall CAVE's walks at a fixed 4 eye rays per pixel, three runs each taking turns, judged against the spread of the old build's own runs."
  echo
  echo '```'; cat "$identity_dir/identity.txt"; echo '```'
  echo
  cat "$identity_dir/suite-compare.md"
  echo
fi
xr_dir=${3:-docs/results/xr-h200}
if compgen -G "$xr_dir/xr-*.json" > /dev/null; then
  bash "$(dirname "$0")/xr-md.sh" "$xr_dir"
fi
