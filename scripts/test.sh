#!/usr/bin/env bash
# Every check CI runs, from a fresh clone: formatting, lints, then all tests.
# One build profile (release) serves tests, benches, graphs and the CLI; see DESIGN.md "Build time".
# The graph tests (tests/dataflow.rs) run `dora run`: the dora CLI and the rerun .rrd reader come
# from pip into .venv/ (prebuilt wheels, seconds), and .venv/bin goes on PATH.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ ! -x .venv/bin/dora ] || [ ! -x .venv/bin/rerun ]; then
  echo "==> creating .venv with dora-rs-cli==1.1.0 and rerun-sdk==0.36.3"
  python3 -m venv .venv
  .venv/bin/pip install --quiet dora-rs-cli==1.1.0 rerun-sdk==0.36.3
fi
export PATH="$PWD/.venv/bin:$PATH"

echo "==> cargo fmt --check"
cargo fmt --all -- --check
# One release build lints and compiles: clippy-driver (with -D warnings) compiles our crates, so
# the dependencies are built once, not once for `cargo clippy` and again for `cargo test`. The
# graph tests' `cargo build` inherits the same wrapper and finds everything up to date.
export RUSTC_WORKSPACE_WRAPPER="$PWD/scripts/clippy-rustc"
echo "==> cargo build --all-targets with clippy (release; warnings are errors)"
cargo build --workspace --all-targets --release
echo "==> cargo test (release)"
cargo test --workspace --release --no-fail-fast
