#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the accuracy suite's views (tools/accuracy-suite.py list) with
# two builds against one reference, to show what a change did on models made by other people.
#   tools/gpu-suite-before-after.sh OUT VLF_AFTER VLF_BEFORE [NAME...]
# After: `vlf verify` at default settings (the light field against `vlf reference` at SPP, which
# agrees with Mitsuba 3 within 0.2% on every suite view): OUT/<name>/after.json and after.txt.
# Before: the other build's light field of the same views (its own propagation at default
# settings, `vlf verify --spp 1`, whose reference is thrown away), compared by `vlf compare`
# with the after run's reference images: OUT/<name>/before-<camera>.json. Both light fields
# are rendered as `vlf verify` renders them (16 eye rays per pixel).
# SPP (default 4096), SIZE (default
# 640x360) and VLF_COMMIT (the after build's commit) from the environment.
set -uo pipefail
out=$(mkdir -p "$1" && realpath "$1"); after=$(realpath "$2"); before=$(realpath "$3"); shift 3
spp=${SPP:-4096}; size=${SIZE:-640x360}
cd "$(dirname "$0")/.."
(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1) > "$out/gpu.txt"
echo "${VLF_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null)}" > "$out/commit.txt"
echo "$spp $size" > "$out/settings.txt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 tools/accuracy-suite.py list "$@" > "$out/views.txt"
cut -d' ' -f1,2 "$out/views.txt" | sort -u | while read -r name scene; do
  mkdir -p "$out/$name"
  cams=$(awk -v n="$name" '$1 == n { printf " --camera %s", $3 }' "$out/views.txt")
  echo "== $name: after ($cams)"
  # shellcheck disable=SC2086
  "$after" verify "$scene" $cams --size "$size" --spp "$spp" --out "$work/after-$name" \
    --json "$out/$name/after.json" 2>&1 | grep -v XDG > "$out/$name/after.txt"
  grep -E "propagated|^  [a-z]+ +[0-9]+x" "$out/$name/after.txt"
  echo "== $name: before"
  # shellcheck disable=SC2086
  "$before" verify "$scene" $cams --size "$size" --spp 1 --out "$work/before-$name" \
    2>&1 | grep -v XDG > "$out/$name/before.txt"
  for cam in $(awk -v n="$name" '$1 == n { print $3 }' "$out/views.txt"); do
    "$after" compare "$work/before-$name/$cam-lightfield.exr" \
      "$work/after-$name/$cam-reference.exr" --json > "$out/$name/before-$cam.json"
    python3 - "$out/$name/before-$cam.json" "$cam" <<'EOF'
import json, sys
c = json.load(open(sys.argv[1]))
print(f"  before {sys.argv[2]}: mean {c['mean_ratio']:.4f} display MSE {c['display_mse']:.2e} relMSE {c['rel_mse']:.2e}")
EOF
  done
done
