#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: references, sweeps and the walkthrough for the guide's
# accuracy page (docs/guide/accuracy.md), packed into OUT_DIR/accuracy.tar.   tools/gpu-accuracy.sh VLF_BINARY OUT_DIR
set -uo pipefail
vlf=$1; out=$2; work=$(mktemp -d)
for scene in cornell cornell-mirror; do
  "$vlf" reference scenes/$scene/scene.toml --size 256x256 --spp 16384 --seed 1 -o $work/ref-$scene.exr 2>&1 | grep -v XDG
  "$vlf" render scenes/$scene/scene.toml --size 256x256 -o $work/default-$scene.exr 2>&1 | grep -v XDG
  "$vlf" compare $work/default-$scene.exr $work/ref-$scene.exr --json > $work/default-$scene.json
  "$vlf" compare $work/default-$scene.exr $work/ref-$scene.exr --diff $work/diff-$scene.png | tee $work/default-$scene.txt
  "$vlf" sweep scenes/$scene/scene.toml --reference $work/ref-$scene.exr --spp 1,4,16,64,256,1024,4096 --ssaa 1 --out $work/sweep-$scene 2>&1 | grep -v XDG | tail -3
done
"$vlf" sweep scenes/cornell/scene.toml --walkthrough --frames 8 --size 256x256 --reference-spp 4096 --out $work/walk 2>&1 | grep -v XDG | tail -3
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt; echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
(cd $work && tar cf "$out/accuracy.tar" .)
