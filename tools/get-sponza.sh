#!/usr/bin/env bash
# Fetch Sponza (glTF) from the Khronos glTF sample assets into models/sponza/, ready for
# tools/gpu-gltf.sh, on a machine with network (the GPU machine has none: carry models/ there).
#   bash tools/get-sponza.sh [OUT_DIR=models/sponza] [LIMIT_MIB=38]
# Source: https://github.com/KhronosGroup/glTF-Sample-Assets/tree/main/Models/Sponza/glTF
# Licence: the model's files are under the Cryengine Limited License Agreement
# (LicenseRef-CRYENGINE-Agreement, see Models/Sponza/LICENSE.md there): not committed here;
# models/ is git-ignored. If the images make the folder larger than LIMIT_MIB (the device
# tool's carry limit is 64 MiB with the source tree), they are halved until it fits (with
# Pillow, or ImageMagick's mogrify); vlf resolves textures to texel density anyway.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-models/sponza}
limit=${2:-38}
base=https://raw.githubusercontent.com/KhronosGroup/glTF-Sample-Assets/main/Models/Sponza
mkdir -p "$out"
curl -fsSL "$base/glTF/Sponza.gltf" -o "$out/Sponza.gltf"
curl -fsSL "$base/LICENSE.md" -o "$out/LICENSE.md"
python3 - "$out/Sponza.gltf" > "$out/.files" <<'PY'
import json, sys
g = json.load(open(sys.argv[1]))
for b in g.get("buffers", []):
    print(b["uri"])
for i in g.get("images", []):
    print(i["uri"])
PY
while read -r f; do
  [ -s "$out/$f" ] || curl -fsSL "$base/glTF/$f" -o "$out/$f"
done < "$out/.files"
rm -f "$out/.files"
cp tools/sponza/scene.toml "$out/scene.toml"
size_mib() { du -sm "$1" | cut -f1; }
while [ "$(size_mib "$out")" -gt "$limit" ]; do
  echo "get-sponza.sh: $(size_mib "$out") MiB > $limit MiB: halving the images" >&2
  if python3 -c 'import PIL' 2>/dev/null; then
    python3 - "$out" <<'PY'
import glob, os, sys
from PIL import Image
for p in glob.glob(os.path.join(sys.argv[1], "*.jpg")) + glob.glob(os.path.join(sys.argv[1], "*.png")):
    im = Image.open(p)
    im = im.resize((max(1, im.width // 2), max(1, im.height // 2)), Image.LANCZOS)
    im.save(p, quality=90) if p.endswith(".jpg") else im.save(p, optimize=True)
PY
  else
    mogrify -resize 50% "$out"/*.jpg "$out"/*.png
  fi
  echo reduced > "$out/REDUCED"
done
echo "$out: $(size_mib "$out") MiB ($(ls "$out" | wc -l) files)"
