#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: is the behaviour of build NEW the same as build OLD's? The
# light fields (.vlf) of Cornell, Cornell-mirror, the textured room and a generated 10K-triangle
# classroom, byte for byte (and OLD twice on Cornell: propagation is deterministic); the
# generator's files; and `vlf bench --suite` of both, taking turns ROUNDS times (default 3) so
# that drifts of the machine fall on both (tools/suite-compare.py compares the medians against the
# spread of one build's own runs); and the drawing: the shipped 4-wall CAVE (8 views of 1920x1200)
# walking the 100K mirror classroom and the mirror gallery at a fixed 4 eye rays per pixel
# (fit_frame_time off), FRAMES frames (default 600) per run, the builds taking turns ROUNDS times
# (tools/suite-compare.py lists the views' GPU time per frame beside the suite).
#   tools/gpu-identity.sh OLD_VLF NEW_VLF OUT_DIR [ROUNDS] [FRAMES]
set -uo pipefail
old=$1; new=$2; out=$3; rounds=${4:-3}; frames=${5:-600}; work=$(mktemp -d)
quiet() { grep -v XDG_RUNTIME_DIR; }
{
  "$old" generate classroom --size 10000 -o $work/gen-old >/dev/null 2>&1
  "$new" generate classroom --size 10000 -o $work/classroom-10k >/dev/null 2>&1
  if diff -r $work/gen-old $work/classroom-10k >/dev/null; then echo "generate classroom --size 10000: same files"; else echo "generate classroom --size 10000: FILES DIFFER"; fi
  for scene in scenes/cornell/scene.toml scenes/cornell-mirror/scene.toml scenes/textured-room/scene.toml $work/classroom-10k/scene.toml; do
    name=$(basename "$(dirname "$scene")")
    "$old" propagate "$scene" -o $work/$name-old.vlf 2>&1 | quiet > /dev/null
    "$new" propagate "$scene" -o $work/$name-new.vlf 2>&1 | quiet > /dev/null
    a=$(sha256sum < $work/$name-old.vlf | cut -c1-16); b=$(sha256sum < $work/$name-new.vlf | cut -c1-16)
    echo "$name: old $a new $b $( [ "$a" = "$b" ] && echo identical || echo DIFFERENT ) ($(stat -c %s $work/$name-new.vlf) bytes)"
  done
  "$old" propagate scenes/cornell/scene.toml -o $work/again.vlf 2>&1 | quiet > /dev/null
  cmp -s $work/again.vlf $work/cornell-old.vlf && echo "cornell, old build twice: identical" || echo "cornell, old build twice: DIFFERENT"
} | tee "$out/identity.txt"
# suites: a first run pays the driver's shader compilation; then the builds take turns
"$old" bench --suite --json $work/suite-cold.json 2>&1 | quiet | tail -1
for r in $(seq 1 "$rounds"); do
  "$old" bench --suite --json "$out/suite-old-$r.json" 2>&1 | quiet | tail -1
  "$new" bench --suite --json "$out/suite-new-$r.json" 2>&1 | quiet | tail -1
done
# the walks, drawn by both builds from the same light field (propagated by OLD)
source tools/walk-scenes.sh
for scene in classroom-100k gallery; do
  "$old" generate $(generate "$scene") -o "$work/$scene" 2>&1 | quiet > /dev/null
  "$old" propagate "$work/$scene/scene.toml" -o "$work/$scene.vlf" 2>&1 | quiet > /dev/null
  config="$work/cave-$scene.toml"
  sed "s|^path = .*|path = \"$(walk_path $scene)\"|" config/displays/cave-4wall-walk.toml > "$config"
  sed -i 's/^fit_frame_time = true/fit_frame_time = false/' "$config"
  for r in $(seq 1 "$rounds"); do
    for build in old new; do
      vlf=$old; [ $build = new ] && vlf=$new
      "$vlf" cave "$config" --scene "$work/$scene.vlf" --headless --frames "$frames" \
        --out "$work/walk" --json "$out/walk-$build-$scene-$r.json" 2>&1 | quiet | grep -E "all views, GPU" | head -1
    done
  done
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt"
