#!/usr/bin/env bash
# Peer benchmark of `volga voxelize` against OpenVDB, Open3D and trimesh (docs/BENCHMARKS.md).
# Heavy (tens of minutes, ~7 GiB peak for trimesh at N=512) and needs root for apt:
# kept out of CI on purpose. Arguments go to bench.py, e.g.
#   bench/peers/run.sh                          # N = 128 256 512, writes docs/BENCHMARKS.md
#   bench/peers/run.sh --sizes 128 --no-docs    # quick check
#   bench/peers/run.sh --skip-trimesh-above 256
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
cd "$repo"

# pyopenvdb exists only as a Debian package, built for Debian's /usr/bin/python3;
# Open3D's wheel needs libusb and libgomp at import time; GNU time measures peak RSS.
apt_pkgs=(python3-openvdb libusb-1.0-0 libgomp1 time)
missing=()
for p in "${apt_pkgs[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if ((${#missing[@]})); then
    apt-get update
    apt-get install -y "${missing[@]}"
fi

# Open3D and trimesh come from PyPI, into a venv kept next to this script (ignored by
# git). It is made from Debian's python so that both interpreters are the same 3.11.
venv="$here/.venv"
if ! "$venv/bin/python" -c 'import open3d, trimesh, scipy, numpy' >/dev/null 2>&1; then
    /usr/bin/python3 -m venv "$venv"
    "$venv/bin/pip" install open3d trimesh scipy numpy
fi

cargo build --release --bin volga

export VOLGA_PEERS_VIA_RUN_SH=1
exec "$venv/bin/python" "$here/bench.py" "$@"
