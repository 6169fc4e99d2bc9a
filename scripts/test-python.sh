#!/usr/bin/env bash
# The Python package's suite: the wheel built by maturin and installed into a fresh virtual
# environment with the `dask` extra's packages, then pytest (python/tests; VOLGA_TEST_DASK=1
# makes the Dask tests fail, not skip, when those packages are missing). The suite compares
# against the `volga` binary bit for bit: $VOLGA_BIN when set (scripts/test.sh passes the
# one `cargo test --profile ci` built for the CLI's tests), else it is built here with the
# `ci` profile.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ -z "${VOLGA_BIN:-}" ]; then
    cargo build --profile ci --bin volga
    VOLGA_BIN="$PWD/target/ci/volga"
fi
export VOLGA_BIN

venv="$(mktemp -d)/venv"
trap 'rm -rf "$(dirname "$venv")"' EXIT
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check "maturin>=1.9,<2" "pytest>=7" numpy \
    "dask[array]>=2024.8" "distributed>=2024.8" "zarr>=2.18" "fsspec>=2024.6"
rm -rf target/wheels-test
"$venv/bin/maturin" build --profile ci --interpreter "$venv/bin/python" -o target/wheels-test
"$venv/bin/pip" install --quiet --disable-pip-version-check target/wheels-test/volga-*.whl
cd python/tests
VOLGA_TEST_DASK=1 "$venv/bin/python" -m pytest -q -p no:cacheprovider
