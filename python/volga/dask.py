"""Grids larger than one machine's memory, on Dask: ``voxelize_array`` and ``write_zarr``.

Needs the ``dask`` extra (``pip install 'volga[dask]'``: dask, distributed and zarr).

A chunk of the grid is computed by the kernel on its own, **bit for bit** the same voxels
as the whole-grid result (``volga.voxelize(..., region=...)``): binary, anti-aliased and
distance modes, with every sign proven. Chunks are independent tasks, so the grid is built
on as many workers as there are, each holding one prepared mesh and the chunks it is
working on, never the whole grid.

Each worker process prepares a mesh (BVH, feature regions, sign oracle) once and keeps it
for the chunks that follow (a cache of the last few meshes per process), so the
preparation is paid once per worker, not once per chunk.

Example
-------
>>> from dask.distributed import Client                          # doctest: +SKIP
>>> import volga.dask                                            # doctest: +SKIP
>>> client = Client(n_workers=2, threads_per_worker=1, memory_limit="2GiB")  # doctest: +SKIP
>>> volga.dask.write_zarr("bunny.obj", "bunny.zarr", resolution=2048,       # doctest: +SKIP
...                       mode="distance", chunks=256)
"""

from __future__ import annotations

import hashlib
import os
import threading
from collections import OrderedDict
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import Mesh, VoxelJob, __version__, load_mesh

__all__ = ["voxelize_array", "bake_array", "write_zarr", "grid_attributes"]

# Meshes prepared in this process, by token (most recently used last).
_JOBS: "OrderedDict[str, VoxelJob]" = OrderedDict()
_JOBS_LOCK = threading.Lock()
_MAX_JOBS = 4


def _require_dask() -> Any:
    try:
        import dask.array as da
    except ImportError as e:  # pragma: no cover - exercised only without the extra
        raise ImportError("volga.dask needs Dask: pip install 'volga[dask]'") from e
    return da


def _mesh_spec(mesh: Any) -> Tuple[Dict[str, Any], Mesh]:
    """What a worker needs to load ``mesh`` again, with a token naming it, and the mesh."""
    if isinstance(mesh, (str, os.PathLike)):
        path = os.path.abspath(os.fspath(mesh))
        st = os.stat(path)
        token = f"path:{path}:{st.st_size}:{st.st_mtime_ns}"
        return {"path": path, "token": token}, load_mesh(path)
    from . import _as_mesh

    m = _as_mesh(mesh)
    vertices = np.ascontiguousarray(m.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(m.faces, dtype=np.int64)
    h = hashlib.sha256(vertices.tobytes())
    h.update(faces.tobytes())
    return {"vertices": vertices, "faces": faces, "token": "arrays:" + h.hexdigest()}, m


def _cached(cache: "OrderedDict[str, Any]", key: str, make: Any) -> Any:
    """``cache[key]``, made by ``make()`` on first use; the least recently used entries
    beyond ``_MAX_JOBS`` are dropped."""
    with _JOBS_LOCK:
        value = cache.get(key)
        if value is not None:
            cache.move_to_end(key)
            return value
    value = make()
    with _JOBS_LOCK:
        cache[key] = value
        while len(cache) > _MAX_JOBS:
            cache.popitem(last=False)
    return value


def _job(spec: Dict[str, Any], options: Dict[str, Any], threads: Optional[int]) -> VoxelJob:
    """This process's prepared job for ``spec`` and ``options`` (made on first use)."""

    def make() -> VoxelJob:
        mesh = load_mesh(spec["path"]) if "path" in spec else Mesh(spec["vertices"], spec["faces"])
        job = VoxelJob(mesh, **options)
        job.prepare(threads=threads)
        return job

    return _cached(_JOBS, spec["token"] + repr(sorted(options.items())), make)


def _chunk(spec: Dict[str, Any], options: Dict[str, Any], threads: Optional[int],
           memory_limit: Optional[int], lo: Tuple[int, int, int], hi: Tuple[int, int, int]) -> np.ndarray:
    job = _job(spec, options, threads)
    grid = job.run_region((lo, hi), memory_limit=memory_limit, threads=threads)
    return np.ascontiguousarray(grid.dense(memory_limit=memory_limit))


def _chunked(name: str, spec: Dict[str, Any], chunks: Tuple[Tuple[int, ...], ...], dtype: np.dtype,
             task: Any) -> Any:
    """A dask array ``name`` of ``chunks``, chunk ``(i, j, k)`` computed by the task
    ``task(spec_key, lo, hi)`` for its voxels ``lo ≤ ijk < hi``; ``spec`` (the mesh or
    scene) goes into the graph once, under its own key."""
    da = _require_dask()
    from dask.highlevelgraph import HighLevelGraph

    spec_key = name + "-spec"
    layer: Dict[Any, Any] = {spec_key: spec}
    starts = [np.concatenate([[0], np.cumsum(c)]).astype(int) for c in chunks]
    for i in range(len(chunks[0])):
        for j in range(len(chunks[1])):
            for k in range(len(chunks[2])):
                lo = (int(starts[0][i]), int(starts[1][j]), int(starts[2][k]))
                hi = (int(starts[0][i + 1]), int(starts[1][j + 1]), int(starts[2][k + 1]))
                layer[(name, i, j, k)] = task(spec_key, lo, hi)
    graph = HighLevelGraph.from_collections(name, layer, dependencies=[])
    return da.Array(graph, name, chunks, dtype=dtype, meta=np.empty((0, 0, 0), dtype=dtype))


def _options(resolution: Optional[int], pitch: Optional[float], bounds: Any, mode: str,
             separability: Optional[int], band: Optional[float], thickness: Optional[float],
             solid: Optional[bool], signed: Optional[bool]) -> Dict[str, Any]:
    options: Dict[str, Any] = {"resolution": resolution, "pitch": pitch, "mode": mode}
    if bounds is not None:
        b = np.asarray(bounds, dtype=np.float64)
        options["bounds"] = tuple(map(tuple, b.tolist()))
    for name, value in [("separability", separability), ("band", band), ("thickness", thickness),
                        ("solid", solid), ("signed", signed)]:
        if value is not None:
            options[name] = value
    return options


def grid_attributes(job: VoxelJob, mesh_token: str = "") -> Dict[str, Any]:
    """The attributes ``write_zarr`` stores beside the array: the transform (index ``[i, j, k]``
    to world at voxel centres), pitch, shape, what the values are and the background."""
    t = np.asarray(job.transform)
    return {
        "transform": t.tolist(),
        "origin": t[:3, 3].tolist(),
        "pitch": job.pitch,
        "shape": list(job.shape),
        "axes": ["x", "y", "z"],
        "mode": job.mode,
        "kind": job.kind,
        "background": float(job.background),
        "mesh": mesh_token,
        "volga_version": __version__,
    }


def voxelize_array(
    mesh: Any,
    resolution: Optional[int] = None,
    *,
    chunks: Union[int, Sequence[int]] = 128,
    mode: str = "distance",
    pitch: Optional[float] = None,
    bounds: Any = None,
    separability: Optional[int] = None,
    band: Optional[float] = None,
    thickness: Optional[float] = None,
    solid: Optional[bool] = None,
    signed: Optional[bool] = None,
    threads: Optional[int] = 1,
    memory_limit: Optional[int] = None,
) -> Any:
    """A lazy ``dask.array`` of the grid ``volga.voxelize(mesh, ...)`` would make, indexed
    ``[i, j, k]`` (bool for binary modes, float32 otherwise), one task per chunk.

    ``mesh`` is a path (each worker loads it; it must be readable there) or anything
    ``volga.voxelize`` takes (its vertices and faces go into the graph once). The grid
    options are ``volga.voxelize``'s. ``chunks`` is a chunk edge (voxels) or a shape per
    axis; a multiple of 8 keeps chunk borders on the kernel's bricks (any shape gives the
    same values). ``threads`` is the kernel's threads per task (default 1: one task per
    worker thread); ``memory_limit`` refuses a chunk over that many bytes (``MemoryError``
    inside the task) before it is computed. The transform is ``volga.VoxelJob(...).transform``
    (``write_zarr`` stores it with the array).
    """
    da = _require_dask()
    from dask.base import tokenize

    spec, m = _mesh_spec(mesh)
    options = _options(resolution, pitch, bounds, mode, separability, band, thickness, solid, signed)
    job = VoxelJob(m, **options)  # checks every option here, before any task runs
    shape = job.shape
    dtype = np.dtype(bool) if job.kind == "binary" else np.dtype(np.float32)
    chunks = da.core.normalize_chunks(chunks, shape=shape, dtype=dtype)
    if memory_limit is not None:
        biggest = tuple(max(c) for c in chunks)
        need = job.estimate(((0, 0, 0), biggest)) + int(np.prod(biggest)) * dtype.itemsize
        if need > memory_limit:
            raise MemoryError(
                f"a chunk of {biggest[0]}×{biggest[1]}×{biggest[2]} voxels needs an estimated "
                f"{need} bytes, more than memory_limit={memory_limit}: use smaller chunks"
            )
    token = tokenize(spec["token"], options, chunks, threads, memory_limit)
    return _chunked("volga-voxelize-" + token, spec, chunks, dtype,
                    lambda key, lo, hi: (_chunk, key, options, threads, memory_limit, lo, hi))


_SCENES: "OrderedDict[str, Any]" = OrderedDict()


def _scene_job(spec: Dict[str, Any]) -> Any:
    """This process's resolved scene for ``spec`` (made on first use)."""
    from . import SceneJob

    return _cached(_SCENES, spec["token"], lambda: SceneJob(
        spec["scene"], base_dir=spec.get("base_dir"), allow_outside_paths=spec["allow_outside_paths"]))


def _scene_chunk(spec: Dict[str, Any], threads: Optional[int], memory_limit: Optional[int],
                 lo: Tuple[int, int, int], hi: Tuple[int, int, int]) -> np.ndarray:
    grid = _scene_job(spec).bake((lo, hi), memory_limit=memory_limit, threads=threads)
    return np.ascontiguousarray(grid.dense(memory_limit=memory_limit))


def bake_array(
    scene: Any,
    *,
    chunks: Union[int, Sequence[int]] = 128,
    base_dir: Any = None,
    allow_outside_paths: bool = False,
    threads: Optional[int] = 1,
    memory_limit: Optional[int] = None,
) -> Any:
    """A lazy ``dask.array`` (float32, ``[i, j, k]``) of a scene's baked density, one task
    per chunk, each chunk bit for bit the whole bake's voxels (``volga.SceneJob.bake``).
    ``scene`` is a scene file (each worker reads it and the files it names, which must be
    readable there) or a dict; each worker process resolves it once and keeps it."""
    da = _require_dask()
    from dask.base import tokenize
    from . import SceneJob

    job = SceneJob(scene, base_dir=base_dir, allow_outside_paths=allow_outside_paths)
    if isinstance(scene, dict):
        token = "dict:" + hashlib.sha256(repr(sorted(scene.items())).encode()).hexdigest()
    else:
        path = os.path.abspath(os.fspath(scene))
        st = os.stat(path)
        scene = path
        token = f"path:{path}:{st.st_size}:{st.st_mtime_ns}"
    spec = {"scene": scene, "base_dir": None if base_dir is None else os.fspath(base_dir),
            "allow_outside_paths": allow_outside_paths, "token": token}
    shape = job.shape
    dtype = np.dtype(np.float32)
    chunks = da.core.normalize_chunks(chunks, shape=shape, dtype=dtype)
    return _chunked("volga-bake-" + tokenize(token, chunks, threads, memory_limit), spec, chunks, dtype,
                    lambda key, lo, hi: (_scene_chunk, key, threads, memory_limit, lo, hi))


def write_zarr(
    mesh: Any,
    store: Any,
    resolution: Optional[int] = None,
    *,
    chunks: Union[int, Sequence[int]] = 128,
    mode: str = "distance",
    multiscale: int = 0,
    pitch: Optional[float] = None,
    bounds: Any = None,
    separability: Optional[int] = None,
    band: Optional[float] = None,
    thickness: Optional[float] = None,
    solid: Optional[bool] = None,
    signed: Optional[bool] = None,
    threads: Optional[int] = 1,
    memory_limit: Optional[int] = None,
    compute: bool = True,
) -> Any:
    """Voxelizes ``mesh`` chunk by chunk into a Zarr group at ``store`` (a path, an fsspec
    URL or a zarr store), on the current Dask scheduler (a ``distributed.Client`` if one is
    active). The group holds array ``"0"`` (the grid, one Zarr chunk per task) and, with
    ``multiscale=n``, arrays ``"1"`` … ``"n"``, each half the previous one's resolution
    (mean of 2×2×2 voxels; for binary grids their maximum). Its attributes carry
    ``volga`` (:func:`grid_attributes`: the transform, pitch, mode and background) and an
    OME-Zarr-style ``multiscales`` entry (axes x, y, z in world units; scale and translation
    of each level's voxel centres). Returns the ``zarr.Group``; with ``compute=False``, the
    group and the ``dask`` store task to compute later.
    """
    da = _require_dask()
    import zarr

    spec, m = _mesh_spec(mesh)
    options = _options(resolution, pitch, bounds, mode, separability, band, thickness, solid, signed)
    job = VoxelJob(m, **options)
    array = voxelize_array(mesh if isinstance(mesh, (str, os.PathLike)) else m, chunks=chunks,
                           threads=threads, memory_limit=memory_limit, **options)
    if not (isinstance(multiscale, int) and 0 <= multiscale <= 16):
        raise ValueError(f"multiscale must be an integer in 0..=16, got {multiscale!r}")
    levels = [array]
    for _ in range(multiscale):
        prev = levels[-1]
        reduce = np.max if job.kind == "binary" else np.mean
        coarse = da.coarsen(reduce, prev, {0: 2, 1: 2, 2: 2}, trim_excess=True)
        levels.append(coarse.astype(prev.dtype))
    root = zarr.open_group(store, mode="w")
    attrs = grid_attributes(job, spec["token"])
    pitch_w = attrs["pitch"]
    origin = np.asarray(attrs["origin"])
    datasets = []
    targets = []
    for level, arr in enumerate(levels):
        scale = pitch_w * 2**level
        # Level l's voxel [0,0,0] averages fine voxels 0 .. 2^l − 1: its centre is their mean.
        translation = origin + 0.5 * (2**level - 1) * pitch_w
        fill = False if arr.dtype == bool else float(job.background)
        z = root.create_array(str(level), shape=arr.shape, chunks=tuple(c[0] for c in arr.chunks),
                              dtype=arr.dtype, fill_value=fill)
        datasets.append({
            "path": str(level),
            "coordinateTransformations": [
                {"type": "scale", "scale": [scale] * 3},
                {"type": "translation", "translation": translation.tolist()},
            ],
        })
        targets.append(z)
    root.attrs["volga"] = attrs
    root.attrs["multiscales"] = [{
        "version": "0.4",
        "name": "volga",
        "axes": [{"name": a, "type": "space"} for a in ("x", "y", "z")],
        "datasets": datasets,
    }]
    stored = da.store(levels, targets, lock=False, compute=compute)
    return root if compute else (root, stored)
