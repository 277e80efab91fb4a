#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the Cornell box and Cornell-mirror at default settings with two
# builds, against one `vlf reference` image each (256x256, SPP samples per pixel, seed 1), as
# README's accuracy figures are made (tools/gpu-accuracy.sh), to show that a change to the
# light field kept them.
#   tools/gpu-cornell-before-after.sh OUT VLF_AFTER VLF_BEFORE
# OUT/<scene>-after.json and <scene>-before.json: `vlf compare --json`. SPP (default 16384)
# from the environment.
set -uo pipefail
out=$(mkdir -p "$1" && realpath "$1"); after=$(realpath "$2"); before=$(realpath "$3")
spp=${SPP:-16384}
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for scene in cornell cornell-mirror; do
  "$after" reference scenes/$scene/scene.toml --size 256x256 --spp "$spp" --seed 1 \
    -o "$work/ref-$scene.exr" 2>&1 | grep -v XDG | tail -1
  for build in after before; do
    vlf=$after; [ "$build" = before ] && vlf=$before
    "$vlf" render scenes/$scene/scene.toml --size 256x256 -o "$work/$build-$scene.exr" 2>&1 \
      | grep -v XDG | tail -1
    "$after" compare "$work/$build-$scene.exr" "$work/ref-$scene.exr" --json \
      > "$out/$scene-$build.json"
    python3 -c "import json,sys; c=json.load(open(sys.argv[1])); print(sys.argv[2], 'mean %.5f display MSE %.3e relMSE %.3e' % (c['mean_ratio'], c['display_mse'], c['rel_mse']))" \
      "$out/$scene-$build.json" "$scene $build"
  done
done
