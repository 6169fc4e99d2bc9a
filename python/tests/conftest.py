"""Shared fixtures: meshes made here (clean and unclean), brute-force references in numpy,
and the `volga` command-line binary the bit-for-bit comparisons run.

Nothing here reads files outside the repository or downloads anything.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


# ---------------------------------------------------------------- meshes

def uv_sphere(center=(0.0, 0.0, 0.0), radius=1.0, rings=12, segments=24):
    """A closed, outward-oriented UV sphere (poles are single vertices)."""
    c = np.asarray(center, dtype=np.float64)
    verts = [c + (0.0, 0.0, radius)]
    for r in range(1, rings):
        theta = np.pi * r / rings
        for s in range(segments):
            phi = 2 * np.pi * s / segments
            verts.append(c + radius * np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]))
    verts.append(c + (0.0, 0.0, -radius))
    faces = []
    ring = lambda r, s: 1 + (r - 1) * segments + s % segments  # noqa: E731
    for s in range(segments):
        faces.append((0, ring(1, s), ring(1, s + 1)))
    for r in range(1, rings - 1):
        for s in range(segments):
            a, b, c2, d = ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s + 1)
            faces.append((a, b, c2))
            faces.append((a, c2, d))
    south = len(verts) - 1
    for s in range(segments):
        faces.append((south, ring(rings - 1, s + 1), ring(rings - 1, s)))
    return np.array(verts), np.array(faces, dtype=np.int64)


def cube(lo=(-1.0, -1.0, -1.0), hi=(1.0, 1.0, 1.0)):
    """A closed, outward-oriented box of 12 triangles."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    v = np.array([[x, y, z] for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])])
    f = np.array(
        [
            [0, 2, 1], [1, 2, 3],  # z = lo
            [4, 5, 6], [5, 7, 6],  # z = hi
            [0, 1, 4], [1, 5, 4],  # y = lo
            [2, 6, 3], [3, 6, 7],  # y = hi
            [0, 4, 2], [2, 4, 6],  # x = lo
            [1, 3, 5], [3, 7, 5],  # x = hi
        ],
        dtype=np.int64,
    )
    return v, f


def concat(*meshes):
    vs, fs, n = [], [], 0
    for v, f in meshes:
        vs.append(v)
        fs.append(f + n)
        n += len(v)
    return np.concatenate(vs), np.concatenate(fs)


def unclean_corpus():
    """Meshes no watertight-only tool handles: name → (vertices, faces)."""
    v, f = uv_sphere((0.1, -0.05, 0.02), 1.0, 10, 20)
    centroids = v[f].mean(axis=1)
    corpus = {
        "closed_sphere": (v, f),
        # two closed spheres overlapping: self-intersecting union, w = 2 in the overlap
        "overlapping": concat(uv_sphere((0, 0, 0), 1.0, 10, 20), uv_sphere((0.8, 0.1, 0), 0.7, 10, 20)),
        # a cap cut off: open, one boundary loop
        "open_cap": (v, f[centroids[:, 2] < 0.7]),
        # half the triangles flipped: inconsistent orientation
        "flipped_half": (v, np.where((centroids[:, 0] > 0)[:, None], f[:, ::-1], f)),
        # zero-area triangles (repeated corners, collinear corners) added
        "degenerate": (
            np.concatenate([v, [[5.0, 5.0, 5.0], [6.0, 6.0, 6.0], [7.0, 7.0, 7.0]]]),
            np.concatenate([f, [[0, 0, 1], [len(v), len(v) + 1, len(v) + 2]]]),
        ),
        # a flat open sheet (w is fractional everywhere off it)
        "sheet": (np.array([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]]), np.array([[0, 1, 2], [0, 2, 3]])),
        # far from the origin
        "far_sphere": uv_sphere((1e6, -2e6, 5e5), 1.0, 10, 20),
    }
    return corpus


# ---------------------------------------------------------------- brute-force references

def brute_winding(v, f, points, chunk=256):
    """Generalized winding number: sum of solid angles (van Oosterom & Strackee) / 4π."""
    tri = v[f]  # (M, 3, 3)
    out = np.empty(len(points))
    for s in range(0, len(points), chunk):
        p = points[s : s + chunk, None, None, :]  # (k, 1, 1, 3)
        r = tri[None] - p  # (k, M, 3, 3)
        a, b, c = r[..., 0, :], r[..., 1, :], r[..., 2, :]
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        num = np.einsum("kmi,kmi->km", a, np.cross(b, c))
        den = la * lb * lc + np.einsum("kmi,kmi->km", a, b) * lc + np.einsum("kmi,kmi->km", b, c) * la + np.einsum("kmi,kmi->km", c, a) * lb
        out[s : s + chunk] = (2 * np.arctan2(num, den)).sum(axis=1) / (4 * np.pi)
    return out


def _closest_on_triangles(p, a, b, c):
    """Closest points to p (3,) on triangles a, b, c (M, 3) (Ericson, Real-Time Collision Detection 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1.0 / (va + vb + vc)
        v_ = vb * denom
        w_ = vc * denom
        res = a + ab * v_[:, None] + ac * w_[:, None]
        # regions, last assignment wins in reverse priority order
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        res = np.where(((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0))[:, None], b + (c - b) * t_bc[:, None], res)
        t_ac = d2 / (d2 - d6)
        res = np.where(((vb <= 0) & (d2 >= 0) & (d6 <= 0))[:, None], a + ac * t_ac[:, None], res)
        t_ab = d1 / (d1 - d3)
        res = np.where(((vc <= 0) & (d1 >= 0) & (d3 <= 0))[:, None], a + ab * t_ab[:, None], res)
        res = np.where(((d6 >= 0) & (d5 <= d6))[:, None], c, res)
        res = np.where(((d3 >= 0) & (d4 <= d3))[:, None], b, res)
        res = np.where(((d1 <= 0) & (d2 <= 0))[:, None], a, res)
    return res


def brute_distance(v, f, points):
    """Unsigned distance from each point to the nearest triangle, by testing every triangle."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    out = np.empty(len(points))
    for k, p in enumerate(points):
        q = _closest_on_triangles(p, a, b, c)
        d = np.linalg.norm(q - p, axis=1)
        out[k] = np.nanmin(d) if np.isfinite(d).any() else np.inf
    return out


def edge_face_check(faces):
    """(closed, manifold, consistently oriented) from the triangles alone: every undirected
    edge used by exactly two triangles, in opposite directions."""
    f = np.asarray(faces)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    und = np.sort(directed, axis=1)
    _, counts = np.unique(und, axis=0, return_counts=True)
    closed = bool((counts == 2).all())
    _, dcounts = np.unique(directed, axis=0, return_counts=True)
    oriented = bool((dcounts == 1).all())
    return closed, oriented


def write_obj(path, v, f):
    with open(path, "w") as out:
        for p in v:
            out.write(f"v {float(p[0])!r} {float(p[1])!r} {float(p[2])!r}\n")
        for t in f:
            out.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")
    return path


# ---------------------------------------------------------------- the CLI

def _volga_bin():
    env = os.environ.get("VOLGA_BIN")
    if env:
        return env
    for profile in ("release", "debug"):
        candidate = REPO / "target" / profile / "volga"
        if candidate.exists():
            return str(candidate)
    return shutil.which("volga")


@pytest.fixture(scope="session")
def volga_cli():
    """Runs the `volga` binary (VOLGA_BIN, else target/{release,debug}/volga). The test
    script builds it, so a missing binary is an error, not a skip."""
    exe = _volga_bin()
    if exe is None:
        pytest.fail("no volga binary: set VOLGA_BIN or run `cargo build --bin volga` first")

    def run(*args, check=True):
        proc = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        if check and proc.returncode != 0:
            raise AssertionError(f"volga {' '.join(map(str, args))} failed ({proc.returncode}): {proc.stderr}")
        return proc

    return run


def read_nrrd_raw(path):
    """The float32 samples of a volga NRRD (detached raw data), as an [i, j, k] array."""
    header = Path(path).read_text().split("\n\n")[0].splitlines()
    fields = {}
    for line in header[1:]:
        if ":" in line and not line.startswith("#"):
            k, val = line.split(":", 1)
            fields[k.strip()] = val.strip()
    sizes = [int(s) for s in fields["sizes"].split()]
    assert fields["type"] == "float" and fields.get("encoding", "raw") == "raw", fields
    dtype = "<f4" if fields.get("endian", "little") == "little" else ">f4"
    data = np.fromfile(Path(path).parent / fields["data file"], dtype=dtype)
    return data.reshape(sizes[::-1]).transpose(2, 1, 0)


@pytest.fixture
def sphere_obj(tmp_path):
    v, f = uv_sphere((0.1, -0.05, 0.02), 1.0, 16, 32)
    return write_obj(tmp_path / "sphere.obj", v, f), v, f
