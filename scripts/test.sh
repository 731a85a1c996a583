#!/usr/bin/env bash
# Every check CI runs, from a fresh clone: formatting, lints, then all tests.
# One build profile (release) serves tests, benches and the CLI; see DESIGN.md "Build time".
set -euo pipefail
cd "$(dirname "$0")/.."

echo "==> cargo fmt --check"
cargo fmt --all -- --check
echo "==> cargo clippy (warnings are errors)"
cargo clippy --workspace --all-targets --release -- -D warnings
echo "==> cargo test (release)"
cargo test --workspace --release
