#!/usr/bin/env python3
"""Peers' marching cubes on the NRRD volga wrote, timed; each mesh written as OBJ in world
coordinates for `volga bench extract --score`.

Usage: peers.py VOLUME.nrrd OUTDIR PEER[,PEER...] [REPEAT]
PEER: skimage (scikit-image marching_cubes), mcubes (PyMCubes), openvdb (pyopenvdb
FloatGrid.convertToPolygons at adaptivity 0, 0.1, 0.3). Only the extraction call is timed
(median of REPEAT runs after one warm-up), one JSON line per mesh on stdout.
Called by bench/extract/run.sh; outside CI.
"""
import json
import os
import sys
import time

import numpy as np


def read_nrrd(path):
    header = {}
    with open(path, "rb") as f:
        for raw in f:
            line = raw.decode().strip()
            if not line:
                break
            if line.startswith("#") or ":" not in line:
                continue
            key, value = line.split(":", 1)
            header[key.strip()] = value.strip().lstrip("=").strip()
    sizes = [int(s) for s in header["sizes"].split()]
    dirs = [[float(x) for x in d.strip("()").split(",")] for d in header["space directions"].split()]
    origin = [float(x) for x in header["space origin"].strip("()").split(",")]
    data = os.path.join(os.path.dirname(path), header["data file"])
    nx, ny, nz = sizes
    vol = np.fromfile(data, dtype="<f4").reshape(nz, ny, nx)
    spacing = np.array([dirs[0][0], dirs[1][1], dirs[2][2]])
    return vol, np.array(origin), spacing


def timed(f, repeat):
    out = f()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t)
    times.sort()
    return times[len(times) // 2], out


def write_obj(path, verts, faces):
    with open(path, "w") as f:
        f.write("".join("v %.9g %.9g %.9g\n" % tuple(v) for v in verts))
        f.write("".join("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in faces))


def main():
    nrrd, outdir, peers = sys.argv[1], sys.argv[2], sys.argv[3].split(",")
    repeat = int(sys.argv[4]) if len(sys.argv) > 4 else 3
    vol, origin, spacing = read_nrrd(nrrd)
    os.makedirs(outdir, exist_ok=True)
    for peer in peers:
        runs = []
        if peer == "skimage":
            import skimage
            from skimage.measure import marching_cubes

            s, (v, f, _, _) = timed(lambda: marching_cubes(vol, 0.5), repeat)
            runs.append(("skimage", f"scikit-image {skimage.__version__}", s, v[:, ::-1], f))
        elif peer == "mcubes":
            import mcubes

            s, (v, f) = timed(lambda: mcubes.marching_cubes(vol, 0.5), repeat)
            runs.append(("mcubes", "PyMCubes", s, v[:, ::-1], f))
        elif peer == "openvdb":
            import pyopenvdb as vdb

            grid = vdb.FloatGrid()
            grid.copyFromArray(np.ascontiguousarray(vol.transpose(2, 1, 0)))
            for a in (0.0, 0.1, 0.3):
                s, (p, t, q) = timed(lambda: grid.convertToPolygons(isovalue=0.5, adaptivity=a), repeat)
                f = np.concatenate([t.reshape(-1, 3), q[:, [0, 1, 2]], q[:, [0, 2, 3]]]) if len(q) else t
                runs.append((f"openvdb_a{a}", f"OpenVDB {vdb.LIBRARY_VERSION} volumeToMesh adaptivity {a}", s, p, f))
        for name, what, s, v, f in runs:
            world = origin + np.asarray(v, dtype=np.float64) * spacing
            path = os.path.join(outdir, name + ".obj")
            write_obj(path, world, np.asarray(f, dtype=np.int64))
            print(json.dumps({"peer": name, "what": what, "median_s": s, "triangles": int(len(f)),
                              "vertices": int(len(v)), "obj": path, "threads": 1}), flush=True)


if __name__ == "__main__":
    main()
