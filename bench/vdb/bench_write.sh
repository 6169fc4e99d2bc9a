#!/usr/bin/env bash
# Size and speed of a .vdb write: the bunny's level set at 512 (half-width 3) written by
# volga (the `write` stage of `volga voxelize --report`: encoding, the file, its fsync)
# and by OpenVDB 10 (`pyopenvdb.write` of the same grid, read from volga's file: Blosc,
# OpenVDB's default), same run, the two taking turns. Outside CI: needs Debian's
# python3-openvdb and a release build.
#
#   bench/vdb/bench_write.sh [VOLGA] [RUNS]      # defaults: target/release/volga, 5
set -euo pipefail
cd "$(dirname "$0")/../.."
VOLGA=${1:-target/release/volga}
RUNS=${2:-5}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
mesh=tests/data/stanford-bunny.obj
echo "# $(date -u +%FT%TZ) $(git rev-parse --short HEAD) $(nproc) cores, $(uname -m); bunny level set at 512, half-width 3; median of $RUNS"
for run in $(seq "$RUNS"); do
  for variant in zip blosc none half; do
    flags="--vdb-compression $variant"
    [ "$variant" = half ] && flags="--vdb-compression blosc --vdb-half"
    "$VOLGA" voxelize $mesh --resolution 512 --distance 3 --out "$OUT/volga_$variant.vdb" $flags \
      --report "$OUT/r_${variant}_$run.json" > /dev/null 2>&1
  done
  /usr/bin/python3 - "$OUT" "$run" <<'PY'
import json, os, sys, time
import pyopenvdb as vdb
out, run = sys.argv[1], sys.argv[2]
g = vdb.read(os.path.join(out, "volga_zip.vdb"), "surface")
t = time.perf_counter()
vdb.write(os.path.join(out, "openvdb.vdb"), grids=[g])
json.dump({"write_s": time.perf_counter() - t, "active_voxels": g.activeVoxelCount()},
          open(os.path.join(out, f"o_{run}.json"), "w"))
PY
done
/usr/bin/python3 - "$OUT" "$RUNS" <<'PY'
import json, os, statistics, sys
out, runs = sys.argv[1], int(sys.argv[2])
def stage(path):
    return [s["wall_s"] for s in json.load(open(path))["stages"] if s["name"] == "write"][0]
o = [json.load(open(os.path.join(out, f"o_{r}.json"))) for r in range(1, runs + 1)]
ov_s = statistics.median(x["write_s"] for x in o)
ov_size = os.path.getsize(os.path.join(out, "openvdb.vdb"))
print(f"active voxels: {o[0]['active_voxels']}")
print(f"{'writer':<22}{'compression':<14}{'MB':>9}{'size/OpenVDB':>14}{'median s':>10}{'OpenVDB s/this s':>18}")
print(f"{'OpenVDB 10 pyopenvdb':<22}{'blosc':<14}{ov_size/1e6:>9.2f}{1.0:>14.2f}{ov_s:>10.3f}{1.0:>18.2f}")
for v, label in [("blosc", "blosc"), ("zip", "zip"), ("none", "none"), ("half", "blosc, half")]:
    s = statistics.median(stage(os.path.join(out, f"r_{v}_{r}.json")) for r in range(1, runs + 1))
    size = os.path.getsize(os.path.join(out, f"volga_{v}.vdb"))
    print(f"{'volga':<22}{label:<14}{size/1e6:>9.2f}{size/ov_size:>14.2f}{s:>10.3f}{ov_s/s:>18.2f}")
PY
