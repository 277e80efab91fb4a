#!/usr/bin/env bash
# Runs on the lent NVIDIA machine: the shipped Space Ship Hallway propagated at default settings,
# without and with rim rays, each with its report (the power balance per iteration and the
# materials where the loss concentrates: `power_balance` in the JSON).
# Writes OUT_DIR/hallway-default.{json,txt} and OUT_DIR/hallway-rim.{json,txt}.
#   tools/gpu-balance.sh VLF_BINARY OUT_DIR
set -euo pipefail
vlf=$1; out=$2; work=$(mktemp -d); mkdir -p "$out"
"$vlf" propagate scenes/space-ship-hallway/scene.toml -o "$work/h.vlf" \
  --report "$out/hallway-default.json" > "$out/hallway-default.txt" 2>&1
"$vlf" propagate scenes/space-ship-hallway/scene.toml --rim-rays -o "$work/h2.vlf" \
  --report "$out/hallway-rim.json" > "$out/hallway-rim.txt" 2>&1
rm -rf "$work"
grep -h "power balance " "$out"/hallway-*.txt
# Then the variants in docs/results/h200/hallway-balance/variants/ (every material black, one
# emitter material on: vent-only, blue-only; vent-one-sided: every material one-sided), one
# shooting iteration each, at 96 and 192 texels per unit, and vent-only with rim rays:
# OUT_DIR/variants/<variant>[-<density>|-rim].{json,txt}.
v=docs/results/h200/hallway-balance/variants; mkdir -p "$out/variants"; work=$(mktemp -d)
for s in vent-only blue-only; do for d in 96 192; do
  "$vlf" propagate $v/$s.toml --texel-density $d --max-iterations 1 -o "$work/x.vlf" \
    --report "$out/variants/$s-$d.json" > "$out/variants/$s-$d.txt" 2>&1
done; done
"$vlf" propagate $v/vent-one-sided.toml --max-iterations 1 -o "$work/x.vlf" \
  --report "$out/variants/vent-one-sided.json" > "$out/variants/vent-one-sided.txt" 2>&1
"$vlf" propagate $v/vent-only.toml --max-iterations 1 --rim-rays -o "$work/x.vlf" \
  --report "$out/variants/vent-rim.json" > "$out/variants/vent-rim.txt" 2>&1
rm -rf "$work"
grep -H "iteration 1 " "$out"/variants/*.txt
# vent-lit: the hallway's own materials with only the vent lights emitting, one iteration, with and
# without rim rays; blue-only with rim rays.
work=$(mktemp -d)
"$vlf" propagate $v/vent-lit.toml --max-iterations 1 --rim-rays -o "$work/x.vlf" \
  --report "$out/variants/vent-lit-rim.json" > "$out/variants/vent-lit-rim.txt" 2>&1
"$vlf" propagate $v/blue-only.toml --max-iterations 1 --rim-rays -o "$work/x.vlf" \
  --report "$out/variants/blue-rim.json" > "$out/variants/blue-rim.txt" 2>&1
"$vlf" propagate $v/vent-lit.toml --max-iterations 1 -o "$work/x.vlf" \
  --report "$out/variants/vent-lit.json" > "$out/variants/vent-lit.txt" 2>&1
rm -rf "$work"
grep -H "iteration 1 " "$out"/variants/vent-lit*.txt "$out"/variants/blue-rim.txt
# vent-lit-one-sided: the same with every material one-sided, with and without rim rays.
work=$(mktemp -d)
for r in "" "--rim-rays"; do
  n=vent-lit-one-sided${r:+-rim}
  "$vlf" propagate $v/vent-lit-one-sided.toml --max-iterations 1 $r -o "$work/x.vlf" \
    --report "$out/variants/$n.json" > "$out/variants/$n.txt" 2>&1
done
rm -rf "$work"
grep -H "iteration 1 " "$out"/variants/vent-lit-one-sided*.txt
# by-material/<material>.toml: vent-lit-one-sided with that one material two-sided again, one
# iteration each: which material's backs take the excess.
work=$(mktemp -d); mkdir -p "$out/variants/by-material"
for t in $v/by-material/*.toml; do
  n=$(basename "$t" .toml)
  "$vlf" propagate "$t" --max-iterations 1 -o "$work/x.vlf" \
    --report "$out/variants/by-material/$n.json" > "$out/variants/by-material/$n.txt" 2>&1
  echo "$n: $(grep -m1 'iteration 1 ' "$out/variants/by-material/$n.txt")"
done
rm -rf "$work"
# fix/: after a face stopped lighting its own back (shaders/direct.wgsl emitter_polygon): the
# hallway at default settings with its report, and `vlf verify` of both cameras (640x360, 2048 spp).
mkdir -p "$out/fix"; work=$(mktemp -d)
"$vlf" propagate scenes/space-ship-hallway/scene.toml -o "$work/h.vlf" \
  --report "$out/fix/hallway-default.json" > "$out/fix/hallway-default.txt" 2>&1
"$vlf" verify scenes/space-ship-hallway/scene.toml --lightfield "$work/h.vlf" --size 640x360 \
  --spp 2048 --out "$out/fix/verify" --json "$out/fix/verify.json" > "$out/fix/verify.txt" 2>&1
rm -rf "$work"
