#!/usr/bin/env bash
# An ADF meshed on its own leaves (`volga adf --mesh --mesh-on-leaves`: the dual grid, no
# lattice) against the same ADF meshed on a lattice (`--mesh-resolution`), for the bunny and
# fandisk at two tolerances; each mesh scored by `volga bench extract --score` against the
# exact mesh (distances in voxels of the scoring resolution, 256 along the longest side).
# Usage: bench/extract/adf_leaves.sh [TOLERANCES...]   (default 1e-3 1e-4). Outside CI.
set -euo pipefail
cd "$(dirname "$0")/../.."
VOLGA=target/release/volga
DATA=${DATA:-../shared/data}
TOLS=${*:-1e-3 1e-4}
LATTICE=${LATTICE:-512}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "# $(date -u +%FT%TZ) commit $(git rev-parse --short HEAD) $(nproc) cores, $(uname -m), loadavg $(cut -d' ' -f1-3 /proc/loadavg)"
for mesh in stanford-bunny fandisk; do
  for tol in $TOLS; do
    scores=()
    for mode in leaves lattice; do
      obj="$OUT/$mesh-$tol-$mode.obj"
      if [ "$mode" = leaves ]; then flags=(--mesh-on-leaves); else flags=(--mesh-resolution "$LATTICE"); fi
      report=$($VOLGA adf "$DATA/$mesh.obj" --tolerance "$tol" --points 1000 --size 64 --out "$OUT/adf" --mesh "$obj" "${flags[@]}")
      echo "$report" | python3 -c "import json,sys; d=json.load(sys.stdin); m=d['mesh']; print(json.dumps({'mesh': '$mesh', 'tolerance': $tol, 'mode': '$mode', 'lattice': None if '$mode' == 'leaves' else $LATTICE, 'leaves': d['leaves'], 'depth_reached': d['depth_reached'], 'build_s': d['build_s'], 'mesh_seconds': m['seconds'], 'triangles': m['triangles']}))"
      scores+=(--score "$obj")
    done
    echo "## scores $mesh $tol (leaves, lattice $LATTICE)"
    $VOLGA bench extract "$DATA/$mesh.obj" --resolution 256 --repeat 1 --adaptivity 0.1 --json "${scores[@]}" \
      | python3 -c "import json,sys; d=json.load(sys.stdin); [print(json.dumps(s)) for s in d['scored']]"
  done
done
