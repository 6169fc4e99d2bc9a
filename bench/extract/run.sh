#!/usr/bin/env bash
# Side by side in one run: volga's extraction methods and the peers' marching cubes on the
# same anti-aliased solid (the NRRD `volga voxelize --anti-aliased --solid` writes), each
# mesh scored by `volga bench extract --score` against the exact mesh.
# Usage: bench/extract/run.sh [RESOLUTIONS...]   (default 256 512)
# Needs: target/release/volga; a Python with scikit-image and PyMCubes (PEER_PY, default
# /work/venv-peers/bin/python); Debian's python3-openvdb for /usr/bin/python3. Outside CI.
set -euo pipefail
cd "$(dirname "$0")/../.."
VOLGA=target/release/volga
PEER_PY=${PEER_PY:-/work/venv-peers/bin/python}
DATA=${DATA:-../shared/data}
RES=${*:-256 512}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
echo "# $(date -u +%FT%TZ) commit $(git rev-parse --short HEAD) $(nproc) cores, $(uname -m), loadavg $(cut -d' ' -f1-3 /proc/loadavg)"
for mesh in stanford-bunny fandisk; do
  for n in $RES; do
    dir="$OUT/$mesh-$n"
    mkdir -p "$dir"
    $VOLGA voxelize "$DATA/$mesh.obj" --resolution "$n" --anti-aliased --solid --out "$dir/volume.nrrd" > /dev/null
    "$PEER_PY" bench/extract/peers.py "$dir/volume.nrrd" "$dir" skimage,mcubes > "$dir/peers.jsonl"
    /usr/bin/python3 bench/extract/peers.py "$dir/volume.nrrd" "$dir" openvdb >> "$dir/peers.jsonl"
    scores=()
    while read -r obj; do scores+=(--score "$obj"); done < <(python3 -c "import json,sys; [print(json.loads(l)['obj']) for l in open('$dir/peers.jsonl')]")
    echo "## $mesh $n"
    echo "peers: $(tr '\n' ' ' < "$dir/peers.jsonl")"
    $VOLGA bench extract "$DATA/$mesh.obj" --resolution "$n" --json "${scores[@]}"
  done
done
