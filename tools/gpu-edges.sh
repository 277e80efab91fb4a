#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: edge antialiasing (src/render/edges.rs, issue 32 items 2 and 6)
# against eye rays on every pixel. The 4-wall stereo CAVE of config/displays/cave-4wall-walk.toml
# (8 views of 1920x1200) walks the shipped walks of config/paths/ through the generated scenes,
# unpaced (fit_frame_time = false), once per variant:
#   ref64    64 eye rays on every pixel, each with its own reflection (edge antialiasing with no
#            contrast allowed: every pixel that differs at all from a neighbour is refined)
#   aa16     16 eye rays per pixel (the still the issue's edge error is measured against; two
#            eye rays share a reflection)
#   aa4      4 eye rays per pixel (today's real-time default)
#   aa1      1 eye ray per pixel
#   edges8   1 eye ray per pixel, 8 where a pixel differs from a neighbour
#   edges16  1 eye ray per pixel, 16 there
#   paced-aa4, paced-edges8, paced-edges16  the same, frame pacing on (fit_frame_time = true: 1
#            to 16 eye rays per pixel by tile as the views' GPU time allows, and on the edges of
#            the tiles it gives 2 or more, 8 or 16)
# Each run writes its last frame's views as EXR; the edge error is each view's display MSE
# against aa16's same view of the same frame, and against ref64's (tools/edge-error.py). Prints per variant the
# views' GPU p50/p99, the frame's GPU median and p99, and the edge error; the reports, the EXRs'
# comparisons and the overviews go into OUT_DIR/edges.tar.
# SCENES (default "classroom-100k classroom-1m"), VARIANTS pick; WORK=dir keeps the generated
# scenes and light fields there and reuses them.
#   tools/gpu-edges.sh VLF_BINARY OUT_DIR [FRAMES]
set -uo pipefail
vlf=$1; out=$2; frames=${3:-300}; work=${WORK:-$(mktemp -d)}; mkdir -p $work "$out"
quiet() { grep -v XDG_RUNTIME_DIR; }
source "$(dirname "$0")/walk-scenes.sh"
variants=${VARIANTS:-ref64 aa16 aa4 aa1 edges8 edges16}
settings() {  # variant -> the display TOML's lines
  case $1 in
    paced-aa4) echo "antialiasing = 4" ;;
    paced-edges*) printf 'antialiasing = 4\nedge_antialiasing = { samples = %s }' "${1#paced-edges}" ;;
    ref64) printf 'antialiasing = 1\nedge_antialiasing = { samples = 64, contrast = 0.0 }' ;;
    aa*) echo "antialiasing = ${1#aa}" ;;
    edges*) printf 'antialiasing = 1\nedge_antialiasing = { samples = %s }' "${1#edges}" ;;
  esac
}
for scene in ${SCENES:-classroom-100k classroom-1m}; do
  if [ ! -f $work/$scene.vlf ]; then
    "$vlf" generate $(generate $scene) -o $work/$scene | quiet | tail -1
    "$vlf" propagate $work/$scene/scene.toml -o $work/$scene.vlf 2>&1 | quiet | grep -E "iterations|propagation  |triangles"
  fi
  for v in $variants; do
    name=$scene-$v
    sed -e "s|^path = .*|path = \"$(walk_path $scene)\"|" \
        -e "s|^fit_frame_time = .*|fit_frame_time = $([[ $v == paced-* ]] && echo true || echo false)|" \
        config/displays/cave-4wall-walk.toml |
      EXTRA="$(settings $v)" awk '{print} /^refresh_hz/ {print ENVIRON["EXTRA"]}' > $work/cave-$name.toml
    "$vlf" cave $work/cave-$name.toml --scene $work/$scene.vlf --headless --frames $frames --exr \
      --out $work/out-$name --json $work/cave-$name.json 2>&1 | quiet > $work/cave-$name.txt
    cp $work/out-$name/overview.png $work/cave-$name-overview.png
  done
  python3 "$(dirname "$0")/edge-error.py" "$vlf" $work $scene $variants | tee $work/edges-$scene.txt
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar cf "$out/edges.tar" gpu.txt commit.txt date.txt cave-*.toml cave-*.json cave-*.txt cave-*-overview.png edges-*.txt edges-*.json)
