#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: a study's condition switches and frame-time constancy (issue 30
# item 2). The paced 4-wall stereo CAVE of config/displays/cave-4wall-conditions.toml (8 views of
# 1920x1200, 120 Hz, the Cornell walk) draws the Cornell box headless with a session log while
# tools/study/conditions_example.py --every EVERY, over --control, switches its conditions (gi-on,
# gi-off: direct light only, gi-on-dim: half the exposure; its start pose left out here) round
# after round (ROUNDS, default 5), a switch every EVERY frames (default 60), then stops the run.
# tools/study/condition_times.py reads the log's rows: GPU and CPU frame time per condition
# (median, p99, max) and around each switch (the frames from the switch's to AROUND after it,
# default 3: their max against the median of their condition), beside the same measure on runs
# of frames away from any switch.
# Reports into OUT_DIR/conditions.tar (conditions.json, the run's report, the log's frames.csv).
# PIXELS="96, 60" draws smaller walls (a smoke test on the software adapter: with FRAMES 40 and
# EVERY 6 it runs in minutes on lavapipe); FRAMES (default 2000) only bounds the run (the script
# stops it), PARAMS passes propagation flags (e.g. "--quality draft"). OTHER_SCENE=path adds a
# condition `other-scene` drawing that scene (other geometry: a renderer of its own, swapped in
# at the switch) at the same walk. RANKS=N runs it as an N-rank cluster (mpirun, a vlf built with
# --features mpi; `[cluster] gpu = "local-rank"`: each rank on its own GPU where the machine has
# them): every rank logs its own walls, and each rank's log is measured (conditions-rank<k>.json).
#   tools/gpu-conditions.sh VLF_BINARY OUT_DIR [EVERY] [FRAMES]
set -euo pipefail
vlf=$1; out=$2; every=${3:-60}; frames=${4:-2000}; work=${WORK:-$(mktemp -d)}; mkdir -p $work $out
rounds=${ROUNDS:-5}; around=${AROUND:-3}
quiet() { grep -v XDG_RUNTIME_DIR || true; }
config=$work/cave-conditions.toml
sed "s|^path = .*|path = \"$PWD/config/paths/cornell-walk.toml\"|" config/displays/cave-4wall-conditions.toml > $config
[ -n "${PIXELS:-}" ] && sed -i "s/^pixels = .*/pixels = [${PIXELS}]/" $config
# the conditions differ only in what a switch rebinds: gi-on-dim's start pose left out, so the
# walk's views (and their cost) go on through every switch
sed -i "/^start_pose = /d" $config
if [ -n "${OTHER_SCENE:-}" ]; then
  printf '\n[[condition]]\nname = "other-scene"\nlight_field = "%s"\n' "$(realpath "$OTHER_SCENE")" >> $config
fi
launch=""
if [ -n "${RANKS:-}" ]; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  printf '\n[cluster]\ngpu = "local-rank"   # rank n on a host draws on its n-th GPU\n' >> $config
  launch="mpirun -np $RANKS --oversubscribe"
fi
rm -rf $work/log $work/out
$launch "$vlf" cave $config --scene scenes/cornell/scene.toml ${PARAMS:-} --headless --frames $frames \
  --control 127.0.0.1:0 --log $work/log --out $work/out --json $work/cave-conditions.json \
  > $work/cave-conditions.txt 2> $work/cave-conditions.err &
pid=$!
addr=""
for _ in $(seq 1 1200); do  # propagating both light fields first: up to 10 minutes
  addr=$(sed -n 's/^control: listening on //p' $work/cave-conditions.err | head -1)
  [ -n "$addr" ] && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.5
done
if [ -z "$addr" ]; then
  cat $work/cave-conditions.err | quiet >&2
  echo "vlf cave never said where it listens" >&2; kill $pid 2>/dev/null; exit 1
fi
python3 tools/study/conditions_example.py "$addr" --every $every --times $rounds > $work/replies.jsonl || true
wait $pid
grep -E "conditions|light field" $work/cave-conditions.err | quiet || true
tail -12 $work/cave-conditions.txt
logs=$work/log; [ -n "${RANKS:-}" ] && logs=$(ls -d $work/log/rank*)
parts=""
for log in $logs; do
  name=conditions; [ -n "${RANKS:-}" ] && name=conditions-$(basename $log)
  python3 tools/study/condition_times.py $log --around $around > $work/$name.json
  cp $log/frames.csv $work/frames-$(basename $log).csv
  parts="$parts $name.json frames-$(basename $log).csv"
done
[ -n "${RANKS:-}" ] && cp $work/conditions-rank0.json $work/conditions.json
cat $work/conditions.json
[ -x "$(command -v nvidia-smi)" ] && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > $work/gpu.txt || echo "no nvidia-smi" > $work/gpu.txt
echo "${VLF_COMMIT:-unknown}" > $work/commit.txt
date -u +%Y-%m-%dT%H:%M:%SZ > $work/date.txt
(cd $work && tar cf "$out/conditions.tar" gpu.txt commit.txt date.txt cave-conditions.json cave-conditions.txt replies.jsonl $parts $( [ -n "${RANKS:-}" ] && echo conditions.json ))
cp $work/conditions.json $out/conditions.json
