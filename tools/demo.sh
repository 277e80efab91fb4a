#!/usr/bin/env bash
# The newcomer's first command: make sure an adapter exists, then propagate and render the
# built-in Cornell box (`vlf demo`), writing out/cornell.png and out/cornell.exr.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
cargo run --release -- demo "$@"
