#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: what drawing textures per pixel (the light field's texture
# detail, src/lightfield/textures.rs) does to accuracy and to a view's time, for one build.
# Run it once per build (the build before the detail and the build with it) on the same machine.
#   - OUT/suite: the accuracy suite's light-field half (tools/gpu-accuracy-suite.sh lightfield:
#     `vlf verify` at default settings against `vlf reference` at 4096 spp, 640x360) on every
#     suite model present (models/ unpacked from MODELS_TAR if given);
#   - OUT/bench/<model>.json: `vlf bench` of the textured models' first camera (1024x768, the
#     real-time eye rays per pixel, 300 frames: GPU milliseconds per view).
# Packed into OUT/texture-detail.tar, also when the run is cut short.
# PARTS (default "bench suite") picks and orders the parts.
#   tools/gpu-texture-detail.sh VLF_BINARY OUT
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2")
cd "$(dirname "$0")/.."
work=$(mktemp -d)
pack() { (cd "$work" && tar cf "$out/texture-detail.tar" --exclude="*.exr" --ignore-failed-read gpu.txt commit.txt bench suite 2>/dev/null); }
trap 'pack; exit 1' TERM
trap pack EXIT
[ -n "${MODELS_TAR:-}" ] && tar xJf "$MODELS_TAR"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$work/gpu.txt" 2>/dev/null
echo "${VLF_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null)}" > "$work/commit.txt"
bench() {
  mkdir -p "$work/bench"
  for scene in scenes/space-ship-hallway/scene.toml scenes/textured-room/scene.toml \
      models/staircase/scene.toml models/living-room/scene.toml; do
    [ -f "$scene" ] || continue
    name=$(basename "$(dirname "$scene")")
    "$vlf" bench --scene "$scene" --frames 300 --size 1024x768 --json "$work/bench/$name.json" 2>&1 \
      | grep -v XDG_RUNTIME_DIR | grep -iE "render|view|ms" | head -4 | sed "s/^/$name: /"
  done
}
suite() {
  bash tools/gpu-accuracy-suite.sh lightfield "$work/suite" "$vlf" 2>&1 | grep -E "^==|^  [a-z]+ +[0-9]+x"
}
for part in ${PARTS:-bench suite}; do
  echo "=== $part"
  "$part"
done
