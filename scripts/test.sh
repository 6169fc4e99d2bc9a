#!/usr/bin/env bash
# The whole test suite: the Rust workspace, then the Python package's suite
# (scripts/test-python.sh). Needs the Rust toolchain and Python ≥ 3.9 with venv; maturin,
# pytest and numpy come from PyPI.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace
scripts/test-python.sh
