#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: vlf's half of the moving objects' comparison with Mitsuba
# (tools/body-accuracy.py, which path traces the same frozen pose on any machine): the figure
# configs of config/objects/ drawn into their scenes at default settings, as EXR:
#   OUT/cornell-mirror.exr   scenes/cornell-mirror, camera front, 256x256, with
#                            config/objects/cornell-mirror-figure.toml
#   OUT/classroom-mirror.exr the generated 10K mirror classroom, camera mirror, 320x240, with
#                            config/objects/classroom-mirror-figure.toml
# and OUT/times.txt (each render's wall time, propagation included). Then, anywhere:
#   python3 tools/body-accuracy.py VLF SCENE OBJECTS DIR --vlf-exr OUT/<name>.exr ...
#   tools/gpu-body-accuracy.sh VLF_BINARY OUT
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2")
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null
"$vlf" generate classroom --size 10000 --mirrors -o "$work/classroom" | tail -1
render() {
  local name=$1 scene=$2 camera=$3 size=$4 objects=$5 start=$SECONDS
  "$vlf" render "$scene" --camera "$camera" --size "$size" --objects "$objects" -o "$out/$name.exr" 2>&1 \
    | grep -v XDG_RUNTIME_DIR | tail -2
  echo "$name $((SECONDS - start)) s" >> "$out/times.txt"
}
render cornell-mirror scenes/cornell-mirror/scene.toml front 256x256 config/objects/cornell-mirror-figure.toml
render classroom-mirror "$work/classroom/scene.toml" mirror 320x240 config/objects/classroom-mirror-figure.toml
cat "$out/times.txt"
