#!/usr/bin/env bash
# Fetch the third-party interiors of the accuracy suite into models/<name>/ (git-ignored; never
# committed), on a machine with network, or from a fetched git mirror of their repository.
#   bash tools/get-models.sh [NAME...] [--from-mirror GIT_DIR]
# NAME: classroom, living-room, dining-room, staircase (default: all four), or living-room-real
# (the living room with its real materials: cut-out leaves, mirrors, glossy steel and wood; its
# `source` file names the scene it is converted from). Each comes from
# Benedikt Bitterli's rendering resources (https://benedikt-bitterli.me/resources/, Mitsuba 0.6
# versions, CC-BY 3.0: see tools/models/<name>/scene.toml for author and credit), as kept in
# github.com/hchoi405/dppm-scenes at the pinned commit below, whose files are each under 4 MiB:
#   - the source files listed in tools/models/<name>/SHA256SUMS (scene.xml, LICENSE.txt, the
#     OBJ meshes and PNG/JPEG textures it names) are downloaded and checked against it;
#   - tools/models/mitsuba2gltf.py (standard library only) converts them into
#     models/<name>/model.gltf + model.bin + textures/, with tools/models/<name>/convert.args;
#     the result is checked against tools/models/<name>/MODEL.sha256;
#   - tools/models/<name>/scene.toml (sky, cameras) and LICENSE.txt + SOURCE.txt go beside it.
# --from-mirror GIT_DIR takes the files from a bare git copy of hchoi405/dppm-scenes that holds
# the pinned commit (how this project's machines get them) instead of curl.
# Sponza is separate: tools/get-sponza.sh (curl from KhronosGroup/glTF-Sample-Assets; its
# Sponza.bin is 9.6 MiB, so it cannot come through a mirror that leaves out files of 4 MiB+).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=hchoi405/dppm-scenes
commit=8fdb2dcb3fe575bb04bc586fded35e81d76787d5
base=https://raw.githubusercontent.com/$repo/$commit/scenes
mirror=""
names=()
while [ $# -gt 0 ]; do
  case "$1" in
    --from-mirror) mirror=$2; shift 2 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) names+=("$1"); shift ;;
  esac
done
[ ${#names[@]} -gt 0 ] || names=(classroom living-room dining-room staircase)
for name in "${names[@]}"; do
  meta=tools/models/$name
  [ -f "$meta/SHA256SUMS" ] || { echo "get-models.sh: unknown model $name" >&2; exit 1; }
  scene=$name
  [ -f "$meta/source" ] && scene=$(cat "$meta/source")
  src=$(mktemp -d)
  trap 'rm -rf "$src"' EXIT
  echo "get-models.sh: $name: $(wc -l < "$meta/SHA256SUMS") source files" >&2
  while IFS= read -r line; do
    f=${line#*  }
    mkdir -p "$src/$(dirname "$f")"
    if [ -n "$mirror" ]; then
      git --git-dir="$mirror" show "$commit:scenes/$scene/$f" > "$src/$f"
    else
      curl -fsSL "$base/$scene/${f// /%20}" -o "$src/$f"
    fi
  done < "$meta/SHA256SUMS"
  (cd "$src" && sha256sum --quiet -c -) < "$meta/SHA256SUMS"
  out=models/$name
  rm -rf "$out"
  # shellcheck disable=SC2046
  python3 tools/models/mitsuba2gltf.py "$src/scene.xml" "$out" $(cat "$meta/convert.args") > /dev/null
  (cd "$out" && sha256sum --quiet -c -) < "$meta/MODEL.sha256"
  cp "$meta/scene.toml" "$out/scene.toml"
  if [ -f "$src/LICENSE.txt" ]; then
    cp "$src/LICENSE.txt" "$out/LICENSE.txt"
  else
    sed -n '1,/^name = /p' "$meta/scene.toml" | grep '^#' | sed 's/^# \{0,1\}//' > "$out/LICENSE.txt"
  fi
  printf 'Source: https://github.com/%s/tree/%s/scenes/%s\nConverted by tools/models/mitsuba2gltf.py %s\n' \
    "$repo" "$commit" "$scene" "$(cat "$meta/convert.args")" > "$out/SOURCE.txt"
  rm -rf "$src"
  trap - EXIT
  echo "$out: $(du -sm "$out" | cut -f1) MiB" >&2
done
