#!/usr/bin/env bash
# Runs on the lent NVIDIA machine after a change to light transport: what the change did to every
# figure it can move, with one build, in one call.
#   - OUT/pictures: the documents' GPU pictures (tools/pictures.sh; stamp them here afterwards
#     with `python3 tools/pictures.py stamp OUT/pictures`);
#   - OUT/suite: the accuracy suite's light-field half (tools/gpu-accuracy-suite.sh lightfield:
#     `vlf verify` at default settings against `vlf reference` at 4096 spp, every view whose
#     model is here: models/ unpacked from MODELS_TAR if given);
#   - OUT/balance/<model>.json: `vlf propagate --report` of each suite model (the power balance);
#   - OUT/cornell/<scene>.json|txt: Cornell and Cornell-mirror at default settings against a
#     16384-spp `vlf reference` at 256x256 (the guide's accuracy figures, tools/gpu-accuracy.sh).
# Packed into OUT/transport.tar (images other than EXR: the device tool brings back 16 MiB a
# file), also when the run is cut short (SIGTERM: what is done so far).
# PARTS (default "suite balance cornell pictures") picks and orders the parts.
#   tools/gpu-transport-check.sh VLF_BINARY OUT
set -uo pipefail
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2")
cd "$(dirname "$0")/.."
work=$(mktemp -d)
pack() { (cd "$work" && tar cf "$out/transport.tar" --exclude="*.exr" --ignore-failed-read gpu.txt commit.txt cornell balance suite pictures 2>/dev/null); }
trap 'pack; exit 1' TERM
trap pack EXIT
quiet() { grep -v XDG_RUNTIME_DIR; }
[ -n "${MODELS_TAR:-}" ] && tar xJf "$MODELS_TAR"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$work/gpu.txt" 2>/dev/null
echo "${VLF_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null)}" > "$work/commit.txt"
mkdir -p "$work/cornell" "$work/balance"
cornell() {
  for scene in cornell cornell-mirror; do
    "$vlf" reference scenes/$scene/scene.toml --size 256x256 --spp 16384 --seed 1 -o "$work/ref-$scene.exr" 2>&1 | quiet | tail -1
    "$vlf" render scenes/$scene/scene.toml --size 256x256 -o "$work/default-$scene.exr" 2>&1 | quiet | tail -1
    "$vlf" compare "$work/default-$scene.exr" "$work/ref-$scene.exr" --json > "$work/cornell/$scene.json"
    "$vlf" compare "$work/default-$scene.exr" "$work/ref-$scene.exr" | tee "$work/cornell/$scene.txt"
  done
}
balance() {
  python3 tools/accuracy-suite.py list 2>/dev/null | cut -d' ' -f1,2 | sort -u | while read -r name scene; do
    "$vlf" propagate "$scene" -o "$work/$name.vlf" --report "$work/balance/$name.json" 2>&1 | quiet \
      | grep -iE "balance|propagation  " | sed "s/^/$name: /"
    rm -f "$work/$name.vlf"
  done
}
suite() {
  bash tools/gpu-accuracy-suite.sh lightfield "$work/suite" "$vlf" 2>&1 | grep -E "^==|^  [a-z]+ +[0-9]+x"
}
pictures() {
  bash tools/pictures.sh "$vlf" "$work/pictures" 2>&1 | grep -E "^==|rror" | tail -20
}
for part in ${PARTS:-suite balance cornell pictures}; do
  echo "=== $part"
  $part
done
