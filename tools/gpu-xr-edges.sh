#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: edge antialiasing in the headset (issue 32 item 3). `vlf xr`
# on vlf's test runtime (tests/xr-runtime: a simulated 90 Hz stereo headset, its head swaying),
# 2064x2208 per eye (Meta Quest 3's recommended size), on the generated 100K- and 1M-triangle
# mirror classrooms, FRAMES frames a run (default 900), once per variant:
#   aa8, aa4        N eye rays on every pixel, unpaced
#   edges8          1 eye ray per pixel, 8 where a pixel differs from a neighbour, unpaced
#   paced-edges8    the same with frame pacing (--fit-frame-time --aa 4 --edge-samples 8: 1 to
#                   16 eye rays per pixel by tile, 8 at the edges of the tiles given 2 or more)
# Each variant is drawn again for 90 frames with the head standing still and the display in
# lockstep (VLF_TEST_XR_STILL_HEAD, VLF_TEST_XR_LOCKSTEP: the same views in every run), its last
# frame's left eye written as EXR; so is the reference, 16 eye rays per pixel (aa16); the edge
# error is a variant's display MSE against the reference's (`vlf compare`). Prints per variant both eyes' GPU time (their medians and p99s added),
# the worst eye's p99/p50, missed refreshes, late and dropped frames, and the edge error; the
# reports, the runtime's reports and the table (xr-edges-SCENE.txt/.json) go into
# OUT_DIR/xr-edges.tar.
# Needs XR_RUNTIME_LIBRARY (tests/xr-runtime's library) and the OpenXR loader on
# LD_LIBRARY_PATH. SCENES and VARIANTS pick; EYES=WxH another size per eye; WORK=dir keeps the
# scenes and light fields.
#   tools/gpu-xr-edges.sh VLF_BINARY OUT_DIR [FRAMES]
set -uo pipefail
vlf=$1; out=$2; frames=${3:-900}; work=${WORK:-$(mktemp -d)}; mkdir -p $work "$out"
quiet() { grep -v XDG_RUNTIME_DIR; }
source "$(dirname "$0")/walk-scenes.sh"
[ -n "${XR_RUNTIME_LIBRARY:-}" ] || { echo "set XR_RUNTIME_LIBRARY to tests/xr-runtime's library" >&2; exit 2; }
manifest=$work/runtime.json
printf '{"file_format_version": "1.0.0", "runtime": {"name": "vlf headless test runtime", "library_path": "%s"}}\n' \
  "$(realpath "$XR_RUNTIME_LIBRARY")" > $manifest
export XR_RUNTIME_JSON=$manifest VLF_TEST_XR_EYE_PIXELS=${EYES:-2064x2208} XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
args() {  # variant -> vlf xr's settings
  case $1 in
    paced-edges8) echo "--fit-frame-time --aa 4 --edge-samples 8" ;;
    edges*) echo "--aa 1 --edge-samples ${1#edges}" ;;
    aa*) echo "--aa ${1#aa}" ;;
  esac
}
variants=${VARIANTS:-aa8 aa4 edges8 paced-edges8}
for scene in ${SCENES:-classroom-100k classroom-1m}; do
  if [ ! -f $work/$scene.vlf ]; then
    "$vlf" generate $(generate $scene) -o $work/$scene | quiet | tail -1
    "$vlf" propagate $work/$scene/scene.toml -o $work/$scene.vlf 2>&1 | quiet | grep -E "iterations|propagation  |triangles"
  fi
  for v in $variants aa16; do
    name=xr-$scene-$v
    if [ $v != aa16 ]; then
      VLF_TEST_XR_REPORT=$work/$name-runtime.txt "$vlf" xr --scene $work/$scene.vlf --frames $frames $(args $v) \
        --json $work/$name.json 2>&1 | quiet > $work/$name.txt
    fi
    VLF_TEST_XR_STILL_HEAD=1 VLF_TEST_XR_LOCKSTEP=1 "$vlf" xr --scene $work/$scene.vlf --frames 90 $(args $v) \
      --screenshot $work/$name-left.exr --screenshot-frame 90 2>&1 | quiet > $work/$name-still.txt
  done
  python3 - "$vlf" $work $scene $variants <<'PY' | tee $work/xr-edges-$scene.txt
import json, subprocess, sys
vlf, work, scene, variants = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
def mse(a, b):
    out = subprocess.run([vlf, "compare", "--json", a, b], capture_output=True, text=True)
    return json.loads(out.stdout[out.stdout.index("{"):])["display_mse"] if out.returncode == 0 else None
rows = {}
print(f"{scene}: headset, 90 Hz; GPU = the two eyes' medians and p99s added; edge error = the "
      "left eye, head still, against 16 eye rays per pixel")
print(f"{'variant':14} {'GPU p50':>8} {'p99':>8} {'worst eye p99/p50':>18} {'missed':>7} {'late':>5} "
      f"{'dropped':>8} {'edge error':>11}")
for v in variants:
    name = f"{work}/xr-{scene}-{v}"
    try:
        r = json.load(open(f"{name}.json"))
    except (OSError, ValueError):
        print(f"{v:14} no report (see {name}.txt)")
        continue
    error = mse(f"{name}-left.exr", f"{work}/xr-{scene}-aa16-left.exr")
    p50 = sum(e["gpu_ms"]["median"] for e in r["eyes"])
    p99 = sum(e["gpu_ms"]["p99"] for e in r["eyes"])
    ratio = max(e["p99_over_p50"] for e in r["eyes"])
    rows[v] = {"gpu_ms_p50": p50, "gpu_ms_p99": p99, "worst_p99_over_p50": ratio,
               "missed": r["missed_frames"], "late": r["late_frames"], "dropped": r["dropped_frames"],
               "frames": r["frames"], "edge_error": error, "quality": r.get("quality")}
    print(f"{v:14} {p50:8.3f} {p99:8.3f} {ratio:18.3f} {r['missed_frames']:7} {r['late_frames']:5} "
          f"{r['dropped_frames']:8} {'-' if error is None else f'{error:.3e}':>11}")
json.dump(rows, open(f"{work}/xr-edges-{scene}.json", "w"), indent=1)
PY
done
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar cf "$out/xr-edges.tar" gpu.txt commit.txt date.txt xr-*.json xr-*.txt)
