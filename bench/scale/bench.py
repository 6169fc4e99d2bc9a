"""volga on Dask, measured: dataset throughput with 1 and 2 workers, the scheduler's
overhead per task, and a dense signed distance grid written to Zarr under a memory cap.

    python bench/scale/bench.py throughput --out DIR [--meshes 200] [--repeat 3]
    python bench/scale/bench.py zarr --out DIR [--resolution 2048] [--chunks 256] [--worker-memory 2GiB]

Needs the `dask` extra (dask, distributed, zarr) and a volga wheel built with --release.
Prints one JSON object per measurement; bench/scale/run.sh keeps them in bench/results/.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(REPO, "python", "tests"))


def emit(record):
    print(json.dumps(record), flush=True)


def cluster(n_workers, memory, resources=None):
    from distributed import Client, LocalCluster

    c = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, memory_limit=memory,
                     resources=resources, dashboard_address=None, silence_logs=40)
    return c, Client(c)


def peak_rss(client):
    def vmhwm():
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
        return None

    return client.run(vmhwm)


def throughput(args):
    import volga.batch as batch
    from batch_data import make_dataset

    work = tempfile.mkdtemp(prefix="volga-scale-")
    kinds = make_dataset(os.path.join(work, "meshes"), count=args.meshes)
    meshes = kinds["good"]
    for mode, resolution in [("solid", 32), ("distance", 64)]:
        for n in (1, 2):
            c, client = cluster(n, "4GiB", {"MEMORY": 3 << 30})
            walls, task_s = [], []
            try:
                for r in range(args.repeat):
                    out = os.path.join(work, f"out-{mode}-{n}-{r}")
                    s = batch.run(meshes, out, mode=mode, resolution=resolution, client=client, progress=False)
                    assert s["done"] == len(meshes), s
                    walls.append(s["time_s"])
                    recs = batch.read_status(out).values()
                    task_s.append(sum(x["time_s"] for x in recs))
                    out_bytes = [o["bytes"] for x in recs for o in x["outputs"]]
                    task_times = sorted(x["time_s"] for x in recs)
                    shutil.rmtree(out)
            finally:
                client.close()
                c.close()
            wall = statistics.median(walls)
            emit({
                "bench": "batch_throughput", "mode": mode, "resolution": resolution, "workers": n,
                "meshes": len(meshes), "wall_s_median": wall, "wall_s": walls,
                "meshes_per_s": len(meshes) / wall, "task_s_sum_median": statistics.median(task_s),
                # Wall time the workers spent outside the tasks' own work, per mesh.
                "overhead_ms_per_mesh": 1e3 * (n * wall - statistics.median(task_s)) / len(meshes),
                "task_s_median": task_times[len(task_times) // 2], "task_s_max": task_times[-1],
                "output_bytes_mean": sum(out_bytes) / len(out_bytes),
            })
    # The scheduler alone: no-op tasks.
    for n in (1, 2):
        c, client = cluster(n, "2GiB")
        try:
            per = []
            for _ in range(args.repeat):
                k = 2000
                t = time.perf_counter()
                futures = client.map(lambda i: i, range(k), pure=False)
                client.gather(futures)
                per.append((time.perf_counter() - t) / k)
                del futures
        finally:
            client.close()
            c.close()
        emit({"bench": "scheduler_noop_task", "workers": n, "tasks": 2000,
              "ms_per_task_median": 1e3 * statistics.median(per), "ms_per_task": [1e3 * x for x in per]})
    shutil.rmtree(work)


def zarr_grid(args):
    import volga
    import volga.dask as vdask
    import zarr

    bunny = os.path.join(REPO, "tests", "data", "stanford-bunny.obj")
    store = os.path.join(args.out, f"bunny-{args.resolution}.zarr")
    shutil.rmtree(store, ignore_errors=True)
    mem = args.worker_memory
    c, client = cluster(2, mem)
    try:
        job = volga.VoxelJob(volga.load_mesh(bunny), resolution=args.resolution, mode="distance", band=3.0)
        pids = client.run(os.getpid)
        t = time.perf_counter()
        vdask.write_zarr(bunny, store, args.resolution, chunks=args.chunks, mode="distance", band=3.0)
        wall = time.perf_counter() - t
        peaks = peak_rss(client)
        # A worker over its cap is killed and restarted by its nanny: its pid changes.
        restarted = len(set(pids.values()) - set(client.run(os.getpid).values()))
    finally:
        client.close()
        c.close()
    g = zarr.open_group(store, mode="r")
    arr = g["0"]
    disk = int(subprocess.run(["du", "-sb", store], capture_output=True, text=True).stdout.split()[0])
    # Spot check: chunks through the surface equal volga.voxelize(region=...) of the same grid.
    shape = np.asarray(job.shape)
    mid = (shape // 2 // args.chunks) * args.chunks
    lo = tuple(int(x) for x in mid)
    hi = tuple(int(min(x + args.chunks, s)) for x, s in zip(mid, shape))
    part = volga.voxelize(bunny, resolution=args.resolution, mode="distance", band=3.0, region=(lo, hi)).matrix
    stored = arr[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    emit({
        "bench": "zarr_dense_sdf", "mesh": "stanford-bunny", "resolution": args.resolution, "shape": list(job.shape),
        "voxels": int(np.prod(job.shape)), "chunks": args.chunks, "workers": 2, "threads_per_worker": 1,
        "worker_memory_cap": mem, "wall_s": wall, "voxels_per_s": float(np.prod(job.shape)) / wall,
        "chunk_count": int(np.prod([-(-s // args.chunks) for s in job.shape])),
        "core_s_per_chunk": 2 * wall / float(np.prod([-(-s // args.chunks) for s in job.shape])),
        "worker_peak_rss_bytes": sorted(peaks.values()), "workers_restarted": restarted,
        "dense_float32_bytes": int(np.prod(job.shape)) * 4, "zarr_bytes_on_disk": disk,
        "spot_check_chunk": [lo, hi], "spot_check_equal": bool(np.array_equal(stored.view(np.uint32), part.view(np.uint32))),
    })
    if not args.keep:
        shutil.rmtree(store)


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="what", required=True)
    t = sub.add_parser("throughput")
    t.add_argument("--meshes", type=int, default=200)
    t.add_argument("--repeat", type=int, default=3)
    z = sub.add_parser("zarr")
    z.add_argument("--out", default=tempfile.gettempdir())
    z.add_argument("--resolution", type=int, default=2048)
    z.add_argument("--chunks", type=int, default=256)
    z.add_argument("--worker-memory", default="2GiB")
    z.add_argument("--keep", action="store_true")
    a = p.parse_args()
    {"throughput": throughput, "zarr": zarr_grid}[a.what](a)


if __name__ == "__main__":
    main()
