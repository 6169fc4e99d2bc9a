#!/usr/bin/env bash
# volga on Dask, measured on this machine: batch throughput with 1 and 2 workers, the
# scheduler's overhead per task, and the bunny's dense signed distance at 2048 voxels
# written to Zarr by 2 workers of 2 GiB each. Results: bench/results/scale_<date>.jsonl.
#
#   bench/scale/run.sh [PYTHON]
#
# PYTHON is an interpreter with the volga wheel (maturin build --release) and the `dask`
# extra installed (default: python3).
set -euo pipefail
cd "$(dirname "$0")/../.."
python="${1:-python3}"
out="bench/results/scale_$(date -u +%F).jsonl"
{
    echo "{\"commit\": \"$(git rev-parse --short HEAD)\", \"date\": \"$(date -u +%FT%TZ)\", \"cpus\": $(nproc), \"mem_gib\": $(free -g | awk '/Mem:/ {print $2}')}"
    "$python" bench/scale/bench.py throughput --meshes 200 --repeat 3
    "$python" bench/scale/bench.py zarr --resolution 2048 --chunks 256 --worker-memory 2GiB
} | tee "$out"
