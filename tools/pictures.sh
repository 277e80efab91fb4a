#!/usr/bin/env bash
# Makes the documents' pictures with the build at hand, each by the command docs/images/pictures.toml
# names for it, and stamps the manifest with the commit, the adapter and the inputs' hash
# (tools/pictures.py; tests/docs.rs fails when a picture's inputs changed since it was made).
#   bash tools/pictures.sh VLF_BINARY OUT_DIR [NAME ...]
# NAMEs are the manifest's entries (default: every entry whose `made_by` is this script and
# whose machine this is: `gpu` entries need a real GPU, `software` ones any adapter). Writes
# OUT_DIR/<image file> and OUT_DIR/pictures-stamp.json; `python3 tools/pictures.py stamp
# OUT_DIR` then copies the pictures into docs/images and updates the manifest.
# On the lent GPU machine (whose copy of the tree has a stale .git) set VLF_COMMIT to the commit
# the build was made from: the stamp records it.
set -euo pipefail
cd "$(dirname "$0")/.."
vlf=$(realpath "$1"); out=$(mkdir -p "$2" && realpath "$2"); shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
names=("$@")
if [ ${#names[@]} = 0 ]; then
  mapfile -t names < <(python3 tools/pictures.py names --machine "${PICTURES_MACHINE:-gpu}")
fi
lf() { # scene -> its light field at default settings, propagated once per run
  local key; key=$(echo "$1" | tr '/.' '__')
  [ -f "$work/$key.vlf" ] || "$vlf" propagate "$1" -o "$work/$key.vlf" --report "$work/$key.json" >&2
  echo "$work/$key.vlf"
}
for name in "${names[@]}"; do
  echo "== $name" >&2
  case "$name" in
    cornell)
      "$vlf" render "$(lf scenes/cornell/scene.toml)" -o "$out/cornell.png" ;;
    cornell-mirror-front | cornell-mirror-side)
      "$vlf" render "$(lf scenes/cornell-mirror/scene.toml)" --camera "${name#cornell-mirror-}" -o "$out/$name.png" ;;
    cornell-glossy-front | cornell-glossy-side)
      "$vlf" render "$(lf scenes/cornell-glossy/scene.toml)" --camera "${name#cornell-glossy-}" -o "$out/$name.png" ;;
    metal-floor-front | metal-floor-low)
      "$vlf" render "$(lf scenes/metal-floor/scene.toml)" --camera "${name#metal-floor-}" -o "$out/$name.png" ;;
    textured-room-front)
      "$vlf" render "$(lf scenes/textured-room/scene.toml)" --camera front -o "$out/$name.png" ;;
    textured-room-up)
      "$vlf" render "$(lf scenes/textured-room/scene.toml)" --camera up --exposure 0.15 -o "$out/$name.png" ;;
    gltf-hallway | gltf-hallway-corner)
      camera=hallway
      [ "$name" = gltf-hallway-corner ] && camera=corner
      "$vlf" render "$(lf scenes/space-ship-hallway/scene.toml)" --camera $camera -o "$out/$name.png" ;;
    cave-wand-ray)
      sed 's/pixels = \[1920, 1200\]/pixels = [640, 400]/' config/displays/cave-4wall-wand.toml > "$work/wand.toml"
      "$vlf" cave "$work/wand.toml" --scene "$(lf scenes/cornell/scene.toml)" --headless --frames 2 \
        --out "$work/wand" >&2
      cp "$work/wand/front-left.png" "$out/cave-wand-ray.png" ;;
    cave-body-mirror | cave-body-floor)
      # the participant's body (config/displays/cave-4wall-body.toml) in the mirror Cornell box:
      # the front wall shows it in the tall box's mirror, the floor its own body and shadow
      sed 's/pixels = \[1920, 1200\]/pixels = [960, 600]/' config/displays/cave-4wall-body.toml \
        | sed "s|^mesh = \"../../assets|mesh = \"$PWD/assets|" > "$work/body.toml"
      [ -d "$work/body" ] || "$vlf" cave "$work/body.toml" --scene "$(lf scenes/cornell-mirror/scene.toml)" --headless \
        --frames 2 --out "$work/body" >&2
      wall=front; [ "$name" = cave-body-floor ] && wall=floor
      cp "$work/body/$wall-left.png" "$out/$name.png" ;;
    cave-xvfb)
      # the windowed CAVE test's own screenshot (Xvfb, two windows, tracking gone quiet)
      VLF_MAKING_PICTURES=1 cargo test --release --features mpi --test all -- --exact \
        windows::windowed_cave_draws_two_windows_under_xvfb_and_says_when_tracking_goes_quiet >&2
      cp target/tmp/cave-xvfb.png "$out/cave-xvfb.png" ;;
    *)
      echo "tools/pictures.sh: no command here for '$name'; docs/images/pictures.toml says what makes it" >&2
      exit 2 ;;
  esac
done
# the adapter, for the stamp: from a light field's report (a draft one where none was made)
ls "$work"/*.json >/dev/null 2>&1 \
  || "$vlf" propagate scenes/cornell/scene.toml --quality draft -o "$work/adapter.vlf" --report "$work/adapter.json" >/dev/null 2>&1
# the propagation reports beside the pictures (what made them); the stamp needs Python 3.11
cp "$work"/*.json "$out/"
python3 tools/pictures.py describe "$vlf" "$out" "$out" "${names[@]}" \
  || echo "tools/pictures.sh: no stamp here (Python 3.11 missing?): run \`python3 tools/pictures.py describe $vlf OUT OUT NAME...\` where the pictures land" >&2
