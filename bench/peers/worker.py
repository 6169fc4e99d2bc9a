"""Serves one peer's voxelization call on a mesh, timed; one process per (tool, N).

    worker.py {openvdb,open3d,trimesh} MESH N          # serve: the driver says when to call
    worker.py {openvdb,open3d,trimesh} MESH N --once   # load + one call, for peak memory

OpenVDB must run under Debian's /usr/bin/python3 (pyopenvdb is a Debian package, not
a wheel); Open3D and trimesh under the venv. Imports are therefore lazy, per tool.

Serve mode: parse the mesh, make one untimed warm-up call, print a JSON "ready" line,
then answer stdin line by line: `run` makes one call and prints {"t": seconds,
"voxels": n} (only the library call is inside the timer); `dump PATH` writes the last
result (openvdb: .npz of the active voxels with the index->world mapping; open3d,
trimesh: .binvox). The driver interleaves the calls of all tools of a task, so that
load from outside (the two cores are shared) falls on every tool alike.
`--once`: nothing but load + one call, so that `/usr/bin/time -v` around the process
gives the peak memory of load + voxelize (interpreter, library and mesh included).
"""

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import numpy as np  # noqa: E402

from common import load_obj, voxel_size, write_binvox  # noqa: E402

HALF_WIDTH = 3  # narrow band half-width in voxels, task (a) of docs/BENCHMARKS.md


def openvdb_setup(verts, tris, h):
    import pyopenvdb as vdb

    # pyopenvdb wants float32 points and int32 indices; converting them is not part of
    # the voxelization, so it happens once, outside the timer.
    pts = np.ascontiguousarray(verts, np.float32)
    tri = np.ascontiguousarray(tris, np.int32)

    def call():
        return vdb.FloatGrid.createLevelSetFromPolygons(
            pts, triangles=tri, transform=vdb.createLinearTransform(voxelSize=h),
            halfWidth=HALF_WIDTH)

    return call


def openvdb_dump(grid, path):
    # Active voxels via a dense copy of the active bounding box: much faster than
    # iterating 3.7 M voxels in Python. Inactive voxels of a level set hold ±background
    # and active ones |v| < background; the count check below proves that here.
    (lo, hi) = grid.evalActiveVoxelBoundingBox()
    lo, hi = np.array(lo), np.array(hi)
    dense = np.empty(tuple(hi - lo + 1), np.float32)
    grid.copyToArray(dense, ijk=tuple(int(x) for x in lo))
    mask = np.abs(dense) < grid.background
    if int(mask.sum()) != grid.activeVoxelCount():
        # Fall back on the definition: iterate the active values.
        ijk, vals = [], []
        for it in grid.citerOnValues():
            if it.count != 1:
                raise RuntimeError("active tile in a narrow band: unexpected")
            ijk.append(it.min)
            vals.append(it.value)
        ijk = np.array(ijk, np.int64)
        vals = np.array(vals, np.float32)
    else:
        ijk = np.argwhere(mask) + lo
        vals = dense[mask]
    # Index -> world through the grid's own transform; check it is affine-diagonal so
    # that centre0 + ijk*step reproduces indexToWorld for every voxel.
    xf = grid.transform
    c0 = np.array(xf.indexToWorld((0, 0, 0)))
    step = np.array(xf.indexToWorld((1, 1, 1))) - c0
    for probe in (tuple(int(x) for x in lo), tuple(int(x) for x in hi)):
        assert np.allclose(xf.indexToWorld(probe), c0 + np.array(probe) * step, rtol=0, atol=1e-12)
    np.savez(path, ijk=ijk.astype(np.int32), values=vals, centre0=c0, step=step,
             background=np.float64(grid.background))


def open3d_setup(verts, tris, h):
    import open3d as o3d

    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(verts),
                                     o3d.utility.Vector3iVector(tris.astype(np.int32)))

    def call():
        return o3d.geometry.VoxelGrid.create_from_triangle_mesh(mesh, voxel_size=h)

    return call


def open3d_dump(grid, h, path):
    ijk = np.array([v.grid_index for v in grid.get_voxels()], np.int64)
    # Open3D: centre of voxel idx = origin + (idx + ½)·h; checked on one voxel.
    c0 = np.asarray(grid.origin) + 0.5 * h
    assert np.allclose(grid.get_voxel_center_coordinate(ijk[0]), c0 + ijk[0] * h, atol=1e-12)
    write_binvox(path, ijk, c0, h)


def trimesh_setup(verts, tris, h):
    import trimesh

    mesh = trimesh.Trimesh(verts, tris, process=False)

    def call():
        return mesh.voxelized(pitch=h)  # method "subdivide", the default

    return call


def trimesh_dump(grid, h, path):
    m = np.asarray(grid.transform)
    # trimesh: transform maps index -> voxel centre; an axis-aligned uniform scale here.
    assert np.allclose(m[:3, :3], np.eye(3) * h)
    write_binvox(path, np.asarray(grid.sparse_indices), m[:3, 3], h)


def count(tool, grid):
    if tool == "openvdb":
        return int(grid.activeVoxelCount())
    if tool == "open3d":
        return len(grid.get_voxels())
    return int(grid.filled_count)


def version(tool):
    if tool == "openvdb":
        import pyopenvdb as vdb
        return ".".join(map(str, vdb.LIBRARY_VERSION))
    if tool == "open3d":
        import open3d as o3d
        return o3d.__version__
    import trimesh
    return trimesh.__version__


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("tool", choices=["openvdb", "open3d", "trimesh"])
    ap.add_argument("mesh")
    ap.add_argument("n", type=int)
    ap.add_argument("--once", action="store_true")
    a = ap.parse_args()

    verts, tris = load_obj(a.mesh)
    h = voxel_size(verts, a.n)
    call = {"openvdb": openvdb_setup, "open3d": open3d_setup, "trimesh": trimesh_setup}[a.tool](
        verts, tris, h)
    if a.once:
        call()
        return

    grid = call()  # warm-up: page in the library code, fill lazy caches
    print(json.dumps({"ready": True, "tool": a.tool, "version": version(a.tool), "h": h,
                      "threads_available": len(os.sched_getaffinity(0))}), flush=True)
    for line in sys.stdin:
        cmd = line.split(maxsplit=1)
        if not cmd:
            continue
        if cmd[0] == "run":
            grid = None  # free the previous result first, as a fresh call would find it
            t0 = time.perf_counter()
            grid = call()
            t = time.perf_counter() - t0
            print(json.dumps({"t": t, "voxels": count(a.tool, grid)}), flush=True)
        elif cmd[0] == "dump":
            path = cmd[1].strip()
            if a.tool == "openvdb":
                openvdb_dump(grid, path)
            elif a.tool == "open3d":
                open3d_dump(grid, h, path)
            else:
                trimesh_dump(grid, h, path)
            print(json.dumps({"ok": True}), flush=True)
        else:
            raise SystemExit(f"unknown command {cmd[0]!r}")


if __name__ == "__main__":
    main()
