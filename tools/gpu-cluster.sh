#!/usr/bin/env bash
# Runs on a lent NVIDIA machine: the 4-wall stereo CAVE (8 views of 1920x1200) as a 2-rank MPI
# cluster, headless, on the shipped walks (config/displays/cave-4wall-walk.toml, paced as shipped,
# on config/paths/<scene>-walk.toml through the generated 100K- and 1M-triangle classrooms with a
# mirror and the mirror gallery). No [[cluster.node]]: the walls split in order, front and left
# (4 views) on rank 0, right and floor (4 views) on rank 1. `[cluster] gpu = "local-rank"` gives
# the n-th rank on a host the host's n-th GPU (PCI bus order), so on a 2-GPU machine each rank
# draws on its own GPU; on a 1-GPU machine both share it. Against it: the same 8 views in one
# process on GPU 0 (VLF_GPU=0). Then a rank killed mid-run (SIGKILL) and a rank stopped
# (SIGSTOP, the lost-rank timeout) on the same machine. nvidia-smi samples every GPU's
# utilisation during the runs (gpu-utilization.csv) to show which GPUs worked.
# Writes into OUT_DIR: cluster-<scene>.json (the cluster report), one-process-<scene>.json,
# cluster-<scene>.txt, one-process-<scene>.txt, lose-kill.txt, lose-stop.txt, lose.json,
# cluster.log, gpu.txt, gpus.txt, commit.txt, date.txt; tools/cluster-md.sh OUT_DIR turns them
# into BENCHMARKS.md's section. Needs a vlf built with `--features mpi` and Open MPI's mpirun.
#   tools/gpu-cluster.sh VLF_BINARY OUT_DIR
# FRAMES (default 3000) frames per run; LOSE=0 leaves out the lost-rank runs; SCENES (default "classroom-100k classroom-1m gallery");
# MODES (default "paced fixed"): paced as shipped, and fixed at 4 eye rays per pixel
# (fit_frame_time = false; reports named <scene>-fixed).
set -uo pipefail
mkdir -p "$2"
vlf=$(realpath "$1"); out=$(cd "$2" && pwd)
frames=${FRAMES:-3000}
SCENES=${SCENES:-classroom-100k classroom-1m gallery}
MODES=${MODES:-paced fixed}
work=${WORK:-$(mktemp -d)}
cd "$(dirname "$0")/.."
log="$out/cluster.log"
if ! command -v mpirun >/dev/null; then
  echo "tools/gpu-cluster.sh: ABSENT: no mpirun on this machine (Open MPI is not installed: apt-get install openmpi-bin libopenmpi-dev); no cluster measurement" | tee "$log" >&2
  exit 2
fi
if ldd "$vlf" | grep -q "not found"; then
  echo "tools/gpu-cluster.sh: $vlf cannot start here, libraries missing:" | tee "$log" >&2
  ldd "$vlf" | grep "not found" | tee -a "$log" >&2
  exit 2
fi
quiet() { grep -v XDG_RUNTIME_DIR; }
mpirun --version | head -1 | tee "$log"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | head -1 > "$out/gpu.txt" 2>/dev/null || echo "?" > "$out/gpu.txt"
nvidia-smi --query-gpu=index,name,pci.bus_id --format=csv,noheader > "$out/gpus.txt" 2>/dev/null || echo "?" > "$out/gpus.txt"
echo "${VLF_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo '?')}" > "$out/commit.txt"
date -u +%Y-%m-%dT%H:%M:%SZ > "$out/date.txt"
cat "$out/gpus.txt" | tee -a "$log"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
nvidia-smi --query-gpu=timestamp,index,pci.bus_id,utilization.gpu,memory.used --format=csv -lms 500 \
  > "$out/gpu-utilization.csv" 2>/dev/null &
sampler=$!
trap 'kill $sampler 2>/dev/null' EXIT
# when each run started and ended, in nvidia-smi's clock format (its own file: nvidia-smi writes
# gpu-utilization.csv at its own offset)
mark() { echo "$*, $(date +%Y/%m/%d\ %H:%M:%S.%3N)" >> "$out/marks.csv"; }

# generate SCENE: the walk's scene as `vlf generate` makes it
source tools/walk-scenes.sh
for scene in $SCENES; do
  if [ ! -f "$work/$scene.vlf" ]; then
    "$vlf" generate $(generate "$scene") -o "$work/$scene" | quiet | tail -1 | tee -a "$log"
    "$vlf" propagate "$work/$scene/scene.toml" -o "$work/$scene.vlf" 2>&1 | quiet | grep -E "iterations|propagation  |triangles" | tee -a "$log"
  fi
  for mode in $MODES; do
    # paced: as shipped (fit_frame_time = true); fixed: 4 eye rays per pixel on every view, every
    # frame (fit_frame_time = false): the frame time the drawing itself takes
    name=$scene; [ "$mode" = fixed ] && name=$scene-fixed
    config="$work/cave-$name.toml"
    sed "s|^path = .*|path = \"$(walk_path $scene)\"|" config/displays/cave-4wall-walk.toml > "$config"
    [ "$mode" = fixed ] && sed -i 's/^fit_frame_time = true/fit_frame_time = false/' "$config"
    printf '\n[cluster]\ngpu = "local-rank"   # rank n on a host draws on its n-th GPU\n' >> "$config"
    echo "== $name: one process on GPU 0" | tee -a "$log"
    mark "$name one process start"
    VLF_GPU=0 "$vlf" cave "$config" --scene "$work/$scene.vlf" --headless --frames "$frames" \
      --out "$work/one-$name" --json "$out/one-process-$name.json" 2>&1 | quiet > "$out/one-process-$name.txt"
    mark "$name one process end"
    tail -14 "$out/one-process-$name.txt" | tee -a "$log"
    echo "== $name: mpirun -np 2" | tee -a "$log"
    mark "$name cluster start"
    timeout 900 mpirun -np 2 --oversubscribe "$vlf" cave "$config" --scene "$work/$scene.vlf" \
      --headless --frames "$frames" --out "$work/cluster-$name" --json "$out/cluster-$name.json" 2>&1 | quiet > "$out/cluster-$name.txt"
    rc=${PIPESTATUS[0]}
    mark "$name cluster end"
    grep -E "^vlf cluster|cluster report|rank [0-9] \(|frame time|swap|frames " "$out/cluster-$name.txt" | head -24 | tee -a "$log"
    echo "mpirun exit status $rc" | tee -a "$log"
  done
done

# a rank lost mid-run: SIGKILL (mpirun ends the job) and SIGSTOP (the other rank's lost-rank
# timeout, [cluster] timeout_s, 10 s by default)
lose() {  # signal name
  local scene=${SCENES%% *}
  local config="$work/cave-$scene.toml" text="$out/lose-$1.txt"
  mpirun -np 2 --oversubscribe "$vlf" cave "$config" --scene "$work/$scene.vlf" --headless \
    --frames 1000000 --out "$work/lose-$1" > "$text" 2>&1 &
  local job=$! started=$SECONDS pid=""
  while [ -z "$pid" ] && [ $((SECONDS - started)) -lt 120 ]; do
    sleep 0.5
    pid=$(sed -n 's/^vlf cluster: rank 1 of 2 .*(pid \([0-9]*\)).*/\1/p' "$text" | head -1)
  done
  sleep 6  # frames under way on both ranks
  local t0; t0=$(date +%s.%N)
  kill -"$1" "$pid"
  local ended=""
  for _ in $(seq 1 300); do
    kill -0 $job 2>/dev/null || { ended=yes; break; }
    sleep 0.1
  done
  local t1; t1=$(date +%s.%N)
  kill -KILL "$pid" 2>/dev/null; kill $job 2>/dev/null; wait $job 2>/dev/null
  local named=no
  grep -qE "^vlf cluster rank 0 .*lost rank 1[ :(]" "$text" && named=yes
  python3 -c "import json,sys; print(json.dumps({'signal': sys.argv[1], 'ended': sys.argv[2] == 'yes', 'seconds_to_end': round(float(sys.argv[4]) - float(sys.argv[3]), 3), 'rank_0_named_rank_1': sys.argv[5] == 'yes', 'timeout_s': 10.0}))" \
    "$1" "$ended" "$t0" "$t1" "$named" >> "$work/lose.jsonl"
  echo "== rank 1 sent SIG$1: ended=$ended, rank 0 named it: $named" | tee -a "$log"
  grep -E "lost rank|LOST" "$text" | head -4 | tee -a "$log"
}
if [ "${LOSE:-1}" = 1 ]; then
  lose KILL
  lose STOP
  python3 -c "import json; print(json.dumps([json.loads(l) for l in open('$work/lose.jsonl')], indent=1))" > "$out/lose.json"
fi
kill $sampler 2>/dev/null
# the device tool brings back few files: one archive
(cd "$out" && tar cf cluster.tar --exclude cluster.tar ./*)
exit 0
