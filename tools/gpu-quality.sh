#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the picture-quality figures (docs/guide/accuracy.md).
# Default-setting propagation of Cornell and Cornell-mirror (reports; bench runs them again
# warm), 512x512 stills of the accuracy views at default settings (EXR, compared here with the
# Mitsuba references by tools/accuracy.py), view times at 1024x768 with the real-time and the
# still antialiasing, the 8-view 1920x1200 CAVE (static, walking into the mirror, with the wand's
# ray) and a wall of two warped and blended projectors,
# packed into OUT_DIR/quality.tar.gz.          tools/gpu-quality.sh VLF_BINARY OUT_DIR
set -uo pipefail
vlf=$1; out=$2; work=$(mktemp -d)
quiet() { grep -v XDG_RUNTIME_DIR; }
for scene in cornell cornell-mirror; do
  # the printed summary is kept as text too (docs/guide/getting-started.md includes Cornell's)
  "$vlf" propagate scenes/$scene/scene.toml -o $work/$scene.vlf --report $work/propagate-$scene.json 2>&1 | quiet \
    | grep -E '^  [a-zA-Z]' | tee $work/propagate-$scene.txt
  "$vlf" bench --scene scenes/$scene/scene.toml --frames 200 --json $work/bench-$scene.json 2>&1 | quiet | grep -E "render|setup|visibility  |propagation  "
  "$vlf" bench --scene scenes/$scene/scene.toml --frames 50 --aa 16 --json $work/bench-$scene-still.json 2>&1 | quiet | grep -E "render"
done
"$vlf" render $work/cornell.vlf --camera front --size 512x512 -o $work/vlf-cornell-front-512.exr 2>&1 | quiet
for cam in front side; do
  "$vlf" render $work/cornell-mirror.vlf --camera $cam --size 512x512 -o $work/vlf-cornell-mirror-$cam-512.exr 2>&1 | quiet
done
"$vlf" cave config/displays/cave-4wall.toml --scene $work/cornell-mirror.vlf --headless --frames 120 --out $work/cave-static --json $work/cave-static.json 2>&1 | quiet | tail -4
"$vlf" cave config/displays/cave-4wall-walk.toml --scene $work/cornell-mirror.vlf --headless --frames 120 --out $work/cave-walk --json $work/cave-walk.json 2>&1 | quiet | tail -14
# projector warp + blend (two 1920x1200 outputs of one wall) and the wand's ray on 8 views
"$vlf" cave config/displays/wall-2projectors.toml --scene $work/cornell-mirror.vlf --headless --frames 120 --out $work/cave-projectors --json $work/cave-projectors.json 2>&1 | quiet | tail -6
"$vlf" cave config/displays/cave-4wall-wand.toml --scene $work/cornell-mirror.vlf --headless --frames 120 --out $work/cave-wand --json $work/cave-wand.json 2>&1 | quiet | tail -6
cp $work/cave-walk/overview.png $work/cave-walk-overview.png
rm -rf $work/cave-static $work/cave-walk $work/cave-projectors $work/cave-wand $work/*.vlf
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar czf "$out/quality.tar.gz" .)
