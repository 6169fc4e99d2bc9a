#!/usr/bin/env bash
# Cost of certified signs: narrow-band signed distance (±3 voxels) of the shared meshes
# at N = 256 and 512 with two volga binaries taking turns (`volga bench voxelize`, medians
# of REPEAT runs per round, median over ROUNDS rounds), then the per-stage profile of the
# bunny at 512 for both (`--profile`; docs/VOXELIZE.md quotes it). Outputs must be equal:
# each job's last result is written by both binaries and compared byte for byte.
#
#   bench/signs/run.sh BASE_BIN NEW_BIN [ROUNDS=3] [REPEAT=5]
#
# BASE_BIN must know `--profile` (any volga from the commit that added it on).
# PROFILE_ONLY=1 runs only the profiles.
set -euo pipefail
base="$(realpath "$1")"
new="$(realpath "$2")"
rounds="${3:-3}"
repeat="${4:-5}"
repo="$(cd "$(dirname "$0")/../.." && pwd)"
data="${VOLGA_DATA:-$repo/../shared/data}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

median() { python3 -c 'import sys,statistics; print(statistics.median(float(x) for x in sys.argv[1:]))' "$@"; }
run() { "$1" bench voxelize "$2" --resolution "$3" --distance 3 --repeat "$repeat" --out "$4" 2>/dev/null |
    python3 -c 'import json,sys; print(json.load(sys.stdin)["median_s"])'; }

if [[ -z "${PROFILE_ONLY:-}" ]]; then
echo "# volga bench voxelize --distance 3, medians of $repeat runs, median of $rounds rounds"
echo "# base $base, new $new; $(nproc) cores; load $(cut -d' ' -f1-3 /proc/loadavg); $(date -u +%F)"
printf '%-22s %5s %10s %10s %7s %s\n' mesh N base_s new_s ratio outputs
for mesh in stanford-bunny teapot spot fandisk; do
    for n in 256 512; do
        b=(); w=()
        for _ in $(seq "$rounds"); do
            b+=("$(run "$base" "$data/$mesh.obj" "$n" "$work/base.nrrd")")
            w+=("$(run "$new" "$data/$mesh.obj" "$n" "$work/new.nrrd")")
        done
        same=identical
        cmp -s "$work/base.raw" "$work/new.raw" || same=DIFFER
        mb=$(median "${b[@]}"); mw=$(median "${w[@]}")
        printf '%-22s %5s %10.3f %10.3f %7.2f %s\n' "$mesh" "$n" "$mb" "$mw" \
            "$(python3 -c "print($mb/$mw)")" "$same"
    done
done

fi

echo
echo "# per-stage profile, stanford-bunny at 512 (median of $repeat runs; wall ms, CPU ms)"
for bin in "$base" "$new"; do
    echo "## $bin"
    "$bin" bench voxelize "$data/stanford-bunny.obj" --resolution 512 --distance 3 --repeat "$repeat" --profile 2>/dev/null |
        python3 -c '
import json, sys
r = json.load(sys.stdin)
for s in r["profile"]:
    name, wall, cpu, share = s["name"], s["wall_s"] * 1e3, s["cpu_s"] * 1e3, 100 * s["share"]
    print(f"{name:16s} {wall:8.1f} {cpu:8.1f} {share:5.1f}%")
total = r["median_s"] * 1e3
print(f"total (median)   {total:8.1f}")'
done
