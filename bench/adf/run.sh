#!/bin/sh
# The ADF benchmark with its OpenVDB peer (outside CI; installs what it needs):
#   bench/adf/run.sh [MESH] [TOLERANCE] [N ...]        from the repository root
# Runs `volga bench adf MESH --tolerance T --json --probes-out PROBES` (the ADF's build,
# cells, bytes and errors at the probe points), then builds OpenVDB level sets of MESH at
# N voxels along its longest side (Debian's python3-openvdb, ../shared/PEERS.md) and
# measures them at the same probes (bench/adf/openvdb_adf_peer.py): memory against the
# ADF's at the same maximum error. Writes both JSON objects to $OUT (default /tmp/volga-adf-peer).
set -eu
MESH=${1:-tests/data/fandisk.obj}
TOL=${2:-1e-4}
shift $(( $# > 2 ? 2 : $# ))
OUT=${OUT:-/tmp/volga-adf-peer}
mkdir -p "$OUT"
/usr/bin/python3 -c 'import pyopenvdb' 2>/dev/null || apt-get install -y python3-openvdb
cargo build --release -p volga-cli
"${CARGO_TARGET_DIR:-target}/release/volga" bench adf "$MESH" --tolerance "$TOL" --repeat 1 --frames 1 --json \
    --probes-out "$OUT/probes.json" > "$OUT/adf.json"
/usr/bin/python3 bench/adf/openvdb_adf_peer.py "$MESH" "$OUT/probes.json" "$@" > "$OUT/openvdb.json"
cat "$OUT/adf.json" "$OUT/openvdb.json"
