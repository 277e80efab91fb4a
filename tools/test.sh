#!/usr/bin/env bash
# The test command (README and CI): make sure an adapter exists (and Open MPI, Mitsuba,
# pygltflib: tools/setup.sh), check formatting, that the core builds without the lab, and
# lints, then run every test, with the CAVE cluster (`--features mpi`) so that
# tests/cluster.rs runs. GPU tests run on whatever adapter wgpu finds; on a machine without a
# GPU that is lavapipe.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cargo fmt --check || { echo "tools/test.sh: the code is not rustfmt-formatted: run \`cargo fmt\`" >&2; exit 1; }
# the core alone (no lab: src/lab/, feature `lab`) must build too
cargo check --release --no-default-features --lib --bins
cargo clippy --release --features mpi --all-targets -- -D warnings
cargo test --release --features mpi "$@"
