#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: glossy surfaces (issue 29): what they cost and how they look.
#   - Cornell with the tall box a rough metal (scenes/cornell-glossy: GGX alpha 0.1, and the
#     same at alpha 0.3), and the room with a glossy floor (scenes/glossy-floor: alpha 0.05,
#     cameras front and floor): `vlf propagate` (its report: iterations, time to converge) and a
#     512x512 still of each camera at default settings against `vlf reference` at 8192 spp of
#     the same (`vlf compare`: JSON and the FLIP difference image; vlf reference agrees with
#     Mitsuba's roughconductor through this box, tests/mitsuba.rs, and Mitsuba itself runs on
#     the CPU only);
#   - the shipped walk CAVE (config/displays/cave-4wall-walk.toml: 8 views of 1920x1200, 120 Hz,
#     paced) through the generated 100K mirror classroom with glossy floors and metal
#     (`vlf generate classroom --size 100000 --mirrors --glossy`) against the same classroom
#     without them, 600 frames each: frame time and eye rays per pixel, what glossy costs;
#   - `vlf bench` of both classrooms' first camera at 1024x768 (GPU ms per view);
#   - (PARTS=metal-floor) scenes/metal-floor (glTF metallicRoughness textures, split per texel):
#     the same stills against vlf reference (cameras front and low), and a bench at 1024x768;
#   - (PARTS=hallway) the shipped Space Ship Hallway with its own mirror floors (no diffuse
#     override): propagation (report), both cameras at 1024x768, `vlf bench` of a view;
#   - (PARTS=living-room) the same for Bitterli's living room with its real materials
#     (models/living-room-real, `bash tools/get-models.sh living-room-real`: cut-out leaves,
#     mirrors, glossy steel and wood); (PARTS=living-room-settings) it propagated at each of
#     SETTINGS, both views at 640x360 as EXR, for tools/mitsuba/ratio-map.py.
# Everything into OUT/glossy.tar (reports, JSON, difference images), the front camera's EXRs
# (and the side camera's stills) into OUT/glossy-exr.tar.
#   tools/gpu-glossy.sh VLF_BINARY OUT [FRAMES]
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2"); frames=${3:-600}
cd "$(dirname "$0")/.."
work=$(mktemp -d)
quiet() { grep -v XDG_RUNTIME_DIR; }
pack() {
  (cd "$work" && tar cf "$out/glossy.tar" --ignore-failed-read gpu.txt commit.txt *.txt *.json *.png $(ls -d verify-* 2>/dev/null) 2>/dev/null)
  # the front camera's stills and references, for comparisons away from edges elsewhere
  # (and the side camera's stills: tools/glossy-mitsuba.sh compares every still with Mitsuba)
  (cd "$work" && ls *-front.exr *-front-reference.exr >/dev/null 2>&1 \
    && tar cf "$out/glossy-exr.tar" *-front.exr *-front-reference.exr $(ls *-side.exr *-low.exr 2>/dev/null))
}
trap 'pack; exit 1' TERM
trap pack EXIT
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$work/gpu.txt" 2>/dev/null
echo "${VLF_COMMIT:-unknown}" > "$work/commit.txt"
cornell() {
  mkdir -p "$work/cornell-glossy-0.3"
  sed 's/^roughness = 0.1/roughness = 0.3/; s/^name = "cornell-glossy"/name = "cornell-glossy-0.3"/; s|^mesh = "../cornell|mesh = "'"$PWD"'/scenes/cornell|' \
    scenes/cornell-glossy/scene.toml > "$work/cornell-glossy-0.3/scene.toml"
  for scene in scenes/cornell-glossy/scene.toml "$work/cornell-glossy-0.3/scene.toml" scenes/glossy-floor/scene.toml; do
    name=$(basename "$(dirname "$scene")")
    cameras="front side"; [ $name = glossy-floor ] && cameras="front floor"
    stills $name "$scene" "$cameras"
  done
}
stills() { # NAME SCENE_TOML CAMERAS: propagation (report), each camera's 512x512 still against vlf reference
  local name=$1 scene=$2 cameras=$3
  "$vlf" propagate "$scene" -o "$work/$name.vlf" --report "$work/propagate-$name.json" 2>&1 | quiet \
    | tee "$work/propagate-$name.txt" | grep -E "iterations|propagation|converged"
  for camera in $cameras; do
    "$vlf" render "$scene" --lightfield "$work/$name.vlf" --camera $camera -o "$work/$name-$camera.exr" 2>&1 | quiet | tail -1
    "$vlf" reference "$scene" --camera $camera --spp 8192 -o "$work/$name-$camera-reference.exr" 2>&1 | quiet | tail -1
    "$vlf" compare "$work/$name-$camera.exr" "$work/$name-$camera-reference.exr" --json \
      --diff "$work/diff-$name-$camera.png" > "$work/compare-$name-$camera.json"
    grep -E '"(display_mse|rel_mse)"' "$work/compare-$name-$camera.json" | tr -d '\n '; echo " $name $camera"
  done
}
metal-floor() {
  # glTF metallicRoughness textures split per texel (scenes/metal-floor): its stills against
  # vlf reference, and a bench of its first camera at 1024x768
  stills metal-floor scenes/metal-floor/scene.toml "front low"
  timeout ${STEP_LIMIT:-240} "$vlf" bench --scene scenes/metal-floor/scene.toml --frames 300 --size 1024x768 \
    --json "$work/bench-metal-floor.json" 2>&1 | quiet | tee "$work/bench-metal-floor.txt" | grep -iE "render" | head -2
}
cave() {
  for variant in plain glossy; do
    flag=""; [ $variant = glossy ] && flag="--glossy"
    "$vlf" generate classroom --size 100000 --mirrors $flag -o "$work/classroom-$variant" | quiet | tail -1
    # a step that runs past STEP_LIMIT seconds (default 240) is stopped and said so
    if ! timeout ${STEP_LIMIT:-240} "$vlf" propagate "$work/classroom-$variant/scene.toml" -o "$work/classroom-$variant.vlf" \
        --report "$work/propagate-classroom-$variant.json" > "$work/propagate-classroom-$variant.txt" 2>&1; then
      echo "classroom-$variant: propagation stopped or failed after ${STEP_LIMIT:-240} s" | tee -a "$work/propagate-classroom-$variant.txt"
      continue
    fi
    grep -E "iterations|propagation  |GPU memory" "$work/propagate-classroom-$variant.txt"
    sed "s|^path = .*|path = \"$PWD/config/paths/classroom-100k-walk.toml\"|" config/displays/cave-4wall-walk.toml > "$work/cave.toml"
    "$vlf" cave "$work/cave.toml" --scene "$work/classroom-$variant.vlf" --headless --frames $frames \
      --out "$work/out-$variant" --json "$work/cave-classroom-$variant.json" 2>&1 | quiet \
      | tee "$work/cave-classroom-$variant.txt" | grep -E "all views|CPU frame|eye rays|limit"
    cp "$work/out-$variant/overview.png" "$work/cave-classroom-$variant-overview.png"
    timeout ${STEP_LIMIT:-240} "$vlf" bench --scene "$work/classroom-$variant/scene.toml" \
      --frames 300 --size 1024x768 --json "$work/bench-classroom-$variant.json" 2>&1 | quiet \
      | tee "$work/bench-classroom-$variant.txt" | grep -iE "render|view" | head -3
  done
}
hallway() {
  # the shipped Space Ship Hallway with its own floors: metallic, roughness 0 in the glTF, so
  # ideal mirrors (scenes/space-ship-hallway/scene.toml overrides them to diffuse); the glass and
  # the base-colour-less walls keep the shipped fixes
  mkdir -p "$work/hallway-real"
  awk '/^\[materials.Floor_and_vent\]/{skip=1} /^\[materials.Glass\]/{skip=0} !skip' \
    scenes/space-ship-hallway/scene.toml \
    | sed 's|^mesh = "space_ship_hallway.glb"|mesh = "'"$PWD"'/scenes/space-ship-hallway/space_ship_hallway.glb"|; s|^name = "space-ship-hallway"|name = "space-ship-hallway-real"|' \
    > "$work/hallway-real/scene.toml"
  cp "$work/hallway-real/scene.toml" "$work/hallway-real-scene.txt"
  real_scene hallway-real "$work/hallway-real/scene.toml" "hallway corner"
}
living-room() {
  # the living room with its real materials (issue 29 item 5: cut-out leaves, mirrors, glossy
  # steel and wood); models/ is not in the repository: bash tools/get-models.sh living-room-real
  [ -f models/living-room-real/scene.toml ] || { echo "living-room: no models/living-room-real (bash tools/get-models.sh living-room-real)"; return; }
  real_scene living-room-real models/living-room-real/scene.toml "room corner"
  # and how right it is: every camera against vlf's path tracer (which takes the cut-outs and
  # the glossy lobes as the light field does; Mitsuba's reference.py reads alpha as opaque)
  [ -f "$work/living-room-real.vlf" ] && timeout ${STEP_LIMIT:-240} "$vlf" verify models/living-room-real/scene.toml \
    --lightfield "$work/living-room-real.vlf" --size 640x360 --spp 2048 --out "$work/verify-living-room-real" \
    --json "$work/verify-living-room-real.json" 2>&1 | quiet | tee "$work/verify-living-room-real.txt" | tail -4
}
living-room-settings() {
  # which setting moves the living room's excess (issue 26): each of SETTINGS ("name:flags,...")
  # propagated, both cameras rendered at 640x360 into verify-settings/NAME-CAMERA.exr, to set
  # against a Mitsuba reference with tools/mitsuba/ratio-map.py
  # (MODEL=living-room: the matte room instead; REFERENCE_SPP=N: `vlf reference` of both views too)
  local model=models/${MODEL:-living-room-real}/scene.toml
  [ -f "$model" ] || { echo "living-room-settings: no $model (bash tools/get-models.sh)"; return; }
  mkdir -p "$work/verify-settings"
  if [ -n "${REFERENCE_SPP:-}" ]; then
    for camera in room corner; do
      "$vlf" reference "$model" --camera $camera --size 640x360 --spp "$REFERENCE_SPP" \
        -o "$work/verify-settings/reference-$camera.exr" 2>&1 | quiet | tail -1
    done
  fi
  local IFS=','
  for setting in ${SETTINGS:-default:,grid512:--grid 512,directions8001:--directions 8001,density192:--texel-density 192}; do
    local name=${setting%%:*} flags=${setting#*:}
    IFS=' ' read -r -a args <<< "$flags"
    timeout ${STEP_LIMIT:-240} "$vlf" propagate "$model" "${args[@]}" -o "$work/s.vlf" \
      --report "$work/verify-settings/propagate-$name.json" > "$work/verify-settings/propagate-$name.txt" 2>&1 \
      || { echo "$name: propagation failed or stopped"; tail -2 "$work/verify-settings/propagate-$name.txt"; continue; }
    for camera in room corner; do
      "$vlf" render "$work/s.vlf" --camera $camera --size 640x360 -o "$work/verify-settings/$name-$camera.exr" 2>&1 | quiet | tail -1
    done
    grep -E "propagation  |GPU memory, propagating" "$work/verify-settings/propagate-$name.txt" | tr -s ' ' | sed "s/^/$name:/"
  done
}
real_scene() { # NAME SCENE_TOML CAMERAS: propagation (report), each camera at 1024x768, a bench
  local name=$1 scene=$2 cameras=$3
  if ! timeout ${STEP_LIMIT:-240} "$vlf" propagate "$scene" -o "$work/$name.vlf" \
      --report "$work/propagate-$name.json" > "$work/propagate-$name.txt" 2>&1; then
    echo "$name: propagation stopped or failed after ${STEP_LIMIT:-240} s" | tee -a "$work/propagate-$name.txt"
    tail -3 "$work/propagate-$name.txt"
    return
  fi
  grep -E "non-diffuse|setup  |propagation  |GPU memory" "$work/propagate-$name.txt"
  for camera in $cameras; do
    "$vlf" render "$work/$name.vlf" --camera $camera --size 1024x768 -o "$work/$name-$camera.png" 2>&1 | quiet | tail -1
  done
  timeout ${STEP_LIMIT:-240} "$vlf" bench --scene "$scene" --frames 300 --size 1024x768 \
    --json "$work/bench-$name.json" 2>&1 | quiet | tee "$work/bench-$name.txt" | grep -iE "render" | head -2
}
for part in ${PARTS:-cornell cave}; do
  echo "=== $part"
  "$part"
done
