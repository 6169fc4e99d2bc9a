#!/bin/sh
# The sculpting benchmark with its peers, in one run (outside CI; installs what it needs):
#   bench/sculpt/run.sh [MESH] [RESOLUTION]      from the repository root
# Builds the OpenVDB CSG peer (../shared/peers/openvdb_csg_carve.cpp, see
# ../shared/PEERS.md) and a venv with scikit-image, then runs
#   volga bench sculpt MESH --resolution N --json --openvdb-peer … --skimage-python …
# which prints one JSON object (docs/SCULPT.md explains the keys).
set -eu
MESH=${1:-tests/data/stanford-bunny.obj}
N=${2:-1024}
PEERS=${PEERS_DIR:-/tmp/volga-peers}
mkdir -p "$PEERS"
if [ ! -x "$PEERS/csg_carve" ]; then
    dpkg -s libopenvdb-dev >/dev/null 2>&1 || apt-get install -y libopenvdb-dev libboost-dev
    g++ -O2 -std=c++17 ../shared/peers/openvdb_csg_carve.cpp -o "$PEERS/csg_carve" -lopenvdb -ltbb
fi
if [ ! -x "$PEERS/venv/bin/python" ]; then
    python3 -m venv "$PEERS/venv"
    "$PEERS/venv/bin/pip" install scikit-image
fi
cargo build --release -p volga-cli
"${CARGO_TARGET_DIR:-target}/release/volga" bench sculpt "$MESH" --resolution "$N" --json \
    --openvdb-peer "$PEERS/csg_carve" --skimage-python "$PEERS/venv/bin/python"
