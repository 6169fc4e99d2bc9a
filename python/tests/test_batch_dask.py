"""volga.batch and volga.dask on a local Dask cluster of 2 worker processes.

The dataset (batch_data.py) holds 200 good meshes (closed, open, self-intersecting,
flat, inconsistently oriented, far from the origin; sharing file names across folders),
8 broken files and one mesh too large for the workers' 300 MB. Runs are compared byte for
byte: uninterrupted, with a worker killed mid-run, and interrupted (the whole process
group killed) then resumed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections import Counter

import numpy as np
import pytest

if not os.environ.get("VOLGA_TEST_DASK"):
    pytest.importorskip("distributed")
    pytest.importorskip("zarr")

import volga  # noqa: E402
import volga.batch as batch  # noqa: E402
import volga.dask as vdask  # noqa: E402
from distributed import Client, LocalCluster, WorkerPlugin  # noqa: E402

from batch_data import make_dataset  # noqa: E402

WORKER_MEMORY = 300_000_000
RESOLUTION = 16


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("meshes")
    kinds = make_dataset(str(root))
    manifest = root / "manifest.txt"
    manifest.write_text("\n".join(kinds["good"] + kinds["broken"] + kinds["huge"]) + "\n")
    return kinds, str(manifest)


@pytest.fixture(scope="module")
def client():
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, memory_limit="1.5GiB",
                           resources={"MEMORY": WORKER_MEMORY}, dashboard_address=None)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def outputs(root):
    """Every output file under ``root`` by relative path, with its bytes."""
    out = {}
    for d, _, files in os.walk(root):
        if batch.WORK in d:
            continue
        for f in files:
            if f.endswith(".npz"):
                p = os.path.join(d, f)
                out[os.path.relpath(p, root)] = open(p, "rb").read()
    return out


def records(root):
    lines = open(os.path.join(root, batch.STATUS)).read().splitlines()
    return [json.loads(l) for l in lines if l.strip()]


@pytest.fixture(scope="module")
def reference(dataset, client, tmp_path_factory):
    out = str(tmp_path_factory.mktemp("reference"))
    summary = batch.run(dataset[1], out, mode="solid", resolution=RESOLUTION, client=client,
                        reserve=32 << 20, progress=False)
    return out, summary


def test_every_good_mesh_is_produced_and_every_bad_one_recorded(dataset, reference):
    kinds, _ = dataset
    out, summary = reference
    assert summary["meshes"] == 209 and summary["processed"] == 209
    assert (summary["done"], summary["failed"], summary["refused"]) == (200, 8, 1), summary
    latest = batch.read_status(out)
    for m in kinds["good"]:
        r = latest[m]
        assert r["status"] == "done", r
        assert r["validator"]["passed"] and r["sign"] is not None
        assert r["input"]["bytes"] == os.path.getsize(m) and r["peak_rss_bytes"] > 0
        (o,) = r["outputs"]
        assert os.path.getsize(o["path"]) == o["bytes"]
    for m in kinds["broken"]:
        r = latest[m]
        assert r["status"] == "failed" and r["outputs"] == [], r
        assert os.path.basename(m) in r["error"], r["error"]
    (huge,) = kinds["huge"]
    assert latest[huge]["status"] == "refused"
    assert "needs an estimated" in latest[huge]["error"] and str(WORKER_MEMORY) in latest[huge]["error"]
    # Names keep the folders (every good mesh is called model.obj).
    assert len(outputs(out)) == 200
    # The files hold the voxelization, as volga.voxelize makes it.
    for m in kinds["good"][:12]:
        z = np.load(latest[m]["outputs"][0]["path"])
        grid = volga.voxelize(m, resolution=RESOLUTION, mode="solid")
        dense = np.zeros(tuple(z["shape"]), dtype=bool)
        dense[tuple(z["indices"].T)] = z["values"]
        assert np.array_equal(dense, grid.matrix), m
        assert np.array_equal(z["transform"], grid.transform)


def test_a_worker_killed_mid_run_changes_no_byte(dataset, reference, client, tmp_path, monkeypatch):
    # A window of 16 tasks in flight: meshes are fed as earlier ones finish.
    monkeypatch.setattr(batch, "_MIN_WINDOW", 16)
    out = str(tmp_path / "killed")
    pids = client.run(os.getpid)
    killed = []

    def kill_one():
        status = os.path.join(out, batch.STATUS)
        deadline = time.time() + 60
        while time.time() < deadline:
            if os.path.exists(status) and sum(1 for _ in open(status)) >= 40:
                pid = sorted(pids.values())[0]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return
            time.sleep(0.005)

    t = threading.Thread(target=kill_one)
    t.start()
    summary = batch.run(dataset[1], out, mode="solid", resolution=RESOLUTION, client=client,
                        reserve=32 << 20, progress=False)
    t.join()
    assert killed, "the worker was not killed during the run"
    assert summary["processed"] == 209 and summary["done"] == 200, summary
    client.wait_for_workers(2, timeout=60)
    assert set(client.run(os.getpid).values()) != set(pids.values())
    assert outputs(out) == outputs(reference[0])
    assert Counter(r["mesh"] for r in records(out)) == Counter(r["mesh"] for r in records(reference[0]))


def test_resume_skips_what_is_complete_and_redoes_the_rest(dataset, reference, client, tmp_path):
    kinds, manifest = dataset
    import shutil

    out = str(tmp_path / "resumed")
    shutil.copytree(reference[0], out)
    # Point the copied records at the copy's files.
    text = open(os.path.join(out, batch.STATUS)).read().replace(reference[0], out)
    open(os.path.join(out, batch.STATUS), "w").write(text)
    before = outputs(out)
    # One output deleted, one cut short: those two meshes are redone, and the rest skipped.
    gone, cut = kinds["good"][3], kinds["good"][4]
    latest = batch.read_status(out)
    os.remove(latest[gone]["outputs"][0]["path"])
    with open(latest[cut]["outputs"][0]["path"], "r+b") as f:
        f.truncate(10)
    summary = batch.run(manifest, out, mode="solid", resolution=RESOLUTION, client=client,
                        reserve=32 << 20, progress=False)
    assert summary["skipped"] == 198 and summary["processed"] == 11, summary
    assert outputs(out) == before
    done = Counter(r["mesh"] for r in records(out) if r["status"] == "done")
    assert done[gone] == 2 and done[cut] == 2
    assert all(done[m] == 1 for m in kinds["good"] if m not in (gone, cut))
    # Another parameter invalidates every record.
    few = kinds["good"][:6]
    summary = batch.run(few, out, mode="solid", resolution=RESOLUTION + 1, client=client, progress=False)
    assert summary["skipped"] == 0 and summary["processed"] == 6
    summary = batch.run(few, out, mode="solid", resolution=RESOLUTION + 1, client=client, progress=False)
    assert summary["skipped"] == 6 and summary["processed"] == 0


def test_an_interrupted_run_resumes_to_the_same_bytes(dataset, reference, tmp_path):
    kinds, _ = dataset
    manifest = tmp_path / "good.txt"
    manifest.write_text("\n".join(kinds["good"] + kinds["broken"]) + "\n")
    out = str(tmp_path / "interrupted")
    cmd = [sys.executable, "-m", "volga.batch", str(manifest), out, "--mode", "solid", "--resolution",
           str(RESOLUTION), "--workers", "2", "--worker-memory", "1GiB", "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    status = os.path.join(out, batch.STATUS)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        if os.path.exists(status) and sum(1 for _ in open(status)) >= 60:
            break
        time.sleep(0.005)
    assert proc.poll() is None, proc.communicate()
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    first = records(out)
    assert 60 <= len(first) < 208, len(first)
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert again.returncode == 1, again.stderr  # the broken files failed
    summary = json.loads(again.stdout)
    assert summary["skipped"] == sum(1 for r in first if r["status"] == "done")
    done = Counter(r["mesh"] for r in records(out) if r["status"] == "done")
    assert sorted(done) == sorted(kinds["good"]) and set(done.values()) == {1}
    ref = outputs(reference[0])
    assert outputs(out) == ref
    assert not os.listdir(os.path.join(out, batch.WORK, "tmp")) if os.path.isdir(
        os.path.join(out, batch.WORK, "tmp")) else True


class CrashOnce(WorkerPlugin):
    """Ends the worker process while the task of one mesh runs, ``times`` times."""

    def __init__(self, marker_dir, count_file, times):
        self.marker_dir, self.count_file, self.times = marker_dir, count_file, times
        self.key = os.path.basename(marker_dir)  # the mesh's part of its task keys

    def setup(self, worker):
        self.worker = worker

    def transition(self, key, start, finish, **kwargs):
        if finish != "executing" or f"volga-batch-{self.key}-" not in str(key):
            return
        marker_dir, count_file, times = self.marker_dir, self.count_file, self.times

        def starts():
            return {f for f in os.listdir(marker_dir) if f.startswith("start-")} if os.path.isdir(marker_dir) else set()

        earlier = starts()  # markers of attempts that died before this one

        def crash_when_started():
            for _ in range(4000):
                if starts() - earlier:
                    n = int(open(count_file).read() or 0) if os.path.exists(count_file) else 0
                    if n < times:
                        open(count_file, "w").write(str(n + 1))
                        os._exit(1)
                    return
                time.sleep(0.0005)

        threading.Thread(target=crash_when_started, daemon=True).start()


def test_a_crashing_mesh_is_retried_then_recorded_and_a_slow_one_times_out(dataset, tmp_path):
    import hashlib

    kinds, _ = dataset
    target = kinds["huge"][0]  # slow to load, so the crash comes while it runs
    out = str(tmp_path / "crash")
    params = batch._parameters("solid", RESOLUTION, {}, 0, True, 0)
    marker_dir = os.path.join(out, batch.WORK, batch._params_hash(params),
                              hashlib.sha1(target.encode()).hexdigest()[:16])
    count_file = str(tmp_path / "crashes")
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, memory_limit="1.5GiB",
                           resources={"MEMORY": 2_000_000_000}, dashboard_address=None)
    with cluster, Client(cluster) as c:
        c.register_plugin(CrashOnce(marker_dir, count_file, 2))
        summary = batch.run([target] + kinds["good"][:4], out, mode="solid", resolution=RESOLUTION,
                            client=c, retries=1, progress=False)
        assert summary["done"] == 4 and summary["failed"] == 1, summary
        rec = batch.read_status(out)[target]
        assert rec["status"] == "failed" and "died 2 times" in rec["error"], rec
        assert int(open(count_file).read()) == 2
        # A timeout ends the worker; the mesh is recorded, the others are done.
        out2 = str(tmp_path / "timeout")
        summary = batch.run([target] + kinds["good"][:4], out2, mode="solid", resolution=RESOLUTION,
                            client=c, timeout=0.05, progress=False)
        rec = batch.read_status(out2)[target]
        assert rec["status"] == "failed" and "timed out after 0.05 s" in rec["error"], rec
        assert summary["failed"] >= 1 and summary["done"] + summary["failed"] == 5


@pytest.mark.parametrize("mode,options", [
    ("distance", {"band": 2.0}),
    ("solid", {}),
    ("anti_aliased", {"solid": True}),
    ("surface", {"separability": 6}),
])
def test_chunked_arrays_equal_the_whole_grid_bit_for_bit(mode, options):
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data", "stanford-bunny.obj")
    whole = volga.voxelize(path, resolution=40, mode=mode, **options).matrix
    for chunks in [(8, 8, 8), (13, 7, 21), (40, 3, 64)]:
        arr = vdask.voxelize_array(path, 40, chunks=chunks, mode=mode, **options)
        got = arr.compute(scheduler="threads")
        assert got.dtype == whole.dtype and got.shape == whole.shape
        view = np.uint8 if got.dtype == bool else np.uint32
        assert np.array_equal(got.view(view), whole.view(view)), (mode, chunks)


def test_zarr_keeps_the_transform_and_the_values(client, tmp_path):
    import zarr

    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data", "teapot.obj")
    store = str(tmp_path / "teapot.zarr")
    vdask.write_zarr(path, store, 48, chunks=16, mode="distance", band=2.0, multiscale=2)
    g = zarr.open_group(store, mode="r")
    whole = volga.voxelize(path, resolution=48, mode="distance", band=2.0)
    assert np.array_equal(g["0"][:].view(np.uint32), whole.matrix.view(np.uint32))
    attrs = g.attrs["volga"]
    assert np.array_equal(np.asarray(attrs["transform"]), whole.transform)
    assert attrs["background"] == pytest.approx(whole.background) and attrs["kind"] == "distance"
    assert g["1"].shape == tuple(s // 2 for s in whole.shape) and g["2"].shape == tuple(s // 4 for s in whole.shape)
    assert np.allclose(g["1"][:], whole.matrix[: 2 * g["1"].shape[0], : 2 * g["1"].shape[1], : 2 * g["1"].shape[2]]
                       .reshape(g["1"].shape[0], 2, g["1"].shape[1], 2, g["1"].shape[2], 2).mean(axis=(1, 3, 5)))
    ms = g.attrs["multiscales"][0]
    assert [d["path"] for d in ms["datasets"]] == ["0", "1", "2"]


def test_bad_arguments_are_refused_before_any_work(dataset, tmp_path):
    _, manifest = dataset
    with pytest.raises(ValueError, match="mode must be one of"):
        batch.run(manifest, str(tmp_path), mode="nope")
    with pytest.raises(ValueError, match="resolution"):
        batch.run(manifest, str(tmp_path), resolution=0)
    with pytest.raises(ValueError, match="band does not apply"):
        batch.run(manifest, str(tmp_path), mode="solid", band=3.0)
    r = subprocess.run([sys.executable, "-m", "volga.batch", manifest, str(tmp_path), "--resolution", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "resolution" in r.stderr
    with pytest.raises(MemoryError, match="smaller chunks"):
        vdask.voxelize_array(volga.Mesh(np.eye(3), [[0, 1, 2]]), 64, chunks=64, memory_limit=1000)


def test_sdf_samples_are_exact_and_reproducible(dataset, client, tmp_path):
    kinds, _ = dataset
    few = kinds["good"][:5]  # closed, open, self-intersecting, flat, flipped
    runs = []
    for name in ("a", "b"):
        out = str(tmp_path / name)
        s = batch.run(few, out, mode="samples", samples=2200, client=client, progress=False)
        assert s["done"] == 5, s
        runs.append(out)
    assert outputs(runs[0]) == outputs(runs[1])
    for m in few:
        z = np.load(batch.read_status(runs[0])[m]["outputs"][0]["path"])
        points, sdf = z["points"], z["sdf"]
        assert points.shape == (2200, 3) and sdf.shape == (2200,)
        exact = volga.signed_distance(m, points.astype(np.float64))
        assert np.array_equal(sdf, exact.astype(np.float32)), m
        assert (sdf < 0).any() or "m003" in m  # the flat square has no inside


def test_a_scene_baked_in_chunks_equals_the_whole_bake():
    scene = os.path.join(os.path.dirname(__file__), "..", "..", "scenes", "hello.ron")
    job = volga.SceneJob(scene)
    whole = job.bake().matrix
    assert whole.shape == job.shape and whole.max() > 0.5
    for chunks in [(32, 32, 32), (45, 17, 60)]:
        got = vdask.bake_array(scene, chunks=chunks).compute(scheduler="threads")
        assert np.array_equal(got.view(np.uint32), whole.view(np.uint32)), chunks
    part = job.bake(((10, 20, 30), (50, 41, 77)))
    assert np.array_equal(part.matrix, whole[10:50, 20:41, 30:77])
    with pytest.raises(ValueError, match="region"):
        job.bake(((0, 0, 0), (1, 1, 10_000)))
    with pytest.raises(MemoryError):
        job.bake(memory_limit=1000)
