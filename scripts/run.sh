#!/usr/bin/env bash
# The main job on a fresh machine: builds trigait (release) and scores every estimator on the
# embedded simulated walker crossing the thesis rig, ending with the summary table.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bin trigait
target/release/trigait eval "$@"
