#!/usr/bin/env bash
# Installs the peers of bench/python/bench_peers.py into a venv (idempotent).
#
#   bench/python/setup_peers.sh [VENV] [VOLGA_WHEEL]
#
# VENV defaults to .venv-peers (relative to the current directory). VOLGA_WHEEL, if given,
# is installed into it last (--force-reinstall --no-deps), e.g. the wheel `maturin build
# --release` wrote under target/wheels/. Set PYTHON to choose the interpreter the venv is
# made from (default python3). Needs root for the apt step when a package is missing.
#
# Why each system package:
#   libusb-1.0-0, libgomp1  Open3D's wheel fails to import without them
#   libeigen3-dev, g++      pysdf 0.1.9 has no wheel for CPython 3.11 and builds from source;
#                           its setup.py cannot parse Eigen 3.4.0's version (minor version
#                           0 reads as "not found") and then tries to download Eigen, so
#                           the headers are passed through CPATH instead.
set -euo pipefail
venv="${1:-.venv-peers}"
wheel="${2:-}"
python="${PYTHON:-python3}"

apt_pkgs=(libusb-1.0-0 libgomp1 libeigen3-dev g++)
missing=()
for p in "${apt_pkgs[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if ((${#missing[@]})); then
    if [ "$(id -u)" != 0 ]; then
        echo "setup_peers.sh: missing Debian packages ${missing[*]}; install them as root" >&2
        exit 1
    fi
    apt-get update
    apt-get install -y "${missing[@]}"
fi

[ -x "$venv/bin/python" ] || "$python" -m venv "$venv"
pip=("$venv/bin/python" -m pip)
"${pip[@]}" install numpy trimesh scipy rtree libigl open3d
"$venv/bin/python" -c 'import pysdf' >/dev/null 2>&1 || CPATH=/usr/include/eigen3${CPATH:+:$CPATH} "${pip[@]}" install pysdf

if [ -n "$wheel" ]; then
    "${pip[@]}" install --force-reinstall --no-deps "$wheel"
fi

status=0
for m in numpy trimesh scipy rtree igl open3d pysdf; do
    if "$venv/bin/python" -c "import $m" 2>/dev/null; then
        echo "ok       $m"
    else
        echo "MISSING  $m (import failed)" >&2
        status=1
    fi
done
if "$venv/bin/python" -c 'import volga' 2>/dev/null; then echo "ok       volga"; else echo "(volga not installed in $venv: pass its wheel as the second argument)"; fi
exit $status
