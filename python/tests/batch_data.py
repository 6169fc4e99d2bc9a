"""A generated dataset of meshes for the batch tests: closed, open, self-intersecting and
flat meshes of varied sizes, broken files, and one mesh too large for the workers' memory."""

from __future__ import annotations

import os
from typing import Dict, List

import numpy as np


def uv_sphere(centre, radius, rings, segments):
    v = [(0.0, 0.0, radius), (0.0, 0.0, -radius)]
    for i in range(1, rings):
        th = np.pi * i / rings
        for j in range(segments):
            ph = 2 * np.pi * j / segments
            v.append((radius * np.sin(th) * np.cos(ph), radius * np.sin(th) * np.sin(ph), radius * np.cos(th)))
    v = np.asarray(v) + np.asarray(centre)
    ring = lambda i, j: 2 + (i - 1) * segments + (j % segments)
    f = []
    for j in range(segments):
        f.append((0, ring(1, j), ring(1, j + 1)))
        f.append((1, ring(rings - 1, j + 1), ring(rings - 1, j)))
    for i in range(1, rings - 1):
        for j in range(segments):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            f += [(a, c, b), (b, c, d)]
    return v, np.asarray(f)


def write_obj(path, v, f):
    with open(path, "w") as out:
        out.write("".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in v))
        out.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))


def make_dataset(root: str, count: int = 200, seed: int = 7) -> Dict[str, List[str]]:
    """Writes ``count`` good meshes (in subfolders, some sharing a file name), 8 broken
    files and one mesh too large for a 300 MB worker into ``root``; returns the paths by
    kind (``good``, ``broken``, ``huge``)."""
    rng = np.random.default_rng(seed)
    kinds: Dict[str, List[str]] = {"good": [], "broken": [], "huge": []}
    for k in range(count):
        folder = os.path.join(root, f"group{k % 4}", f"m{k:03d}")
        os.makedirs(folder, exist_ok=True)
        path = os.path.join(folder, "model.obj")
        centre = rng.normal(size=3) * 3
        if k % 100 == 99:
            centre = centre + 1e5  # far from the origin
        r = 0.5 + rng.random()
        rings, segs = int(rng.integers(5, 14)), int(rng.integers(6, 20))
        v, f = uv_sphere(centre, r, rings, segs)
        kind = k % 5
        if kind == 1:  # open: the upper cap removed
            f = f[[not all(v[i][2] > centre[2] + 0.3 * r for i in tri) for tri in f]]
        elif kind == 2:  # self-intersecting: two overlapping spheres
            v2, f2 = uv_sphere(centre + [0.6 * r, 0.1, 0.0], 0.8 * r, rings, segs)
            f = np.concatenate([f, f2 + len(v)])
            v = np.concatenate([v, v2])
        elif kind == 3:  # flat: a square in a plane
            v = centre + np.array([[-r, -r, 0], [r, -r, 0], [r, r, 0], [-r, r, 0]], dtype=float)
            f = np.array([[0, 1, 2], [0, 2, 3]])
        elif kind == 4:  # inconsistently oriented: every other triangle flipped
            f = f.copy()
            f[::2] = f[::2, ::-1]
        write_obj(path, v, f)
        kinds["good"].append(path)
    broken_dir = os.path.join(root, "broken")
    os.makedirs(broken_dir, exist_ok=True)
    broken = {
        "empty.obj": "",
        "garbage.obj": "this is not an obj file\n\x00\x01\x02",
        "index_out_of_range.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
        "nan.obj": "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
        "truncated.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2",
        "no_faces.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
        "binary.glb": "glTF\x02\x00\x00\x00garbage",
    }
    for name, text in broken.items():
        p = os.path.join(broken_dir, name)
        with open(p, "w") as out:
            out.write(text)
        kinds["broken"].append(p)
    kinds["broken"].append(os.path.join(broken_dir, "missing.obj"))  # listed, never written
    v, f = uv_sphere((0.0, 0.0, 0.0), 1.0, 260, 400)  # 207,480 triangles: ≈ 650 MB to voxelize
    huge = os.path.join(root, "huge", "model.obj")
    os.makedirs(os.path.dirname(huge), exist_ok=True)
    write_obj(huge, v, f)
    kinds["huge"].append(huge)
    return kinds
