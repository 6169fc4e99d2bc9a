#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run): formatting, lints and the API docs with
# warnings denied, the Rust workspace's tests, then the Python package's suite
# (scripts/test-python.sh), both with the `ci` profile (one compile of the kernel). Needs the Rust toolchain (rustfmt and clippy components) and
# Python ≥ 3.9 with venv; maturin, pytest and numpy come from PyPI.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --all --check
cargo clippy --workspace --all-targets -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps
cargo test --workspace --profile ci
scripts/test-python.sh
