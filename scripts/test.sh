#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run): formatting, lints and the API docs with
# warnings denied, the Rust workspace's tests, then the Python package's suite
# (scripts/test-python.sh), both with the `ci` profile. Needs the Rust toolchain (rustfmt and clippy components) and
# Python ≥ 3.9 with venv; maturin, pytest and numpy come from PyPI.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --all --check
cargo clippy --workspace --all-targets -- -D warnings
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps
cargo test --workspace --profile ci
# The CLI's integration tests made target/ci/volga (as `cargo build --bin volga` would,
# but with the tests' features: rebuilding it without them took 2 min 19 s on 2 cores).
VOLGA_BIN="$PWD/target/ci/volga" scripts/test-python.sh
