#!/usr/bin/env bash
# Benchmarks with same-run baselines: every estimator against linear trilateration, our NLS
# against SciPy's least_squares on the same exported problems, then the criterion benches.
# Installs NumPy and SciPy into .venv on first use.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
if ! .venv/bin/python -c 'import scipy' 2>/dev/null; then
  .venv/bin/python -m pip install --quiet --disable-pip-version-check 'numpy>=1.26' 'scipy>=1.11'
fi

# The same build line as every script and graph: building `--bin trigait` alone unifies the
# dependencies' features differently and recompiles them.
cargo build --release --workspace --all-targets
target/release/trigait bench --python .venv/bin/python "$@"

if [ "${CRITERION:-0}" = 1 ]; then
  cargo bench -p trigait-trilateration --bench estimators -- --warm-up-time 0.5 --measurement-time 2
fi
