#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the participant's body in the shipped walk CAVE (issue 28).
# The 4-wall stereo CAVE of config/displays/cave-4wall-walk.toml (8 views of 1920x1200, 120 Hz,
# paced as shipped) walks the scripted walks through the generated 100K- and 1M-triangle mirror
# classrooms three times: without moving objects, with the shipped avatar on the walking head
# (assets/avatar/mannequin.glb, 4,456 triangles), and with the avatar and a 200K-triangle prop
# carried in front of it (a sphere of 199,712 triangles: the update's size the issue asks for);
# the avatar without its shadows (what they cost), and with its shadows per pixel instead of from
# the shadow atlas (`[object_lighting] shadows = "per_pixel"`), and with its own direct light by
# shadow rays per eye ray instead of once per frame at its vertices (`direct_light = "per_pixel"`,
# as before per-vertex light), and the avatar and the prop without the occlusion rays that correct
# the probes' light on them (`occlusion_rays = 0`, as before them), and the avatar without the
# shadow atlas's indirect rays (`atlas_indirect_rays = 0`, as before them). VARIANTS picks some of
# "none body body-noshadow body-perpixel body-pixeldirect body-prop body-noocclusion
# body-prop-noocclusion body-noindirect" (tools/gpu-shadow.sh: the shadows' three).
# Reports (JSON + text, the last frame's overview) into OUT_DIR/body.tar; the reports' "moving
# objects' update" line is the skinning + triangles + refit pass's GPU time per frame, with the
# vertices' direct light and the shadow atlas where they are made once per frame.
# SCENES (default "classroom-100k classroom-1m") picks the walks; WORK=dir reuses light fields.
#   tools/gpu-body.sh VLF_BINARY OUT_DIR [FRAMES]
set -uo pipefail
vlf=$1; out=$2; frames=${3:-600}; work=${WORK:-$(mktemp -d)}; mkdir -p $work
quiet() { grep -v XDG_RUNTIME_DIR; }
source "$(dirname "$0")/walk-scenes.sh"
# the prop: a UV sphere of radius 0.15 m, 353 rings x 283 segments x 2 = 199,712 triangles
python3 - $work/prop.obj <<'PY'
import math, sys
rings, segments, r = 353, 283, 0.15
lines = ["mtllib prop.mtl", "usemtl prop"]
for i in range(rings + 1):
    t = math.pi * i / rings
    for j in range(segments):
        p = 2 * math.pi * j / segments
        lines.append(f"v {r*math.sin(t)*math.cos(p):.6f} {r*math.cos(t):.6f} {r*math.sin(t)*math.sin(p):.6f}")
for i in range(rings):
    for j in range(segments):
        a, b = i * segments + j + 1, i * segments + (j + 1) % segments + 1
        c, d = a + segments, b + segments
        lines += [f"f {a} {b} {c}", f"f {b} {d} {c}"]
open(sys.argv[1], "w").write("\n".join(lines) + "\n")
open(sys.argv[1].replace(".obj", ".mtl"), "w").write("newmtl prop\nKd 0.7 0.5 0.2\n")
PY
body="[[object]]
name = \"body\"
kind = \"avatar\"
mesh = \"$PWD/assets/avatar/mannequin.glb\""
prop="[[object]]
name = \"prop\"
mesh = \"$work/prop.obj\"
follow = \"head\"
position = [0.25, -0.35, -0.45]"
for scene in ${SCENES:-classroom-100k classroom-1m}; do
  if [ ! -f $work/$scene.vlf ]; then
    "$vlf" generate $(generate $scene) -o $work/$scene | quiet | tail -1
    "$vlf" propagate $work/$scene/scene.toml -o $work/$scene.vlf 2>&1 | quiet | grep -E "iterations|propagation  |triangles"
  fi
  sed "s|^path = .*|path = \"$(walk_path $scene)\"|" config/displays/cave-4wall-walk.toml > $work/cave-$scene-none.toml
  { cat $work/cave-$scene-none.toml; echo; echo "$body"; } > $work/cave-$scene-body.toml
  { cat $work/cave-$scene-body.toml; echo; echo "$prop"; } > $work/cave-$scene-body-prop.toml
  # what the shadows cost: the body without them
  { cat $work/cave-$scene-body.toml; echo; echo "[object_lighting]"; echo "shadow_samples = 0"; echo "sky_shadow_samples = 0"; echo "vertex_shadow_samples = 0"; echo "vertex_sky_shadow_samples = 0"; echo "atlas_shadow_samples = 0"; echo "atlas_sky_shadow_samples = 0"; } > $work/cave-$scene-body-noshadow.toml
  # the body's own direct light by shadow rays per eye ray that meets it (before per-vertex light)
  { cat $work/cave-$scene-body.toml; echo; echo "[object_lighting]"; echo "direct_light = \"per_pixel\""; } > $work/cave-$scene-body-pixeldirect.toml
  # what the occlusion rays cost: the probes' light as it is (before they were added)
  { cat $work/cave-$scene-body.toml; echo; echo "[object_lighting]"; echo "occlusion_rays = 0"; } > $work/cave-$scene-body-noocclusion.toml
  { cat $work/cave-$scene-body-prop.toml; echo; echo "[object_lighting]"; echo "occlusion_rays = 0"; } > $work/cave-$scene-body-prop-noocclusion.toml
  # what the shadow atlas's indirect rays cost: the direct light's shadow only (before them)
  { cat $work/cave-$scene-body.toml; echo; echo "[object_lighting]"; echo "atlas_indirect_rays = 0"; } > $work/cave-$scene-body-noindirect.toml
  # the shadows per pixel of every view (before the shadow atlas)
  { cat $work/cave-$scene-body.toml; echo; echo "[object_lighting]"; echo "shadows = \"per_pixel\""; } > $work/cave-$scene-body-perpixel.toml
  for variant in ${VARIANTS:-none body body-noshadow body-perpixel body-prop}; do
    "$vlf" cave $work/cave-$scene-$variant.toml --scene $work/$scene.vlf --headless --frames $frames \
      --out $work/out-$scene-$variant --json $work/cave-$scene-$variant.json 2>&1 | quiet \
      | tee $work/cave-$scene-$variant.txt | grep -E "moving|all views|CPU frame|eye rays|limit"
    cp $work/out-$scene-$variant/overview.png $work/cave-$scene-$variant-overview.png
  done
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar cf "$out/body.tar" gpu.txt commit.txt date.txt cave-*.json cave-*.txt cave-*-overview.png)
