#!/usr/bin/env bash
# The test command (README and CI): make sure an adapter exists, then run every test, with the
# CAVE cluster (`--features mpi`; tools/setup.sh installs Open MPI) so tests/cluster.rs runs.
# GPU tests run on whatever adapter wgpu finds; on a machine without a GPU that is lavapipe.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cargo test --release --features mpi "$@"
