"""Datasets from many meshes on Dask: ``volga.batch.run`` and the ``volga-batch`` command.

Needs the ``dask`` extra (``pip install 'volga[dask]'``). One task per mesh, on the
caller's ``distributed.Client`` or a local cluster, with:

* **atomic outputs**: each mesh's file is written under a temporary name and renamed, so a
  reader never sees half a file; byte for byte the same for the same mesh and parameters
  (no timestamps inside);
* **one status record per mesh** in ``status.jsonl`` under the output root (one JSON
  object per line, appended by the client only): ``mesh``, ``status`` (``done``,
  ``failed``, ``refused``), ``error``, ``outputs`` (path, bytes, sha256), the input's
  sha256 and size, the parameters and their hash, time, the worker's peak memory, the
  estimate, how the signs were proven and the validator's verdict;
* **resume**: a rerun skips every mesh whose latest record is ``done`` for the same
  parameters with its outputs present (same size; same sha256 with ``verify=True``) and
  its input unchanged, and redoes the rest; changing a parameter invalidates every record;
* **failure isolation**: a mesh that cannot be read or voxelized is recorded ``failed``
  with its error and the batch goes on; a mesh whose memory estimate exceeds what a
  worker has is ``refused`` before anything is allocated; a task over ``timeout`` seconds
  ends its worker process (the kernel cannot be interrupted mid-call) and is recorded
  ``failed``; a worker that dies (crash, out-of-memory kill) while a mesh runs is
  restarted by its nanny and the mesh retried at most ``retries`` times, then recorded
  ``failed``, never dropped;
* **memory-aware scheduling**: every task holds ``reserve`` bytes of the workers'
  ``MEMORY`` resource; a mesh whose estimate (the bound ``volga voxelize`` checks) is
  larger is handed back and resubmitted holding its estimate, so a worker never runs more
  than fits;
* **progress** on stderr (and the dashboard's address) and a summary at the end.
"""

from __future__ import annotations

import argparse
import contextlib
import glob as _glob
import hashlib
import io
import itertools
import json
import os
import sys
import tempfile
import threading
import time
import uuid
import zipfile
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import __version__

__all__ = ["run", "main", "read_status", "MODES"]

MODES = ("surface", "solid", "anti_aliased", "distance", "samples")
STATUS = "status.jsonl"
WORK = ".volga-batch"
MESH_SUFFIXES = (".obj", ".gltf", ".glb")
DEFAULT_RESERVE = 256 << 20
# Fewest tasks a run keeps in flight (see `run`).
_MIN_WINDOW = 256


# ----------------------------------------------------------------------------- paths


def _is_url(s: str) -> bool:
    return "://" in s


def _fs(path: str) -> Tuple[Any, str]:
    """An fsspec filesystem and the path within it (local paths without fsspec)."""
    if not _is_url(path):
        return None, os.path.abspath(path)
    import fsspec

    fs, p = fsspec.core.url_to_fs(path)
    return fs, p


def _join(root: str, *parts: str) -> str:
    return "/".join([root.rstrip("/")] + [p.strip("/") for p in parts])


def _exists(path: str) -> bool:
    fs, p = _fs(path)
    return fs.exists(p) if fs else os.path.exists(p)


def _size(path: str) -> Optional[int]:
    fs, p = _fs(path)
    try:
        return int(fs.info(p)["size"]) if fs else os.path.getsize(p)
    except (OSError, FileNotFoundError, KeyError):
        return None


def _read_bytes(path: str) -> bytes:
    fs, p = _fs(path)
    if fs:
        with fs.open(p, "rb") as f:
            return f.read()
    with open(p, "rb") as f:
        return f.read()


def _write_atomic(path: str, data: bytes, tmp_dir: Optional[str] = None) -> None:
    """Writes ``data`` to ``path`` under a temporary name (in ``tmp_dir``, on the same file
    system, or beside ``path``), then renames it into place."""
    fs, p = _fs(path)
    if tmp_dir is not None:
        _, t = _fs(tmp_dir)
        if fs:
            fs.makedirs(t, exist_ok=True)
        else:
            os.makedirs(t, exist_ok=True)
        tmp = f"{t}/{uuid.uuid4().hex}.tmp"
    else:
        tmp = f"{p}.tmp-{uuid.uuid4().hex}"
    if fs:
        fs.makedirs(os.path.dirname(p) or "/", exist_ok=True)
        with fs.open(tmp, "wb") as f:
            f.write(data)
        fs.mv(tmp, p)
        return
    os.makedirs(os.path.dirname(p), exist_ok=True)
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, p)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


# -------------------------------------------------------------------------- manifest


def manifest(meshes: Union[str, os.PathLike, Iterable[str]]) -> List[str]:
    """The mesh paths or URLs of ``meshes``: a list, a text file (one per line, ``#``
    comments) or a glob pattern (``*``, ``?``, ``[``; local or fsspec), in a fixed order,
    without repeats."""
    if isinstance(meshes, (str, os.PathLike)):
        s = os.fspath(meshes)
        if any(c in s for c in "*?["):
            if _is_url(s):
                import fsspec

                fs, p = fsspec.core.url_to_fs(s)
                proto = s.split("://", 1)[0]
                items = [f"{proto}://{q}" for q in sorted(fs.glob(p))]
            else:
                items = sorted(_glob.glob(s, recursive=True))
            items = [i for i in items if i.lower().endswith(MESH_SUFFIXES)]
        elif s.lower().endswith(MESH_SUFFIXES):
            items = [s]
        else:
            text = _read_bytes(s).decode("utf-8")
            base = os.path.dirname(os.path.abspath(s)) if not _is_url(s) else None
            items = []
            for line in text.splitlines():
                line = line.strip()
                if not line or line.startswith("#"):
                    continue
                if base and not _is_url(line) and not os.path.isabs(line):
                    line = os.path.join(base, line)
                items.append(line)
    else:
        items = [os.fspath(m) for m in meshes]
    seen = set()
    out = []
    for i in items:
        if i not in seen:
            seen.add(i)
            out.append(i)
    return out


def _output_names(items: Sequence[str]) -> Dict[str, str]:
    """Each mesh's output name: its path relative to the meshes' common folder, without
    the extension (``chairs/1a2b/model``); names two meshes would share get a hash suffix."""
    paths = [i.split("://", 1)[-1] if _is_url(i) else os.path.abspath(i) for i in items]
    dirs = [os.path.dirname(p) for p in paths]
    common = os.path.commonpath(dirs) if dirs else ""
    names = {}
    for item, p in zip(items, paths):
        rel = os.path.relpath(p, common) if common else os.path.basename(p)
        names[item] = os.path.splitext(rel)[0].replace(os.sep, "/")
    counts: Dict[str, int] = {}
    for n in names.values():
        counts[n] = counts.get(n, 0) + 1
    for item, n in names.items():
        if counts[n] > 1:
            names[item] = f"{n}-{hashlib.sha1(item.encode()).hexdigest()[:10]}"
    return names


# ------------------------------------------------------------------------ parameters


def _parameters(mode: str, resolution: int, options: Dict[str, Any], samples: int, validate: bool,
                seed: int) -> Dict[str, Any]:
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    if not (isinstance(resolution, int) and 1 <= resolution <= 65536):
        raise ValueError(f"resolution must be an integer in 1..=65536, got {resolution!r}")
    params: Dict[str, Any] = {"mode": mode, "volga_version": __version__}
    if mode == "samples":
        if not (isinstance(samples, int) and 1 <= samples <= 100_000_000):
            raise ValueError(f"samples must be an integer in 1..=100000000, got {samples!r}")
        params.update(samples=samples, seed=int(seed))
        return params
    params.update(resolution=resolution, validate=bool(validate))
    params.update({k: v for k, v in options.items() if v is not None})
    return params


def _params_hash(params: Dict[str, Any]) -> str:
    return _sha256(json.dumps(params, sort_keys=True).encode())[:16]


# ----------------------------------------------------------------------------- files


def _npz(arrays: Dict[str, np.ndarray]) -> bytes:
    """An ``.npz`` (``numpy.load`` reads it) whose bytes depend on the arrays only (no
    timestamps), uncompressed members in a deflated zip."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for name, arr in arrays.items():
            info = zipfile.ZipInfo(name + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(arr), allow_pickle=False)
            z.writestr(info, member.getvalue())
    return buf.getvalue()


def read_status(out: str) -> Dict[str, Dict[str, Any]]:
    """The latest record of every mesh in ``out``'s ``status.jsonl`` (a line cut short by a
    crash is skipped)."""
    path = _join(os.fspath(out), STATUS)
    if not _exists(path):
        return {}
    latest: Dict[str, Dict[str, Any]] = {}
    for line in _read_bytes(path).decode("utf-8", errors="replace").splitlines():
        try:
            rec = json.loads(line)
        except ValueError:
            continue
        if isinstance(rec, dict) and "mesh" in rec:
            latest[rec["mesh"]] = rec
    return latest


def _complete(rec: Dict[str, Any], phash: str, mesh: str, verify: bool) -> bool:
    """Whether ``rec`` says ``mesh`` is done for these parameters and its files agree."""
    if rec.get("status") != "done" or rec.get("params_hash") != phash:
        return False
    size = rec.get("input", {}).get("bytes")
    if size is None or _size(mesh) != size:
        return False
    if verify and _sha256(_read_bytes(mesh)) != rec["input"].get("sha256"):
        return False
    for o in rec.get("outputs", []):
        if _size(o["path"]) != o["bytes"]:
            return False
        if verify and _sha256(_read_bytes(o["path"])) != o["sha256"]:
            return False
    return True


# ------------------------------------------------------------------------ the task


def _peak_reset() -> None:
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def _peak_rss() -> Optional[int]:
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    except (ImportError, OSError):
        return None


def _markers(work: str) -> List[str]:
    fs, p = _fs(work)
    try:
        if fs:
            return [os.path.basename(q) for q in fs.ls(p, detail=False)]
        return os.listdir(p)
    except (OSError, FileNotFoundError):
        return []


def _touch(path: str, text: str = "") -> None:
    _write_atomic(path, text.encode())


def _remove(path: str) -> None:
    fs, p = _fs(path)
    try:
        if fs:
            fs.rm(p)
        else:
            os.remove(p)
    except (OSError, FileNotFoundError):
        pass


def _load(mesh: str, data: bytes) -> Any:
    from . import load_mesh

    if not _is_url(mesh):
        return load_mesh(mesh)
    suffix = os.path.splitext(mesh.split("?", 1)[0])[1] or ".obj"
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "mesh" + suffix)
        with open(p, "wb") as f:
            f.write(data)
        return load_mesh(p)


def _samples(mesh: Any, count: int, seed: int, data_hash: str) -> Dict[str, np.ndarray]:
    """DeepSDF-style samples (as examples/python/dataset.py): 10 of every 11 on the surface
    (uniform by area) moved by a Gaussian of 0.005 or 0.0005 of the box's diagonal, the rest
    uniform in the box padded by 5 %; signed distances with proven signs."""
    from . import signed_distance

    rng = np.random.default_rng([seed, int(data_hash[:15], 16)])
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces)
    lo, hi = v.min(axis=0), v.max(axis=0)
    diag = float(np.linalg.norm(hi - lo)) or 1.0
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    near = count * 10 // 11
    if area.sum() > 0:
        tri = rng.choice(len(f), size=near, p=area / area.sum())
        r1, r2 = rng.random(near), rng.random(near)
        s = np.sqrt(r1)
        p = (1 - s)[:, None] * a[tri] + (s * (1 - r2))[:, None] * b[tri] + (s * r2)[:, None] * c[tri]
        sigma = np.where(rng.random(near) < 0.5, 5e-3, 5e-4) * diag
        p = p + rng.normal(size=(near, 3)) * sigma[:, None]
    else:
        p = np.empty((0, 3))
    pad = 0.05 * (hi - lo) + 1e-9
    u = lo - pad + rng.random((count - len(p), 3)) * (hi - lo + 2 * pad)
    # The distances are those of the stored (float32) points.
    points = np.concatenate([p, u]).astype(np.float32)
    d = signed_distance(mesh, points.astype(np.float64), threads=1)
    return {"points": points, "sdf": d.astype(np.float32)}


def _process(mesh: str, out_name: str, out_root: str, params: Dict[str, Any], phash: str,
             admitted: int, budget: Optional[int], timeout: Optional[float], retries: int,
             layout: str) -> Dict[str, Any]:
    """One mesh, on a worker: the record the client appends to ``status.jsonl``, or
    ``{"status": "needs", "bytes": n}`` when the mesh needs more memory than ``admitted``."""
    from . import VoxelJob, validate as _validate

    key = hashlib.sha1(mesh.encode()).hexdigest()[:16]
    work = _join(out_root, WORK, phash, key)
    record: Dict[str, Any] = {
        "mesh": mesh, "status": "failed", "error": None, "outputs": [], "params_hash": phash,
        "parameters": params, "input": {}, "time_s": 0.0, "peak_rss_bytes": None,
        "estimate_bytes": None, "sign": None, "validator": None,
    }
    marks = _markers(work)
    if "timeout" in marks:
        record["error"] = f"timed out after {timeout} s (the worker running it was ended)"
        return record
    died = sum(1 for m in marks if m.startswith("start-"))
    if died > retries:
        record["error"] = (f"the worker process died {died} times while this mesh ran "
                           f"(killed for memory, or crashed); not retried again")
        return record
    start_mark = _join(work, f"start-{uuid.uuid4().hex}")
    _touch(start_mark)
    watchdog = None
    if timeout:
        def expire() -> None:
            _touch(_join(work, "timeout"))
            os._exit(75)

        watchdog = threading.Timer(timeout, expire)
        watchdog.daemon = True
        watchdog.start()
    t0 = time.perf_counter()
    _peak_reset()
    try:
        data = _read_bytes(mesh)
        record["input"] = {"sha256": _sha256(data), "bytes": len(data)}
        m = _load(mesh, data)
        arrays: Dict[str, np.ndarray]
        if params["mode"] == "samples":
            arrays = _samples(m, params["samples"], params["seed"], record["input"]["sha256"])
        else:
            options = {k: params[k] for k in ("resolution", "separability", "band", "thickness", "solid",
                                               "signed") if k in params}
            job = VoxelJob(m, mode=params["mode"], **options)
            need = int(job.estimate())
            record["estimate_bytes"] = need
            if budget is not None and need > budget:
                record["status"] = "refused"
                record["error"] = (f"voxelizing needs an estimated {need} bytes, more than a worker's "
                                   f"{budget} (MEMORY resource or memory limit)")
                return record
            if need > admitted:
                return {"status": "needs", "bytes": need}
            grid = job.run_region(None, memory_limit=admitted, threads=1)
            record["sign"] = grid.stats.get("sign")
            if params.get("validate") and grid.kind == "binary":
                sep = int(params.get("separability", 26))
                report = _validate(grid, connectivity=sep, mesh=m, require=["separating"], listed=4, threads=1)
                record["validator"] = {"passed": bool(report.get("passed")), "connectivity": sep,
                                       "require": ["separating"]}
                if not report.get("passed"):
                    record["error"] = f"validator: {sep}-tunnels through the mesh (the voxels are not {sep}-separating)"
                    return record
            t = np.asarray(grid.transform)
            arrays = {"shape": np.asarray(grid.shape, dtype=np.int64), "transform": t,
                      "background": np.asarray(grid.background, dtype=np.float32)}
            if layout == "dense":
                arrays["grid"] = np.asarray(grid.dense())
            else:
                arrays["indices"] = np.asarray(grid.sparse_indices, dtype=np.int32)
                arrays["values"] = np.asarray(grid.values)
        blob = _npz(arrays)
        path = _join(out_root, out_name + ".npz")
        _write_atomic(path, blob, tmp_dir=_join(out_root, WORK, "tmp"))
        record["outputs"] = [{"path": path, "bytes": len(blob), "sha256": _sha256(blob)}]
        record["status"] = "done"
    except MemoryError as e:
        record["status"] = "refused"
        record["error"] = f"MemoryError: {e}"
    except Exception as e:  # every error of one mesh is that mesh's record
        record["error"] = f"{type(e).__name__}: {e}"
    finally:
        if watchdog is not None:
            watchdog.cancel()
        record["time_s"] = round(time.perf_counter() - t0, 6)
        record["peak_rss_bytes"] = _peak_rss()
        _remove(start_mark)
    return record


# ----------------------------------------------------------------------------- client


def _workers(client: Any) -> Dict[str, Any]:
    """Every worker's info (``scheduler_info`` lists only some by default in newer
    releases, and takes no ``n_workers`` in older ones)."""
    try:
        info = client.scheduler_info(n_workers=-1)
    except TypeError:
        info = client.scheduler_info()
    return info.get("workers", {})


def _memory_budget(client: Any) -> Tuple[Optional[int], bool]:
    """The memory one task may have (bytes), and whether the workers declare ``MEMORY``."""
    workers = _workers(client)
    declared = [w.get("resources", {}).get("MEMORY") for w in workers.values()]
    if workers and all(d is not None for d in declared):
        return int(min(declared)), True
    limits = [w.get("memory_limit") for w in workers.values() if w.get("memory_limit")]
    return (int(min(limits)) if limits else None), False


def run(
    meshes: Union[str, os.PathLike, Iterable[str]],
    out: Union[str, os.PathLike],
    *,
    mode: str = "solid",
    resolution: int = 64,
    separability: Optional[int] = None,
    band: Optional[float] = None,
    thickness: Optional[float] = None,
    solid: Optional[bool] = None,
    signed: Optional[bool] = None,
    samples: int = 250_000,
    seed: int = 0,
    validate: bool = True,
    layout: str = "sparse",
    client: Any = None,
    n_workers: Optional[int] = None,
    worker_memory: Optional[int] = None,
    reserve: int = DEFAULT_RESERVE,
    timeout: Optional[float] = None,
    retries: int = 2,
    verify: bool = False,
    progress: bool = True,
) -> Dict[str, Any]:
    """Voxelizes (or samples) every mesh of ``meshes`` into ``out`` on a Dask cluster;
    returns the summary (also printed with ``progress``).

    ``meshes``: a list, a text file of paths or URLs, or a glob. ``out``: a folder or an
    fsspec URL. ``mode``: ``surface``, ``solid`` (binary, checked by the topology validator
    with ``validate``), ``anti_aliased``, ``distance`` (``volga.voxelize``'s modes and
    options, ``resolution`` voxels along the longest side), or ``samples``: ``samples``
    signed-distance samples per mesh (half near the surface, half in the box; seeded by
    ``seed`` and the mesh's bytes). Outputs are ``out/<name>.npz``: ``indices`` (K, 3)
    int32 and ``values`` of the voxels that differ from ``background`` (``layout="dense"``:
    ``grid``, the whole ``[i, j, k]`` array), with ``shape`` and ``transform``; or
    ``points`` and ``sdf``.

    ``client``: a ``distributed.Client``; without one, a local cluster of ``n_workers``
    processes (default: the cores) with one thread and ``worker_memory`` bytes each (default:
    the machine's memory shared between them), declared as their ``MEMORY`` resource.
    """
    if layout not in ("sparse", "dense"):
        raise ValueError(f"layout must be \"sparse\" or \"dense\", got {layout!r}")
    if not (isinstance(retries, int) and 0 <= retries <= 100):
        raise ValueError(f"retries must be an integer in 0..=100, got {retries!r}")
    if timeout is not None and not (timeout > 0):
        raise ValueError(f"timeout must be > 0 seconds, got {timeout!r}")
    if not (isinstance(reserve, int) and reserve > 0):
        raise ValueError(f"reserve must be a positive number of bytes, got {reserve!r}")
    options = {"separability": separability, "band": band, "thickness": thickness, "solid": solid,
               "signed": signed}
    params = _parameters(mode, resolution, options, samples, validate, seed)
    phash = _params_hash(params)
    if mode != "samples":
        # Options the mode would refuse are refused here, once, not once per mesh.
        from . import VoxelJob, Mesh

        tiny = Mesh(np.eye(3), np.array([[0, 1, 2]]))
        VoxelJob(tiny, resolution=4, mode=mode, **{k: v for k, v in options.items() if v is not None})
    items = manifest(meshes)
    out = os.fspath(out)
    out_root = out if _is_url(out) else os.path.abspath(out)
    names = _output_names(items)
    status_path = _join(out_root, STATUS)
    t0 = time.perf_counter()
    # Temporary files a killed run left behind (outputs are renamed out of this folder).
    tmp_fs, tmp_local = _fs(_join(out_root, WORK, "tmp"))
    if tmp_fs is not None:
        if tmp_fs.exists(tmp_local):
            tmp_fs.rm(tmp_local, recursive=True)
    elif os.path.isdir(tmp_local):
        import shutil

        shutil.rmtree(tmp_local, ignore_errors=True)
    latest = read_status(out_root)
    todo = [m for m in items if not (m in latest and _complete(latest[m], phash, m, verify))]
    skipped = len(items) - len(todo)

    own = None
    if client is None:
        import dask
        from distributed import Client, LocalCluster

        n = n_workers or os.cpu_count() or 1
        if worker_memory is None:
            from distributed.system import MEMORY_LIMIT

            worker_memory = int(MEMORY_LIMIT // n)
        with dask.config.set({"distributed.scheduler.allowed-failures": retries + 2}):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   memory_limit=worker_memory, resources={"MEMORY": worker_memory},
                                   dashboard_address=":0" if progress else None)
        client = Client(cluster)
        own = (client, cluster)
    with contextlib.ExitStack() as stack:
        if own:
            stack.callback(own[1].close)
            stack.callback(own[0].close)
        budget, declared = _memory_budget(client)
        if progress and getattr(client, "dashboard_link", None):
            print(f"volga-batch: dashboard {client.dashboard_link}", file=sys.stderr)
        counts = {"done": 0, "failed": 0, "refused": 0}
        from distributed import as_completed

        def submit(mesh: str, admitted: int) -> Any:
            fut = client.submit(
                _process, mesh, names[mesh], out_root, params, phash, admitted, budget, timeout, retries,
                layout, key=f"volga-batch-{hashlib.sha1(mesh.encode()).hexdigest()[:16]}-{admitted}-{phash}",
                resources={"MEMORY": admitted} if declared else None, pure=False,
            )
            fut.volga_mesh = mesh
            return fut

        first = min(reserve, budget) if budget else reserve
        # At most `window` tasks in flight: the scheduler holds a few KB per task, so a
        # million meshes are fed as the earlier ones finish, not submitted at once.
        threads = sum(w.get("nthreads", 1) for w in _workers(client).values())
        window = max(_MIN_WINDOW, 8 * threads)
        queue = iter(todo)
        pending = as_completed([submit(m, first) for m in itertools.islice(queue, window)])
        status_fs, status_local = _fs(status_path)
        if status_fs is None:
            os.makedirs(os.path.dirname(status_local), exist_ok=True)
            status = open(status_local, "a")
        else:
            status = status_fs.open(status_local, "a")
        stack.callback(status.close)
        if status_fs is None:
            stack.callback(lambda: (status.flush(), os.fsync(status.fileno())))  # runs before the close
        last = synced = 0.0
        finished = 0
        for fut in pending:
            mesh = fut.volga_mesh
            try:
                rec = fut.result()
            except Exception as e:  # KilledWorker and the like: recorded, never dropped
                rec = {"mesh": mesh, "status": "failed", "error": f"{type(e).__name__}: {e}",
                       "outputs": [], "params_hash": phash, "parameters": params}
            if rec.get("status") == "needs":
                pending.add(submit(mesh, int(rec["bytes"])))
                continue
            following = next(queue, None)
            if following is not None:
                pending.add(submit(following, first))
            # Each record reaches the operating system at once (a killed client loses none);
            # the disk is synced at most once a second (a power loss costs a redo, no more).
            status.write(json.dumps(rec, sort_keys=True) + "\n")
            status.flush()
            counts[rec["status"]] = counts.get(rec["status"], 0) + 1
            finished += 1
            now = time.perf_counter()
            if status_fs is None and now - synced > 1.0:
                os.fsync(status.fileno())
                synced = now
            if progress and (now - last > 1.0 or finished == len(todo)):
                last = now
                print(f"volga-batch: {finished}/{len(todo)} ({counts['done']} done, {counts['failed']} failed, "
                      f"{counts['refused']} refused), {finished / max(now - t0, 1e-9):.1f} meshes/s",
                      file=sys.stderr)
    elapsed = time.perf_counter() - t0
    summary = {
        "meshes": len(items), "skipped": skipped, "processed": len(todo), **counts,
        "time_s": round(elapsed, 3), "meshes_per_s": round(len(todo) / elapsed, 3) if elapsed > 0 else None,
        "status": status_path, "params_hash": phash,
    }
    if progress:
        print("volga-batch: " + json.dumps(summary), file=sys.stderr)
    return summary


def _bytes(text: str) -> int:
    units = {"k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}
    t = text.strip().lower().rstrip("ib").rstrip("b")
    if t and t[-1] in units:
        return int(float(t[:-1]) * units[t[-1]])
    return int(t)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``volga-batch MESHES OUT [options]``: exit 0 when every mesh is done or skipped, 1 when
    some failed or were refused, 2 for bad arguments."""
    p = argparse.ArgumentParser(prog="volga-batch", description=__doc__.split("\n\n")[0])
    p.add_argument("meshes", help="a text file of mesh paths or URLs, a glob, or one mesh")
    p.add_argument("out", help="output folder or fsspec URL (status.jsonl and <name>.npz)")
    p.add_argument("--mode", default="solid", choices=MODES)
    p.add_argument("--resolution", type=int, default=64)
    p.add_argument("--separability", type=int)
    p.add_argument("--band", type=float)
    p.add_argument("--thickness", type=float)
    p.add_argument("--solid", action="store_true", default=None)
    p.add_argument("--unsigned", action="store_true")
    p.add_argument("--samples", type=int, default=250_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-validate", action="store_true")
    p.add_argument("--layout", default="sparse", choices=("sparse", "dense"))
    p.add_argument("--scheduler", help="address of a running Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster: worker processes (default: the cores)")
    p.add_argument("--worker-memory", type=_bytes, help="local cluster: bytes per worker (e.g. 4GiB)")
    p.add_argument("--reserve", type=_bytes, default=DEFAULT_RESERVE)
    p.add_argument("--timeout", type=float, help="seconds per mesh")
    p.add_argument("--retries", type=int, default=2)
    p.add_argument("--verify", action="store_true", help="resume: re-hash inputs and outputs")
    p.add_argument("--quiet", action="store_true")
    a = p.parse_args(argv)
    client = None
    try:
        if a.scheduler:
            from distributed import Client

            client = Client(a.scheduler)
        summary = run(
            a.meshes, a.out, mode=a.mode, resolution=a.resolution, separability=a.separability, band=a.band,
            thickness=a.thickness, solid=a.solid, signed=False if a.unsigned else None, samples=a.samples,
            seed=a.seed, validate=not a.no_validate, layout=a.layout, client=client, n_workers=a.workers,
            worker_memory=a.worker_memory, reserve=a.reserve, timeout=a.timeout, retries=a.retries,
            verify=a.verify, progress=not a.quiet,
        )
    except (ValueError, OSError) as e:
        print(f"volga-batch: {e}", file=sys.stderr)
        return 2
    finally:
        if client is not None:
            client.close()
    print(json.dumps(summary))
    return 0 if summary["failed"] == 0 and summary["refused"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
