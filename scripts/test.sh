#!/usr/bin/env bash
# Every check CI runs, from a fresh clone: formatting, lints, then all tests.
# One build profile (release) serves tests, benches, graphs and the CLI; see DESIGN.md "Build time".
# The graph tests (tests/dataflow.rs) run `dora run`: the dora CLI, the rerun .rrd reader and the
# Python node API (dora-rs, pyarrow) come from pip into .venv/ (prebuilt wheels, seconds), and
# .venv/bin goes on PATH (dora starts a `.py` node with the first `python` on PATH).
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/venv.sh   # .venv/ with the pinned packages of scripts/requirements.txt
export PATH="$PWD/.venv/bin:$PATH"

echo "==> cargo fmt --check"
cargo fmt --all -- --check
# One release build lints and compiles: .cargo/config.toml makes clippy-driver (with -D warnings)
# the compiler of our crates, so the dependencies are built once, not once for `cargo clippy` and
# again for `cargo test`, and the graph tests' `cargo build` finds everything up to date.
echo "==> release build of everything, linted by clippy (warnings are errors)"
cargo build --release --workspace --all-targets
echo "==> cargo test (release)"
# One test at a time within each test binary: the graph tests measure latency, and a
# neighbouring test's CPU work (an eval baseline, reading an .rrd back) stalled their graphs
# by up to 0.8 s on 2 cores; timing-based node loop tests likewise.
cargo test --workspace --release --no-fail-fast -- --test-threads=1
