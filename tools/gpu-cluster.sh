#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the 4-wall stereo CAVE (8 views of 1920x1200,
# config/displays/cave-4wall.toml) as a 2-rank MPI cluster, headless, 300 frames, Cornell-mirror
# propagated once to a .vlf that both ranks load; the walls split in order between the ranks
# (front and left on rank 0, right and floor on rank 1: no [cluster] table, so the default
# split). Both ranks share the machine's one GPU (the 2-GPU kind is not lent): the frame time
# is then the two ranks' work on one GPU, not a node per wall. Also the same CAVE in one
# process for comparison. Writes OUT_DIR/cluster-2ranks.json (the cluster report),
# cave-1process.json, cluster.log, gpu.txt, commit.txt; tools/cluster-md.sh OUT_DIR turns them
# into BENCHMARKS.md's section. Needs a vlf built with `--features mpi` and Open MPI's mpirun.
#   tools/gpu-cluster.sh VLF_BINARY OUT_DIR
set -uo pipefail
mkdir -p "$2"
vlf=$(realpath "$1"); out=$(cd "$2" && pwd)
frames=${FRAMES:-300}   # FRAMES=3 for a smoke test
cd "$(dirname "$0")/.."
if ! command -v mpirun >/dev/null; then
  echo "tools/gpu-cluster.sh: ABSENT: no mpirun on this machine (Open MPI is not installed: apt-get install openmpi-bin libopenmpi-dev); no cluster measurement" | tee "$out/cluster.log" >&2
  exit 2
fi
if ldd "$vlf" | grep -q "not found"; then
  echo "tools/gpu-cluster.sh: $vlf cannot start here, libraries missing:" | tee "$out/cluster.log" >&2
  ldd "$vlf" | grep "not found" | tee -a "$out/cluster.log" >&2
  exit 2
fi
mpirun --version | head -1 | tee "$out/cluster.log"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null || echo "?" > "$out/gpu.txt"
git rev-parse --short HEAD > "$out/commit.txt" 2>/dev/null || echo "?" > "$out/commit.txt"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
"$vlf" propagate scenes/cornell-mirror/scene.toml -o /tmp/mirror.vlf 2>&1 | grep -E "iterations|propagation  " | tee -a "$out/cluster.log"
# one process first (the baseline), then the cluster
"$vlf" cave config/displays/cave-4wall.toml --scene /tmp/mirror.vlf --headless --frames "$frames" \
  --out /tmp/cave-1process --json "$out/cave-1process.json" 2>&1 | grep -v XDG | tee -a "$out/cluster.log"
timeout 900 mpirun -np 2 --oversubscribe "$vlf" cave config/displays/cave-4wall.toml --scene /tmp/mirror.vlf \
  --headless --frames "$frames" --out /tmp/cave-cluster --json "$out/cluster-2ranks.json" 2>&1 | grep -v XDG | tee -a "$out/cluster.log"
rc=${PIPESTATUS[0]}
echo "mpirun exit status $rc" | tee -a "$out/cluster.log"
[ -f "$out/cluster-2ranks.json" ] || { echo "tools/gpu-cluster.sh: no cluster report written" >&2; exit 1; }
exit "$rc"
