#!/usr/bin/env bash
# The test command (README and CI): make sure an adapter and the tests' tools exist
# (tools/setup.sh test), check formatting, that the core builds without the lab, and lints, then
# run every test binary with the CAVE cluster (`--features mpi`, the demo's build too, so
# tests/cluster.rs runs), reporting every failure (`--no-fail-fast`: one failing binary does not
# hide the rest). GPU tests run on whatever adapter wgpu finds; on a machine without a GPU that
# is lavapipe.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh test
cargo fmt --check || { echo "tools/test.sh: the code is not rustfmt-formatted: run \`cargo fmt\`" >&2; exit 1; }
# the core alone (no lab: src/lab/, feature `lab`) must build too
cargo check --release --no-default-features --lib --bins
cargo clippy --release --features mpi --all-targets -- -D warnings
cargo test --release --features mpi --no-fail-fast "$@"
