#!/usr/bin/env bash
# Runs on the lent NVIDIA machine (docs/guide/lab.md): the suite (`vlf bench --suite`), `vlf
# bench` on the Cornell box and the Cornell-mirror box at our defaults and at the paper's
# settings, a perturbation run, the
# README images, and BENCHMARKS.md assembled from it all, everything into OUT_DIR.
#   tools/gpu-bench.sh VLF_BINARY OUT_DIR
set -uo pipefail
vlf=$1; out=$2
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader > "$out/gpu.txt" 2>&1
bench() {  # name scene [flags...]
  local name=$1 scene=$2; shift 2
  "$vlf" bench --scene "$scene" --frames 300 --json "$out/bench-$name.json" --markdown "$out/bench-$name.md" "$@" 2>&1 | grep -v XDG
}
# The first suite on a fresh machine also pays the driver's shader compilation in its setup
# times (up to 0.5 s a scene); it is kept as suite-cold.json, and the second run is reported.
"$vlf" bench --suite --json "$out/suite-cold.json" 2>&1 | grep -v XDG | tail -3
"$vlf" bench --suite --json "$out/suite.json" --plot "$out/suite-scaling.png" 2>&1 | grep -v XDG | tail -12
bench default scenes/cornell/scene.toml
bench paper scenes/cornell/scene.toml --config config/propagation/paper.toml
bench mirror scenes/cornell-mirror/scene.toml
bench mirror-paper scenes/cornell-mirror/scene.toml --config config/propagation/paper.toml
bench perturb4 scenes/cornell/scene.toml --perturb 4
for size in 256x192 1024x768 2048x1536; do
  "$vlf" bench --scene scenes/cornell/scene.toml --frames 300 --config config/propagation/paper.toml --size $size 2>&1 | grep "render "
done | sed 's/^ *//' > "$out/render-scaling.txt"
"$vlf" propagate scenes/cornell/scene.toml -o /tmp/cornell.vlf 2>&1 | grep -v XDG | tail -3
"$vlf" render /tmp/cornell.vlf -o "$out/cornell.png" | grep -v XDG
"$vlf" propagate scenes/cornell-mirror/scene.toml -o /tmp/mirror.vlf 2>&1 | grep -v XDG | tail -3
for cam in front side; do "$vlf" render /tmp/mirror.vlf --camera $cam -o "$out/cornell-mirror-$cam.png" | grep -v XDG; done
"$vlf" propagate scenes/textured-room/scene.toml -o /tmp/room.vlf 2>&1 | grep -v XDG | tail -3
"$vlf" render /tmp/room.vlf --camera front -o "$out/textured-room-front.png" | grep -v XDG
"$vlf" render /tmp/room.vlf --camera up --exposure 0.15 -o "$out/textured-room-up.png" | grep -v XDG
bash "$(dirname "$0")/benchmarks-md.sh" "$out" "$vlf" > "$out/BENCHMARKS.md"
# at most a few files come back from the lent machine: pack them
(cd "$out" && tar cf results.tar gpu.txt render-scaling.txt suite.json suite-cold.json bench-*.json bench-*.md && rm -f bench-*.json bench-*.md gpu.txt render-scaling.txt suite.json suite-cold.json)
(cd "$out" && tar cf images.tar *.png && rm -f *.png)
