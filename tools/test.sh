#!/usr/bin/env bash
# The test command (README and CI): make sure an adapter and the tests' tools exist
# (tools/setup.sh test), check formatting, then build and run every test binary with the CAVE
# cluster (`--features mpi`, the demo's build too, so tests/cluster.rs runs), reporting every
# failure (`--no-fail-fast`: one failing binary does not hide the rest). GPU tests run on
# whatever adapter wgpu finds; on a machine without a GPU that is lavapipe.
#
# Clippy lints the build itself: cargo runs our own crate's compiles (library, binary, every
# test) through clippy-driver, a rustc with clippy's lints (what `cargo clippy` runs, here with
# code generation), and warnings are errors. A separate `cargo clippy` would compile every
# dependency a second time in check mode: about 3 minutes of a 2-core CI machine. That
# `cargo clippy` and the core's build without the lab: tools/lint.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh test
cargo fmt --check || { echo "tools/test.sh: the code is not rustfmt-formatted: run \`cargo fmt\`" >&2; exit 1; }
clippy_driver=$(command -v clippy-driver || true)
[ -n "$clippy_driver" ] || { echo "tools/test.sh: clippy-driver not found: run \`rustup component add clippy\`" >&2; exit 1; }
# the form `cargo clippy -- -D warnings` hands clippy-driver its arguments in
export RUSTC_WORKSPACE_WRAPPER="$clippy_driver" CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
# Four tests at a time on any machine (RUST_TEST_THREADS overrides it): many tests spend their
# time waiting on other processes (mpirun's ranks, Xvfb, Mitsuba in Python, the OpenXR test
# runtime, `vlf` runs) and lavapipe does not keep two cores busy, so two at a time (one per core
# here) left a quarter of a 2-core machine idle. Measured on one (lavapipe): the test binary
# 480 s with two at a time, 303 s with four.
export RUST_TEST_THREADS=${RUST_TEST_THREADS:-4}
cargo test --release --features mpi --no-fail-fast "$@"
