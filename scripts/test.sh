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
# One release build lints and compiles: .cargo/config.toml makes clippy-driver (with -D warnings)
# the compiler of our crates, so the dependencies are built once, not once for `cargo clippy` and
# again for `cargo test`, and the graph tests' `cargo build` finds everything up to date.
echo "==> release build of everything, linted by clippy (warnings are errors)"
cargo build --release --workspace --all-targets
echo "==> cargo test (release)"
cargo test --workspace --release --no-fail-fast
