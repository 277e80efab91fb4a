#!/usr/bin/env bash
# The render.wgsl variants of the traversal experiments (docs/results/h100/traversal/, BENCHMARKS.md
# "Where the time went"), rebuilt from their patches for VLF_SHADER_DIR: each
# docs/results/h100/traversal/variants/NAME.patch is applied to shaders/render.wgsl of the commit
# its `base:` line names, into OUT_DIR/NAME/render.wgsl. The results name the variant they ran
# (cave-<scene>-NAME.json). The variants:
#   s16, s24, s32, s48   the traversal stack at 16, 24, 32, 48 entries instead of 64
#   s32-noentry          32 entries, without the entry distance kept beside each (no early pop)
#   mt                   leaves tested with the Moller-Trumbore test instead of the affine map
#   wg                   the stack in workgroup memory (32 entries per thread) instead of local
#   norefl               no mirror reflection traced (what the traversal costs alone)
#   no-reflection, s64-fixed   the same on 10b4c62 (no results kept)
#   bash tools/shader-variants.sh OUT_DIR [NAME...]     # then: VLF_SHADER_DIR=OUT_DIR/NAME vlf ...
set -euo pipefail
cd "$(dirname "$0")/.."
out=$1; shift
dir=docs/results/h100/traversal/variants
names=("$@")
[ ${#names[@]} -gt 0 ] || names=($(ls $dir | sed -n 's/\.patch$//p'))
for name in "${names[@]}"; do
  base=$(sed -n 's/^base: //p' "$dir/$name.patch")
  mkdir -p "$out/$name"
  git show "$base:shaders/render.wgsl" > "$out/$name/render.wgsl"
  patch --quiet "$out/$name/render.wgsl" "$dir/$name.patch"
  echo "$out/$name/render.wgsl (render.wgsl of $base, $name)"
done
