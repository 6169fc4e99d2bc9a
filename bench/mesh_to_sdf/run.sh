#!/usr/bin/env bash
# Per band voxel: volga's whole signed-distance voxelization against the `mesh_to_sdf`
# crate's per-point queries on the same voxels, in turns (ROUNDS rounds; medians).
# Needs the network once (cargo fetches mesh_to_sdf 0.4); not part of CI.
#
#   bench/mesh_to_sdf/run.sh [VOLGA_BIN=target/release/volga] [N=256] [ROUNDS=3]
# MESHES="teapot" (names in ../shared/data) narrows the meshes.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
volga="$(realpath "${1:-$repo/target/release/volga}")"
n="${2:-256}"
rounds="${3:-3}"
data="${VOLGA_DATA:-$repo/../shared/data}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cargo build --release -q --manifest-path "$here/Cargo.toml"
peer="$here/target/release/volga-bench-mesh-to-sdf"

echo "# N = $n, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%F), volga $volga"
for mesh in ${MESHES:-teapot stanford-bunny}; do
    for r in $(seq "$rounds"); do
        "$volga" bench voxelize "$data/$mesh.obj" --resolution "$n" --distance 3 --repeat 5 \
            --out "$work/$mesh.nrrd" 2>/dev/null > "$work/volga_$r.json"
        "$peer" "$data/$mesh.obj" "$work/$mesh.nrrd" 5 > "$work/peer_$r.json"
    done
    python3 - "$work" "$rounds" "$mesh" <<'PY'
import json, statistics, sys
work, rounds, mesh = sys.argv[1], int(sys.argv[2]), sys.argv[3]
v = [json.load(open(f"{work}/volga_{r}.json")) for r in range(1, rounds + 1)]
p = [json.load(open(f"{work}/peer_{r}.json")) for r in range(1, rounds + 1)]
band = p[0]["band_voxels"]
vt = statistics.median(x["median_s"] for x in v)
print(f"{mesh}: {band:,} band voxels")
print(f"  volga voxelize --distance 3 (all of it)   {vt:8.3f} s  {vt / band * 1e6:6.3f} us/voxel  wrong signs 0 (proven)")
for i, m in enumerate(p[0]["mesh_to_sdf"]):
    t = statistics.median(x["mesh_to_sdf"][i]["median_s"] for x in p)
    print(f"  mesh_to_sdf {m['method']:28s} {t:8.3f} s  {t / band * 1e6:6.3f} us/voxel  "
          f"wrong signs {m['wrong_signs']:,}  ratio {t / vt:5.2f}")
PY
done
