#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the renders of the accuracy suite on models made by other
# people (tools/accuracy-suite.py says which and why), in two halves that need different
# software (and together exceed what one call to that machine may carry):
#   tools/gpu-accuracy-suite.sh references OUT [NAME...]
#       Mitsuba 3 at SPP on the GPU (cuda_ad_rgb; llvm_ad_rgb without CUDA), the edge mask and
#       the material each pixel sees (tools/mitsuba/edges.py): OUT/<model>-<camera>.npz
#       (tools/accuracy-suite.py pack). Needs Python with numpy and Mitsuba 3.
#   tools/gpu-accuracy-suite.sh lightfield OUT VLF_BINARY [NAME...]
#       `vlf verify` at default settings: the light field's image (16 eye rays per pixel) and
#       vlf's own path tracer at SPP, OUT/<model>/<camera>-lightfield.exr and verify.json.
# Then, anywhere: python3 tools/accuracy-suite.py measure REFERENCES LIGHTFIELD.
# SPP (default 4096), SIZE (default 640x360) and VLF_COMMIT (the build's commit) from the
# environment.
set -uo pipefail
mode=$1; out=$(mkdir -p "$2" && realpath "$2"); shift 2
spp=${SPP:-4096}; size=${SIZE:-640x360}
cd "$(dirname "$0")/.."
(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1) > "$out/gpu.txt"
# the build measured: VLF_COMMIT when given (the device's copy of the tree may carry an older
# .git than the build), else the checkout's HEAD
echo "${VLF_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null)}" > "$out/commit.txt"
echo "$spp $size" > "$out/settings.txt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
case "$mode" in
  references)
    variant=${MITSUBA_VARIANT:-cuda_ad_rgb}
    python3 -c "import mitsuba as mi; mi.set_variant('$variant')" 2>/dev/null || variant=llvm_ad_rgb
    echo "$variant" > "$out/variant.txt"
    python3 tools/accuracy-suite.py list "$@" > "$out/views.txt"
    while read -r name scene cam; do
      path=$scene; tag=$name-$cam
      echo "== $tag: Mitsuba ($variant, $spp spp, $size)"
      start=$SECONDS
      python3 tools/mitsuba/reference.py "$path" --camera "$cam" --size "$size" --spp "$spp" \
        --variant "$variant" -o "$work/$tag.exr" --variance "$work/$tag-var.exr" \
        > "$out/$tag-mitsuba.txt" 2>&1 || { tail -5 "$out/$tag-mitsuba.txt"; continue; }
      python3 tools/mitsuba/edges.py "$path" --camera "$cam" --size "$size" --variant "$variant" \
        -o "$work/$tag-edges.png" --surfaces "$work/$tag-surfaces.json" \
        > "$out/$tag-edges.txt" 2>&1 || { tail -5 "$out/$tag-edges.txt"; continue; }
      python3 tools/accuracy-suite.py pack "$work/$tag" "$out/$tag.npz" --seconds $((SECONDS - start))
    done < "$out/views.txt"
    ;;
  lightfield)
    vlf=$(realpath "$1"); shift
    python3 tools/accuracy-suite.py list "$@" > "$out/views.txt"
    cut -d' ' -f1,2 "$out/views.txt" | sort -u | while read -r name scene; do
      path=$scene; mkdir -p "$out/$name"
      cams=$(awk -v n="$name" '$1 == n { printf " --camera %s", $3 }' "$out/views.txt")
      echo "== $name: vlf verify ($cams)"
      # shellcheck disable=SC2086
      "$vlf" verify "$path" $cams --size "$size" --spp "$spp" --out "$work/$name" \
        --json "$out/$name/verify.json" 2>&1 | grep -v XDG | tee "$out/$name/verify.txt"
      cp "$work/$name"/*-lightfield.exr "$out/$name/" 2>/dev/null
    done
    ;;
  *) echo "usage: $0 references|lightfield OUT ..." >&2; exit 2 ;;
esac
