#!/usr/bin/env bash
# Before a commit (what tools/test.sh leaves to the developer to save CI a second compile of
# every dependency): rustfmt, clippy on every target as `cargo clippy` runs it, and the core
# built alone, without the lab's and the LSL outlets' crates (`--no-default-features`; the
# static half of that, no core module naming the lab, is tests/architecture.rs). tools/test.sh
# lints the build itself with clippy-driver, so a lint that fails here fails the tests too.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --check || { echo "tools/lint.sh: the code is not rustfmt-formatted: run \`cargo fmt\`" >&2; exit 1; }
cargo clippy --release --features mpi --all-targets -- -D warnings
cargo check --release --no-default-features --lib --bins
echo "tools/lint.sh: formatted, clippy clean, the core builds without the lab"
