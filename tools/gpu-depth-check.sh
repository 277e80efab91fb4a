#!/usr/bin/env bash
# The light field of a scene by path depth, and `vlf verify` of the whole, on the GPU machine:
#   bash tools/gpu-depth-check.sh VLF SCENE OUT [VLF_BEFORE]
# For every camera of SCENE (320x180): the light field after one iteration (direct light only:
# paths of depth 2, as Mitsuba's max_depth = 2), after two (depth 3), at default settings and
# by plain shooting to the tolerance (`--no-accelerate`: no geometric tail), rendered to
# OUT/<label>-{it1,it2,def,plain}-<camera>.exr, their propagation reports as JSON, and
# `vlf verify --spp 4096` of the default light field (OUT/<label>-verify.json).
# With VLF_BEFORE, the same with that binary under the label "before" (VLF's is "after").
# tools/mitsuba/depth-ratios.py compares the renders with Mitsuba's depth-limited references and
# says where the error sits (near edges or away from them, by material).
set -euo pipefail
vlf=$1 scene=$2 out=$3 before=${4:-}
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null || true
cameras=$(python3 -c "import tomllib,sys; print(' '.join(c['name'] for c in tomllib.load(open(sys.argv[1],'rb')).get('camera',[])))" "$scene")
run() {
  local bin=$1 label=$2 work
  work=$(mktemp -d)
  for kind in it1 it2 def plain; do
    case $kind in
      it1) flags=(--no-accelerate --max-iterations 1) ;;
      it2) flags=(--no-accelerate --max-iterations 2) ;;
      def) flags=() ;;
      plain) flags=(--no-accelerate --max-iterations 300) ;;
    esac
    "$bin" propagate "$scene" "${flags[@]}" -o "$work/$kind.vlf" --report "$out/$label-$kind-report.json" > /dev/null
    for c in $cameras; do
      "$bin" render "$scene" --lightfield "$work/$kind.vlf" --camera "$c" --size 320x180 -o "$out/$label-$kind-$c.exr" > /dev/null
    done
  done
  "$bin" verify "$scene" --lightfield "$work/def.vlf" --size 320x180 --spp 4096 --out "$work/verify" --json "$out/$label-verify.json" | grep -E "^  [a-z]" || true
  for c in $cameras; do cp "$work/verify/$c-reference.exr" "$out/reference-$c.exr"; done
  rm -rf "$work"
}
[ -z "$before" ] || run "$before" before
run "$vlf" after
