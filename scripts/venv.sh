#!/usr/bin/env bash
# Creates .venv/ (or brings it up to date) with the pinned Python packages of
# scripts/requirements.txt: the dora CLI, rerun-sdk, and dora's Python node API with pyarrow for
# Python stages such as nodes/python-stage. Installs only when the requirements changed since the
# last install, so the scripts that call it start in a moment.
set -euo pipefail
cd "$(dirname "$0")/.."

requirements=scripts/requirements.txt
stamp=.venv/.installed-requirements.txt
if [ ! -x .venv/bin/python ]; then
  echo "==> creating .venv"
  python3 -m venv .venv
fi
if ! cmp -s "$requirements" "$stamp"; then
  echo "==> installing $requirements into .venv"
  .venv/bin/pip install --quiet -r "$requirements"
  cp "$requirements" "$stamp"
fi
