#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: vlf's half of the normal maps' comparison with Mitsuba 3
# (tools/normalmap-accuracy.py, which path traces the scene on any machine): the normal-mapped
# wall scenes/normal-wall at default settings, camera front, 512x512, as OUT/vlf.exr, with
# OUT/times.txt (the render's wall time, propagation included) and OUT/gpu.txt. Then, anywhere
# with Mitsuba 3 (the issue's figure: >= 4096 spp):
#   python3 tools/normalmap-accuracy.py VLF DIR --size 512x512 --spp 4096 --vlf-exr OUT/vlf.exr
#   tools/gpu-normalmap.sh VLF_BINARY OUT
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2")
cd "$(dirname "$0")/.."
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null
start=$SECONDS
"$vlf" render scenes/normal-wall/scene.toml --camera front --size 512x512 -o "$out/vlf.exr" 2>&1 \
  | grep -v XDG_RUNTIME_DIR | tail -2
echo "normal-wall $((SECONDS - start)) s" >> "$out/times.txt"
cat "$out/times.txt"
