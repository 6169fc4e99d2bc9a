"""Shared helpers of the peer benchmark: mesh loading, file formats, exact references.

Numpy only, and written for both interpreters the benchmark uses: Debian's
/usr/bin/python3 (numpy 1.24, where pyopenvdb lives) and the venv (numpy 2.x, Open3D,
trimesh). Everything here runs outside the timed calls.
"""

import math
import os
import re
from concurrent.futures import ThreadPoolExecutor

import numpy as np


# --------------------------------------------------------------------------- meshes

def load_obj(path):
    """(vertices float64 (V,3), triangles int64 (T,3)) of an OBJ; polygons fan-triangulated.

    Every peer gets these same arrays (volga reads the file itself), so no peer's own
    loader changes the input, e.g. by welding vertices at seams.
    """
    verts, tris = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = []
                for tok in line.split()[1:]:
                    i = int(tok.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                for k in range(1, len(idx) - 1):
                    tris.append([idx[0], idx[k], idx[k + 1]])
    verts = np.asarray(verts, np.float64)
    tris = np.asarray(tris, np.int64)
    # Drop vertices no face uses (the bunny has 1,113): they are not surface, yet
    # trimesh's subdivide voxelizer would still mark their voxels.
    used, tris = np.unique(tris, return_inverse=True)
    return verts[used], tris.reshape(-1, 3)


def voxel_size(verts, n):
    """Voxel edge h giving n voxels along the longest side of the bounding box (volga's
    `--resolution` definition)."""
    return float((verts.max(0) - verts.min(0)).max()) / n


# --------------------------------------------------------------------------- binvox

def write_binvox(path, ijk, centre0, h, pad=1):
    """Writes voxels `ijk` of a grid whose voxel (0,0,0) has its centre at world point
    `centre0` and edge `h`, as a .binvox with a correct world mapping.

    binvox's mapping is world = translate + scale·(i + 0.5)/D for file index i, i.e.
    voxel i spans [translate + i·h, translate + (i+1)·h] with h = scale/D. The set is
    shifted to start at `pad` (an empty layer so the grid border never touches the
    surface) and D is the largest extent plus 2·pad (binvox grids are cubes).
    Order: index = x·D² + z·D + y (y fastest), RLE pairs (value, count ≤ 255).
    Returns D.
    """
    ijk = np.asarray(ijk, np.int64)
    lo = ijk.min(0)
    q = ijk - lo + pad
    d = int(q.max()) + 1 + pad
    translate = np.asarray(centre0, np.float64) + (lo - pad) * h - 0.5 * h
    flat = np.zeros(d * d * d, np.uint8)
    flat[q[:, 0] * d * d + q[:, 2] * d + q[:, 1]] = 1
    with open(path, "wb") as f:
        f.write(b"#binvox 1\n")
        f.write(f"dim {d} {d} {d}\n".encode())
        f.write("translate {!r} {!r} {!r}\n".format(*map(float, translate)).encode())
        f.write(f"scale {float(d * h)!r}\n".encode())
        f.write(b"data\n")
        f.write(_rle(flat))
    return d


def _rle(flat):
    # Run boundaries, then split runs longer than 255 into full chunks + remainder.
    change = np.flatnonzero(np.diff(flat)) + 1
    starts = np.concatenate(([0], change))
    lengths = np.diff(np.concatenate((starts, [flat.size])))
    values = flat[starts]
    reps = (lengths + 254) // 255
    vals = np.repeat(values, reps)
    counts = np.full(reps.sum(), 255, np.int64)
    last = np.cumsum(reps) - 1
    counts[last] = lengths - (reps - 1) * 255
    return np.stack([vals, counts.astype(np.uint8)], 1).astype(np.uint8).tobytes()


def read_binvox(path):
    """(ijk int64 (n,3) of set voxels, dims (3,), translate, scale) of a .binvox file.

    The format wants cubic grids, but volga writes `dim X Y Z` of its own box; both are
    read, with the same order generalized: index = x·(Z·Y) + z·Y + y.
    """
    with open(path, "rb") as f:
        header = {}
        line = f.readline().strip()
        if not line.startswith(b"#binvox"):
            raise ValueError(f"{path}: not a binvox file")
        while True:
            line = f.readline()
            if not line:
                raise ValueError(f"{path}: no `data` line")
            parts = line.decode().split()
            if parts and parts[0] == "data":
                break
            if parts:
                header[parts[0]] = parts[1:]
        pairs = np.frombuffer(f.read(), np.uint8).reshape(-1, 2)
    dx, dy, dz = (int(x) for x in header["dim"])
    flat = np.repeat(pairs[:, 0], pairs[:, 1].astype(np.int64))
    if flat.size != dx * dy * dz:
        raise ValueError(f"{path}: {flat.size} voxels decoded, expected {dx}x{dy}x{dz}")
    idx = np.flatnonzero(flat)
    x, rem = np.divmod(idx, dz * dy)
    z, y = np.divmod(rem, dy)
    translate = [float(v) for v in header.get("translate", [0, 0, 0])]
    scale = float(header.get("scale", [1])[0])
    return np.stack([x, y, z], 1), (dx, dy, dz), translate, scale


# --------------------------------------------------------------------------- NRRD

def read_nrrd_header(path):
    """The fields of a NRRD header (`key: value` and `key:=value`) as a dict of strings."""
    fields = {}
    with open(path, "rb") as f:
        magic = f.readline().decode().strip()
        if not magic.startswith("NRRD"):
            raise ValueError(f"{path}: not a NRRD file")
        for raw in f:
            line = raw.decode().rstrip("\n")
            if not line.strip():
                break  # attached data would follow; volga writes detached headers
            if line.startswith("#"):
                continue
            m = re.match(r"([^:]+):=(.*)", line) or re.match(r"([^:]+):\s*(.*)", line)
            if m:
                fields[m.group(1).strip()] = m.group(2).strip()
    return fields


def read_volga_nrrd(path):
    """(data float32 [x,y,z] memmap, origin (3,), spacing (3,), fields) of a volga NRRD.

    Volga writes a detached header: `space origin` is the world position of voxel
    (0,0,0)'s centre, `space directions` is diagonal, data are float32 little endian,
    x fastest, in the file named by `data file:` (relative to the header).
    """
    fields = read_nrrd_header(path)
    if fields.get("type") not in ("float", "float32"):
        raise ValueError(f"{path}: type {fields.get('type')}, expected float")
    if fields.get("encoding", "raw") != "raw" or fields.get("endian", "little") != "little":
        raise ValueError(f"{path}: expected raw little-endian data")
    sizes = [int(s) for s in fields["sizes"].split()]
    vecs = [[float(c) for c in v.strip("()").split(",")]
            for v in re.findall(r"\([^)]*\)", fields["space directions"])]
    spacing = np.array([vecs[k][k] for k in range(3)])
    if any(abs(vecs[i][j]) > 0 for i in range(3) for j in range(3) if i != j):
        raise ValueError(f"{path}: non-diagonal space directions")
    origin = np.array([float(c) for c in fields["space origin"].strip("()").split(",")])
    data_path = os.path.join(os.path.dirname(path), fields["data file"])
    # Fortran order makes data[i, j, k] the voxel at origin + (i, j, k)·spacing.
    data = np.memmap(data_path, dtype="<f4", mode="r", shape=tuple(sizes), order="F")
    return data, origin, spacing, fields


# --------------------------------------------------------------------------- references

def _chunks(n, size):
    return [(s, min(s + size, n)) for s in range(0, n, size)]


def _map_chunks(fn, n, size, threads):
    # Numpy's big element-wise kernels release the GIL, so threads use both cores.
    with ThreadPoolExecutor(max_workers=threads) as pool:
        return list(pool.map(fn, _chunks(n, size)))


def exact_unsigned_distance(points, verts, tris, chunk=16, threads=2):
    """Exact distance from each point to the mesh: min over ALL triangles of the
    point–triangle distance (Ericson, Real-Time Collision Detection §5.1.5: the Voronoi
    region of the closest feature decides the barycentrics). Brute force on purpose:
    no acceleration structure whose bugs could hide in the reference."""
    # Per-component (T,) arrays: plain broadcasting beats einsum on (P,T,3) here.
    a = verts[tris[:, 0]].T.copy()
    b = verts[tris[:, 1]].T.copy()
    c = verts[tris[:, 2]].T.copy()
    ab, ac = b - a, c - a
    points = np.asarray(points, np.float64)

    def dot(u, v):
        return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]

    def run(rng):
        p = points[rng[0]:rng[1]].T[:, :, None]          # (3, P, 1)
        ap, bp, cp = p - a[:, None, :], p - b[:, None, :], p - c[:, None, :]
        d1, d2 = dot(ap, ab[:, None, :]), dot(ap, ac[:, None, :])
        d3, d4 = dot(bp, ab[:, None, :]), dot(bp, ac[:, None, :])
        d5, d6 = dot(cp, ab[:, None, :]), dot(cp, ac[:, None, :])
        va = d3 * d6 - d5 * d4
        vb = d5 * d2 - d1 * d6
        vc = d1 * d4 - d3 * d2
        with np.errstate(divide="ignore", invalid="ignore"):
            # Face interior first, then each test of Ericson's sequence overrides it
            # in reverse order, so the earliest test that holds wins, as in his code.
            denom = va + vb + vc
            v = vb / denom
            w = vc / denom
            reg = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)  # edge BC
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            v = np.where(reg, 1 - t, v)
            w = np.where(reg, t, w)
            reg = (vb <= 0) & (d2 >= 0) & (d6 <= 0)            # edge AC
            v = np.where(reg, 0.0, v)
            w = np.where(reg, d2 / (d2 - d6), w)
            reg = (d6 >= 0) & (d5 <= d6)                       # vertex C
            v = np.where(reg, 0.0, v)
            w = np.where(reg, 1.0, w)
            reg = (vc <= 0) & (d1 >= 0) & (d3 <= 0)            # edge AB
            v = np.where(reg, d1 / (d1 - d3), v)
            w = np.where(reg, 0.0, w)
            reg = (d3 >= 0) & (d4 <= d3)                       # vertex B
            v = np.where(reg, 1.0, v)
            w = np.where(reg, 0.0, w)
            reg = (d1 <= 0) & (d2 <= 0)                        # vertex A
            v = np.where(reg, 0.0, v)
            w = np.where(reg, 0.0, w)
        dist2 = sum((ap[k] - v * ab[k][None, :] - w * ac[k][None, :]) ** 2 for k in range(3))
        # A zero-area triangle leaves 0/0 in the face branch; its points are covered
        # by its neighbours' edges, so it is skipped rather than poisoning the min.
        return np.sqrt(np.nanmin(dist2, axis=1))

    return np.concatenate(_map_chunks(run, len(points), chunk, threads))


def winding_number(points, verts, tris, chunk=16, threads=2):
    """Generalized winding number of each point: Σ solid angles / 4π over all triangles,
    each solid angle exact by Van Oosterom & Strackee's formula. ≥ ½ means inside,
    which is the answer volga documents for open meshes such as the bunny."""
    A = verts[tris[:, 0]].T.copy()
    B = verts[tris[:, 1]].T.copy()
    C = verts[tris[:, 2]].T.copy()
    points = np.asarray(points, np.float64)

    def run(rng):
        p = points[rng[0]:rng[1]].T[:, :, None]
        a, b, c = A[:, None, :] - p, B[:, None, :] - p, C[:, None, :] - p
        la = np.sqrt(a[0] ** 2 + a[1] ** 2 + a[2] ** 2)
        lb = np.sqrt(b[0] ** 2 + b[1] ** 2 + b[2] ** 2)
        lc = np.sqrt(c[0] ** 2 + c[1] ** 2 + c[2] ** 2)
        det = (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2])
               + a[2] * (b[0] * c[1] - b[1] * c[0]))
        ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
        bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2]
        ca = c[0] * a[0] + c[1] * a[1] + c[2] * a[2]
        den = la * lb * lc + ab * lc + bc * la + ca * lb
        return np.arctan2(det, den).sum(axis=1) / (2.0 * math.pi)

    return np.concatenate(_map_chunks(run, len(points), chunk, threads))
