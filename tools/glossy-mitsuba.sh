#!/usr/bin/env bash
# The glossy Cornell box and the glossy-floor room against Mitsuba 3's own BSDFs (issue 29 item
# 4): vlf's 512x512 stills at default settings (made on a GPU by `PARTS=cornell
# tools/gpu-glossy.sh`, unpacked into STILLS: cornell-glossy-<camera>.exr, GGX alpha 0.1,
# cornell-glossy-0.3-<camera>.exr, glossy-floor-<camera>.exr) against Mitsuba 3 at 512x512 and SPP samples per pixel
# (default 4096; `roughconductor`, and `blendbsdf` of it and `diffuse` for the floor, rendered here on the CPU by tools/mitsuba/reference.py with the
# llvm_ad_rgb variant: `apt-get install libllvm19` on Debian 12), whole image and away from
# geometric edges (tools/mitsuba/edges.py, radius 2 px). Mitsuba's own noise is measured from
# its variance image (tools/mitsuba/compare.py). Writes into OUT: mitsuba-<name>-<camera>.exr
# (+ -var.exr), compare-<name>-<camera>.json, compare-<name>-<camera>-away-from-edges.json,
# diff-<name>-<camera>.png, noise-<name>-<camera>.json, edges-<name>-<camera>.png.
# VIEWS: scene:camera pairs (default every glossy box's front and side, the glossy floor's front
# and floor), the alpha 0.3 box as 0.3:<camera>.
#   tools/glossy-mitsuba.sh VLF_BINARY STILLS OUT
set -euo pipefail
vlf=$(realpath "$1"); stills=$(realpath "$2"); out=$(mkdir -p "$3" && realpath "$3")
spp=${SPP:-4096}
cd "$(dirname "$0")/.."
work=$(mktemp -d)
# the alpha 0.3 box: the shipped scene with its roughness changed (as tools/gpu-glossy.sh does)
mkdir -p "$work/cornell-glossy-0.3"
sed 's/^roughness = 0.1/roughness = 0.3/; s/^name = "cornell-glossy"/name = "cornell-glossy-0.3"/; s|^mesh = "../cornell|mesh = "'"$PWD"'/scenes/cornell|' \
  scenes/cornell-glossy/scene.toml > "$work/cornell-glossy-0.3/scene.toml"
box=scenes/cornell-glossy/scene.toml; rough="$work/cornell-glossy-0.3/scene.toml"
floor=scenes/glossy-floor/scene.toml
views=${VIEWS:-$box:front $rough:front $box:side $rough:side $floor:front $floor:floor}
views=${views//0.3:/$rough:}
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-$(ls /usr/lib/x86_64-linux-gnu/libLLVM-19.so 2>/dev/null || true)}
for spec in $views; do
  scene=${spec%%:*}; camera=${spec##*:}
  name=$(basename "$(dirname "$scene")")
  mask="$out/edges-$name-$camera.png"
  [ -f "$mask" ] || python3 tools/mitsuba/edges.py "$scene" --camera $camera --size 512x512 --radius 2 -o "$mask"
  still="$stills/$name-$camera.exr"
  [ -f "$still" ] || { echo "tools/glossy-mitsuba.sh: $still missing (PARTS=cornell tools/gpu-glossy.sh makes it)" >&2; exit 2; }
  ref="$out/mitsuba-$name-$camera.exr"
  if [ ! -f "$ref" ]; then
    python3 tools/mitsuba/reference.py "$scene" --camera $camera --size 512x512 --spp $spp \
      --variant llvm_ad_rgb -o "$ref" --variance "$out/mitsuba-$name-$camera-var.exr" --quiet
  fi
  "$vlf" compare "$still" "$ref" --json --diff "$out/diff-$name-$camera.png" > "$out/compare-$name-$camera.json"
  "$vlf" compare "$still" "$ref" --json --mask "$mask" > "$out/compare-$name-$camera-away-from-edges.json"
  # Mitsuba's own noise: the relMSE its variance alone gives (vlf's relMSE form)
  python3 - "$ref" "$out/mitsuba-$name-$camera-var.exr" > "$out/noise-$name-$camera.json" <<'PY'
import json, sys
import numpy as np
sys.path.insert(0, "tools/mitsuba")
from compare import read
ref, var = read(sys.argv[1]), read(sys.argv[2])
print(json.dumps({"reference_noise_rel_mse": float(np.mean(var / (ref * ref + 0.01)))}))
PY
  echo "$name $camera: $(grep -E '"(display_mse|rel_mse)"' "$out/compare-$name-$camera.json" | tr -d '\n ')  away from edges: $(grep -E '"display_mse"' "$out/compare-$name-$camera-away-from-edges.json" | tr -d '\n ')"
done
# with DOCS_IMAGES=dir: the difference images the accuracy guide shows, halved to 256x256 (2x2
# box), as glossy-mitsuba-diff-<box01|box03|floor>-<camera>.png
if [ -n "${DOCS_IMAGES:-}" ]; then
  python3 - "$out" "$DOCS_IMAGES" <<'PY'
import sys
from pathlib import Path
import numpy as np
import mitsuba as mi
mi.set_variant("scalar_rgb")
out, docs = Path(sys.argv[1]), Path(sys.argv[2])
for name, short in (("cornell-glossy", "box01"), ("cornell-glossy-0.3", "box03"), ("glossy-floor", "floor")):
    for diff in sorted(out.glob(f"diff-{name}-*.png")):
        camera = diff.stem[len(f"diff-{name}-"):]
        if "-" in camera:  # diff-cornell-glossy-0.3-* when looking for cornell-glossy
            continue
        a = np.array(mi.Bitmap(str(diff)), dtype=np.float64)[:, :, :3]
        h, w = a.shape[0] // 2 * 2, a.shape[1] // 2 * 2
        half = a[:h, :w].reshape(h // 2, 2, w // 2, 2, 3).mean(axis=(1, 3))
        image = np.clip(np.round(half), 0, 255).astype(np.uint8)
        target = docs / f"glossy-mitsuba-diff-{short}-{camera}.png"
        mi.Bitmap(image, pixel_format=mi.Bitmap.PixelFormat.RGB).write(str(target))
        print(target)
PY
fi
