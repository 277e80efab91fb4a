#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: `vlf verify` at default settings on models with two-sided
# materials against `vlf reference`, into OUT_DIR (JSON, tables, error maps):
#   - the Space Ship Hallway (third-party glTF, every material doubleSided), both cameras;
#   - the Cornell box with every material but the light two-sided, and the shipped one-sided
#     box, which must agree (the two-sided fix, docs/guide/scenes.md).
#   tools/gpu-verify.sh VLF_BINARY OUT_DIR [SPP]
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2"); spp=${3:-4096}
cd "$(dirname "$0")/.."
work=$(mktemp -d)
(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || true) > "$out/gpu.txt" 2>&1
git rev-parse --short HEAD > "$out/commit.txt" 2>/dev/null || true
"$vlf" verify scenes/space-ship-hallway/scene.toml --size 640x360 --spp "$spp" --out "$out/hallway" \
  --json "$out/verify-hallway.json" 2>&1 | grep -v XDG | tee "$out/verify-hallway.txt"
cp -r scenes/cornell "$work/cornell-two-sided"
for m in floor ceiling backWall rightWall leftWall shortBox tallBox; do
  printf '\n[materials.%s]\ntwo_sided = true\n' "$m" >> "$work/cornell-two-sided/scene.toml"
done
for scene in scenes/cornell "$work/cornell-two-sided"; do
  name=$(basename "$scene")
  "$vlf" verify "$scene/scene.toml" --size 256x256 --spp "$spp" --out "$out/$name" \
    --json "$out/verify-$name.json" 2>&1 | grep -v XDG | tee "$out/verify-$name.txt"
done
rm -f "$out"/*/*.exr
