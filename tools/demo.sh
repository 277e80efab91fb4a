#!/usr/bin/env bash
# The newcomer's first command: install what the build and an adapter need (tools/setup.sh
# demo), then propagate and render the built-in Cornell box (`vlf demo`), writing
# out/cornell.png and out/cornell.exr. Built with `--features mpi`, as the tests are, so that
# `bash tools/test.sh` afterwards reuses this build.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh demo
cargo run --release --features mpi -- demo "$@"
