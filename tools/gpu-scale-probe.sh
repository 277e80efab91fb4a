#!/usr/bin/env bash
# Exploratory: generated scenes of growing size through `vlf bench` at default settings, each
# under a time limit, on the lent GPU.   tools/gpu-scale-probe.sh VLF_BINARY
vlf=$1
for s in 1000 10000 100000 1000000; do $vlf generate classroom --size $s -o /tmp/classroom-$s >/dev/null; done
$vlf generate gallery --size 10000 --mirrors -o /tmp/gallery-mirror >/dev/null
for sc in classroom-1000 classroom-10000 classroom-100000 classroom-1000000 gallery-mirror; do
  echo "== $sc"
  /usr/bin/time -f "wall %e s, max RSS %M KB" timeout 150 $vlf bench --scene /tmp/$sc/scene.toml --frames 50 2>&1 | grep -vE "XDG|^  (adapter|grid|textures|sky|scene) " | tail -22
done
