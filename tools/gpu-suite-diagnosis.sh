#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: what the accuracy suite's misses on the Bitterli interiors
# come from (docs/guide/accuracy.md, "What the suite shows"). `vlf verify` at 320x180 against
# `vlf reference` (1024 spp) of: each model with every material made one-sided (two-sided
# surfaces out of the question), each at four times the texel density and twice the grid
# (discretisation), and the living room with direct light sent through the fixed directions.
#   tools/gpu-suite-diagnosis.sh VLF_BINARY OUT_DIR      (models/ from tools/get-models.sh)
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2")
cd "$(dirname "$0")/.."
for m in classroom living-room staircase; do
  d=models/$m-1s; mkdir -p "$d"
  sed "s|^mesh = \"model.gltf\"|mesh = \"../$m/model.gltf\"|" "models/$m/scene.toml" > "$d/scene.toml"
  python3 - "$m" >> "$d/scene.toml" <<'PY'
import json, re, sys
print()
for mat in json.load(open(f"models/{sys.argv[1]}/model.gltf"))["materials"]:
    n = mat["name"]
    print(f'[materials.{json.dumps(n) if re.search(r"[^A-Za-z0-9_-]", n) else n}]\ntwo_sided = false')
PY
done
v() { n=$1; shift; echo "=== $n $*"; "$vlf" verify "$@" --size 320x180 --spp 1024 --out "$out/$n" --json "$out/$n.json" 2>&1 | grep -v "XDG\|warning\|error maps\|targets:"; }
{
  v lr-1s models/living-room-1s/scene.toml
  v lr-fine models/living-room/scene.toml --texel-density 384 --grid 512
  v cls-1s models/classroom-1s/scene.toml
  v cls-fine models/classroom/scene.toml --texel-density 384 --grid 512
  v st-1s models/staircase-1s/scene.toml
  v st-fine models/staircase/scene.toml --texel-density 384 --grid 512
  v lr-nodirect models/living-room/scene.toml --direct-samples 0
} | tee "$out/diagnosis.txt"
rm -rf "$out"/*/
