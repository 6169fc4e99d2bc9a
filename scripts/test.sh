#!/usr/bin/env bash
# The whole test suite: the Rust workspace, then the Python package built as a wheel and
# installed into a fresh virtual environment, with its pytest suite. Needs the Rust
# toolchain and Python ≥ 3.9 with venv; maturin, pytest and numpy come from PyPI.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo test --workspace

# The Python suite compares against the `volga` binary the Rust tests just built.
cargo build --profile test --bin volga
export VOLGA_BIN="$PWD/target/debug/volga"

venv="$(mktemp -d)/venv"
trap 'rm -rf "$(dirname "$venv")"' EXIT
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check "maturin>=1.9,<2" "pytest>=7" numpy
rm -rf target/wheels-test
# The test profile (opt-level 2, debug assertions on) reuses the crates `cargo test` built.
"$venv/bin/maturin" build --profile test --strip --interpreter "$venv/bin/python" -o target/wheels-test
"$venv/bin/pip" install --quiet --disable-pip-version-check target/wheels-test/volga-*.whl
cd python/tests
"$venv/bin/python" -m pytest -q -p no:cacheprovider
