#!/usr/bin/env bash
# A glTF model on the GPU machine: propagate (report JSON), render from its cameras, bench.
#   bash tools/gpu-gltf.sh VLF_BINARY MODEL_DIR OUT_DIR [extra propagate flags, e.g. --quality high]
# MODEL_DIR holds the .gltf/.glb (and its buffers and images), with an optional scene.toml beside
# it for sky and cameras (tools/get-sponza.sh writes Sponza's). Writes OUT_DIR/: report.json and
# propagate.txt (the table, warnings, host peak memory), model.vlf, <camera>.png/.exr, bench.json,
# bench.txt, gpu.txt, summary.txt. FRAMES=N changes the bench's frame count (200).
set -uo pipefail
vlf=$(realpath "$1"); model_dir=$2; out=$3; shift 3
mkdir -p "$out"
model=$(ls "$model_dir"/*.gltf "$model_dir"/*.glb 2>/dev/null | head -1)
[ -n "$model" ] || { echo "gpu-gltf.sh: no .gltf or .glb in $model_dir" >&2; exit 1; }
scene=$model
[ -f "$model_dir/scene.toml" ] && scene=$model_dir/scene.toml
(nvidia-smi -L; nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv) > "$out/gpu.txt" 2>&1
timed() { if [ -x /usr/bin/time ]; then /usr/bin/time -v "$@"; else "$@"; fi; }
echo "== propagate $scene $*"
timed "$vlf" propagate "$scene" -o "$out/model.vlf" --report "$out/report.json" "$@" 2>&1 | tee "$out/propagate.txt"
cameras=$(python3 -c 'import sys, tomllib; print(" ".join(c["name"] for c in tomllib.load(open(sys.argv[1], "rb")).get("camera", [])))' "$model_dir/scene.toml" 2>/dev/null || true)
# the scene.toml's cameras, else the model's first (its own, or the one that frames it)
for cam in ${cameras:-""}; do
  echo "== render ${cam:-first camera}"
  name=${cam:-view}
  "$vlf" render "$out/model.vlf" ${cam:+--camera "$cam"} -o "$out/$name.png" 2>&1 | tee -a "$out/render.txt"
  "$vlf" render "$out/model.vlf" ${cam:+--camera "$cam"} -o "$out/$name.exr" >/dev/null 2>&1
done
echo "== bench"
"$vlf" bench --scene "$scene" --frames "${FRAMES:-200}" --json "$out/bench.json" "$@" 2>&1 | tee "$out/bench.txt"
python3 - "$out" > "$out/summary.txt" <<'PY'
import json, sys, os
out = sys.argv[1]
r = json.load(open(os.path.join(out, "report.json")))
h = r.get("host_textures", {})
print(f"scene {r['scene']} on {r['adapter']['name']}")
print(f"triangles {r['triangles']}, faces {r['faces']}, diffuse elements {r['diffuse_elements']}, non-diffuse {r['non_diffuse_elements']}")
print(f"textures: {h.get('textures', 0)} images, host {h.get('kept_bytes', 0) / 2**20:.1f} MiB kept of {h.get('full_bytes', 0) / 2**20:.1f} MiB full, GPU {r['texture_bytes'] / 2**20:.1f} MiB")
print(f"setup {r['setup_seconds']:.3f} s, visibility {r['visibility_seconds']:.3f} s, propagation {r['propagation_seconds']:.3f} s, {r['iterations']} iterations, residual {r['final_residual']:.2e}")
print(f"GPU memory propagating {r['propagation_memory_bytes'] / 2**20:.1f} MiB, rendering {r['render_memory_bytes'] / 2**20:.1f} MiB")
print("warnings:")
for w in r["warnings"]:
    print("  " + w)
PY
grep -E "Maximum resident set size" "$out/propagate.txt" >> "$out/summary.txt" || true
cat "$out/summary.txt"
