#!/usr/bin/env python3
"""Side-by-side benchmark of volga's Python package against its Python peers.

    bench/python/setup_peers.sh /work/venv-peers target/wheels/volga-*.whl
    /work/venv-peers/bin/python bench/python/bench_peers.py [--points 1000000] [--repeat 5]

Every peer is measured in the same run as volga, on the same arrays, as the median of
--repeat calls after one warm-up; only the library call is timed (time.perf_counter; the
process CPU time of the same calls is recorded too, to show who uses both cores).

1. Signed distance, negative inside, on --points points per mesh (half uniform in the
   bounding box padded 10 %, half near the surface), for the shared meshes and generated
   unclean ones (overlapping spheres, open sphere, inconsistently oriented sphere, sphere
   with zero-area triangles, flat square). Each timed call includes the peer's own
   acceleration structure (volga, libigl, pysdf, trimesh build theirs inside the call;
   Open3D's RaycastingScene is built in the timed block too). trimesh runs on a subset
   (--trimesh-points) and its time is extrapolated linearly.
   Signs are checked against a brute-force generalized winding number (numpy, van
   Oosterom–Strackee solid angles) on --check-points points: inside iff w >= 1/2; points
   with |w - 1/2| < 1e-3 or |distance| < 1e-9 * diagonal are left out as ambiguous.
   Distance error = max | |d_tool| - |d_volga| | (volga's distance is exact).
2. Surface voxelization of the shared meshes at --resolutions voxels along the longest
   side: volga (26-separating) vs trimesh `voxelized` and Open3D `VoxelGrid`, each result
   checked with volga.validate (26-tunnels through the mesh, cover).

Writes a JSON file (--json-out) and prints Markdown tables. Outside CI on purpose.
"""

import argparse
import datetime
import gc
import importlib
import importlib.metadata
import json
import math
import os
import platform
import subprocess
import sys
import time
import traceback
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))

SHARED_MESHES = ["stanford-bunny", "spot", "fandisk", "teapot"]
GENERATED_MESHES = ["spheres-overlapping", "sphere-open", "sphere-flipped-half",
                    "sphere-degenerate", "flat-square"]
SDF_TOOLS = ["volga", "libigl", "open3d", "pysdf", "trimesh"]
VOX_TOOLS = ["volga", "trimesh", "open3d"]
MODULES = {"volga": "volga", "libigl": "igl", "open3d": "open3d", "pysdf": "pysdf",
           "trimesh": "trimesh"}
DISTRIBUTIONS = ["volga", "numpy", "libigl", "open3d", "pysdf", "trimesh", "scipy", "rtree"]


# --------------------------------------------------------------------------- imports

def import_tools():
    """{tool: module or None}, {tool: error text} — a peer that fails to import is
    reported as missing, never a crash."""
    mods, errors = {}, {}
    for tool, name in MODULES.items():
        try:
            mods[tool] = importlib.import_module(name)
        except Exception as e:  # ImportError, or OSError from a missing shared library
            mods[tool] = None
            errors[tool] = f"{type(e).__name__}: {e}"
    return mods, errors


def versions():
    out = {"python": platform.python_version()}
    for d in DISTRIBUTIONS:
        try:
            out[d] = importlib.metadata.version(d)
        except importlib.metadata.PackageNotFoundError:
            out[d] = None
    return out


def machine_info():
    cpu = None
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                                text=True, check=True).stdout.strip()
        dirty = bool(subprocess.run(["git", "status", "--porcelain"], cwd=ROOT,
                                    capture_output=True, text=True).stdout.strip())
    except (OSError, subprocess.CalledProcessError):
        commit, dirty = None, None
    mem = None
    try:
        with open("/proc/meminfo") as f:
            mem = int(f.readline().split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return {
        "cpu_model": cpu,
        "cores": os.cpu_count(),
        "memory_bytes": mem,
        "platform": platform.platform(),
        "volga_commit": commit,
        "volga_worktree_dirty": dirty,
        "loadavg_at_start": list(os.getloadavg()),
    }


# --------------------------------------------------------------------------- meshes

def load_obj(path):
    """(vertices float64 (V,3), triangles int64 (T,3)) of an OBJ; polygons fan-triangulated;
    only the position index of each corner is used (so spot's texture seams do not open
    it); vertices no face uses are dropped. Every tool gets these same arrays."""
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
    used, inv = np.unique(tris, return_inverse=True)
    return verts[used], inv.reshape(-1, 3).astype(np.int64)


def uv_sphere(n_lat=64, n_lon=128, centre=(0.0, 0.0, 0.0), radius=1.0):
    """Closed, consistently outward-oriented UV sphere: one vertex per pole, n_lat - 1
    rings of n_lon vertices; 2·n_lon·(n_lat - 1) triangles."""
    theta = np.pi * np.arange(1, n_lat) / n_lat                  # ring polar angles
    phi = 2 * np.pi * np.arange(n_lon) / n_lon
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack([st * np.cos(phi), st * np.sin(phi), np.broadcast_to(ct, (n_lat - 1, n_lon))], -1)
    verts = np.concatenate([[[0.0, 0.0, 1.0]], ring.reshape(-1, 3), [[0.0, 0.0, -1.0]]])
    north, south = 0, len(verts) - 1
    r = lambda i, j: 1 + i * n_lon + (j % n_lon)  # noqa: E731
    j = np.arange(n_lon)
    tris = [np.stack([np.full(n_lon, north), r(0, j), r(0, j + 1)], 1)]
    for i in range(n_lat - 2):
        tris.append(np.stack([r(i, j), r(i + 1, j), r(i + 1, j + 1)], 1))
        tris.append(np.stack([r(i, j), r(i + 1, j + 1), r(i, j + 1)], 1))
    tris.append(np.stack([r(n_lat - 2, j), np.full(n_lon, south), r(n_lat - 2, j + 1)], 1))
    tris = np.concatenate(tris).astype(np.int64)
    verts = verts * radius + np.asarray(centre, np.float64)
    assert signed_volume(verts, tris) > 0, "uv_sphere must be outward oriented"
    return verts, tris


def signed_volume(verts, tris):
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def edge_stats(tris):
    """Boundary edges (used by one face), non-manifold edges (> 2 faces), and edges used
    twice with the same direction (inconsistent orientation); degenerate edges (i, i) of
    zero-area triangles are counted apart."""
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    loops = int((e[:, 0] == e[:, 1]).sum())
    e = e[e[:, 0] != e[:, 1]]
    und = np.sort(e, 1)
    _, cnt = np.unique(und, axis=0, return_counts=True)
    _, dcnt = np.unique(e, axis=0, return_counts=True)
    return {
        "boundary_edges": int((cnt == 1).sum()),
        "nonmanifold_edges": int((cnt > 2).sum()),
        "same_direction_edges": int((dcnt > 1).sum()),
        "degenerate_edges": loops,
    }


def generated_mesh(name, seed):
    """The unclean test meshes, deterministic for a seed."""
    rng = np.random.default_rng([seed, GENERATED_MESHES.index(name)])
    if name == "spheres-overlapping":
        # Two closed spheres concatenated: self-intersecting, the lens has w = 2.
        v1, f1 = uv_sphere(centre=(0.0, 0.0, 0.0))
        v2, f2 = uv_sphere(centre=(0.6, 0.25, 0.1), radius=0.8)
        return np.concatenate([v1, v2]), np.concatenate([f1, f2 + len(v1)])
    if name == "sphere-open":
        # Cap of triangles removed (those whose centroid has z > 0.8): a hole of radius 0.6.
        v, f = uv_sphere()
        keep = v[f].mean(1)[:, 2] <= 0.8
        return v, f[keep]
    if name == "sphere-flipped-half":
        # Half of the faces (seeded random choice) reversed: inconsistent orientation.
        v, f = uv_sphere()
        flip = rng.permutation(len(f))[: len(f) // 2]
        f = f.copy()
        f[flip] = f[flip][:, ::-1]
        return v, f
    if name == "sphere-degenerate":
        # Closed sphere plus 300 zero-area triangles: 100 with a repeated vertex index,
        # 100 needles of three collinear new vertices (some crossing the surface),
        # 100 with three distinct vertex indices at one point.
        v, f = uv_sphere()
        n = len(v)
        k = 100
        rep = rng.integers(0, n, (k, 2))
        extra_f = [np.stack([rep[:, 0], rep[:, 0], rep[:, 1]], 1)]
        p = rng.uniform(-1.2, 1.2, (k, 3))
        t = rng.normal(size=(k, 3))
        t *= (rng.uniform(0.05, 0.4, k) / np.linalg.norm(t, axis=1))[:, None]
        needle = np.stack([p, p + t, p + 2.5 * t], 1).reshape(-1, 3)
        extra_f.append(n + np.arange(3 * k).reshape(k, 3))
        q = v[rng.integers(0, n, k)]
        point3 = np.repeat(q, 3, axis=0)
        extra_f.append(n + 3 * k + np.arange(3 * k).reshape(k, 3))
        return np.concatenate([v, needle, point3]), np.concatenate([f] + extra_f).astype(np.int64)
    if name == "flat-square":
        # A planar 32 x 32 grid of squares in z = 0, two triangles each: open, no volume,
        # so no point has w >= 1/2 off the plane (all points are outside).
        n = 32
        g = np.linspace(-1.0, 1.0, n + 1)
        x, y = np.meshgrid(g, g, indexing="ij")
        v = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
        i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        a = (i * (n + 1) + j).ravel()
        b, c, d = a + (n + 1), a + (n + 1) + 1, a + 1
        f = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)
        return v, f
    raise ValueError(name)


# --------------------------------------------------------------------------- points

def sample_points(verts, tris, n, rng):
    """n points: half uniform in the bounding box padded by 10 % of each side (at least
    5 % of the diagonal, so flat meshes get a slab), half near the surface (uniformly
    chosen triangle, uniform barycentric point, offset along the unit face normal by
    N(0, 0.01 · diagonal); a zero-area triangle gets a random direction). Shuffled."""
    lo, hi = verts.min(0), verts.max(0)
    diag = float(np.linalg.norm(hi - lo))
    pad = np.maximum(0.1 * (hi - lo), 0.05 * diag)
    n_box = n // 2
    n_near = n - n_box
    box = rng.uniform(lo - pad, hi + pad, (n_box, 3))
    t = rng.integers(0, len(tris), n_near)
    a, b, c = verts[tris[t, 0]], verts[tris[t, 1]], verts[tris[t, 2]]
    r1, r2 = rng.random(n_near), rng.random(n_near)
    s = np.sqrt(r1)
    on = (1 - s)[:, None] * a + (s * (1 - r2))[:, None] * b + (s * r2)[:, None] * c
    nrm = np.cross(b - a, c - a)
    ln = np.linalg.norm(nrm, axis=1)
    bad = ln <= 1e-300
    if bad.any():
        rnd = rng.normal(size=(int(bad.sum()), 3))
        nrm[bad] = rnd
        ln[bad] = np.linalg.norm(rnd, axis=1)
    nrm /= ln[:, None]
    near = on + nrm * rng.normal(0.0, 0.01 * diag, n_near)[:, None]
    pts = np.concatenate([box, near])
    return np.ascontiguousarray(pts[rng.permutation(n)]), diag


# --------------------------------------------------------------------------- reference

def winding_numbers(verts, tris, points, chunk_elems=1_500_000):
    """Generalized winding number of each point, by brute force: sum over the triangles of
    the signed solid angle Ω = 2·atan2(a·(b×c), |a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|)
    (van Oosterom & Strackee 1983) with a, b, c the corners relative to the point, divided
    by 4π. float64, vectorized over blocks of (points × triangles) of at most chunk_elems
    pairs; coordinates are centred on the bounding box first (translation invariant)."""
    centre = 0.5 * (verts.min(0) + verts.max(0))
    v = verts - centre
    p = np.asarray(points, np.float64) - centre
    t0, t1, t2 = v[tris[:, 0]], v[tris[:, 1]], v[tris[:, 2]]
    m = len(tris)
    w = np.zeros(len(p))
    if m == 0:
        return w
    tri_chunk = max(1, min(m, chunk_elems))
    pt_chunk = max(1, chunk_elems // tri_chunk)
    for j0 in range(0, m, tri_chunk):
        j1 = min(m, j0 + tri_chunk)
        A0, A1, A2 = (t0[j0:j1, k][None, :] for k in range(3))
        B0, B1, B2 = (t1[j0:j1, k][None, :] for k in range(3))
        C0, C1, C2 = (t2[j0:j1, k][None, :] for k in range(3))
        for i0 in range(0, len(p), pt_chunk):
            i1 = min(len(p), i0 + pt_chunk)
            px, py, pz = (p[i0:i1, k][:, None] for k in range(3))
            ax, ay, az = A0 - px, A1 - py, A2 - pz
            bx, by, bz = B0 - px, B1 - py, B2 - pz
            cx, cy, cz = C0 - px, C1 - py, C2 - pz
            la = np.sqrt(ax * ax + ay * ay + az * az)
            lb = np.sqrt(bx * bx + by * by + bz * bz)
            lc = np.sqrt(cx * cx + cy * cy + cz * cz)
            num = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
            den = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc
                   + (bx * cx + by * cy + bz * cz) * la + (cx * ax + cy * ay + cz * az) * lb)
            w[i0:i1] += np.arctan2(num, den).sum(1)
    return w * (2.0 / (4.0 * math.pi))


def self_check_winding():
    """The brute-force winding number against known answers; raises on a mismatch."""
    tv = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
    tt = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int64)  # outward
    assert signed_volume(tv, tt) > 0
    q = np.array([[0.1, 0.1, 0.1], [0.25, 0.25, 0.25], [2.0, 2.0, 2.0], [-0.3, 0.2, 0.1],
                  [0.2, 0.2, 0.0 + 1e-7]])
    w = winding_numbers(tv, tt, q, chunk_elems=3)  # tiny chunks: exercise the blocking
    expect = np.array([1.0, 1.0, 0.0, 0.0, 1.0])
    assert np.allclose(w, expect, atol=1e-9), (w, expect)
    assert np.allclose(winding_numbers(tv, tt[:, ::-1], q), -expect, atol=1e-9)
    # One face (1,0,0),(0,1,0),(0,0,1) seen from the origin subtends an octant: 4π/8,
    # i.e. w = +1/8 with the face oriented away from the origin (the origin is on its
    # inner side), -1/8 reversed.
    w1 = winding_numbers(tv, np.concatenate([tt[3:], tt[3:, ::-1]]), np.zeros((1, 3)))
    assert abs(w1[0]) < 1e-12, w1
    w1 = winding_numbers(tv, tt[3:], np.zeros((1, 3)))
    assert abs(w1[0] - 0.125) < 1e-12, w1
    # Closed sphere: 1 inside, 0 outside; open sphere (cap removed): the cap's solid angle
    # is missing, i.e. w = 1 - Ω_cap/4π at the centre = (1 + cos θ_cap)/2 for a hole of
    # polar half-angle θ_cap (exact for the polygonal hole only in the limit).
    v, f = uv_sphere(32, 64)
    ws = winding_numbers(v, f, np.array([[0, 0, 0], [0.3, -0.2, 0.5], [1.5, 0, 0], [0, 0, -3.0]]))
    assert np.allclose(ws, [1, 1, 0, 0], atol=1e-9), ws
    return True


def self_check_meshes(seed):
    """The generated meshes are closed / open / inconsistent as intended."""
    out = {}
    for name in GENERATED_MESHES:
        v, f = generated_mesh(name, seed)
        s = edge_stats(f)
        s["triangles"] = int(len(f))
        out[name] = s
    v, f = uv_sphere()
    s = edge_stats(f)
    assert s == {"boundary_edges": 0, "nonmanifold_edges": 0, "same_direction_edges": 0,
                 "degenerate_edges": 0}, s
    assert out["spheres-overlapping"]["boundary_edges"] == 0
    assert out["spheres-overlapping"]["same_direction_edges"] == 0
    assert out["sphere-open"]["boundary_edges"] > 0
    assert out["sphere-open"]["same_direction_edges"] == 0
    assert out["sphere-flipped-half"]["boundary_edges"] == 0
    assert out["sphere-flipped-half"]["same_direction_edges"] > 0
    assert out["sphere-degenerate"]["degenerate_edges"] == 100
    assert out["flat-square"]["boundary_edges"] == 4 * 32
    # determinism
    for name in GENERATED_MESHES:
        a, b = generated_mesh(name, seed), generated_mesh(name, seed)
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    return out


# --------------------------------------------------------------------------- timing

def timed(fn, repeat, warmup=1, warmup_fn=None, budget=None):
    """(result of the last call, {median, times, cpu_median, cpu_times}) of fn(), after
    `warmup` untimed calls (of warmup_fn if given, e.g. the same call on fewer points).
    CPU time is the whole process's (all threads). With a budget (seconds), timed calls
    stop early once one more call (as long as the last) would pass it; at least one."""
    out = None
    for _ in range(warmup):
        out = (warmup_fn or fn)()
        del out
        gc.collect()
    walls, cpus = [], []
    for _ in range(repeat):
        if budget is not None and walls and sum(walls) + walls[-1] > budget:
            break
        out = None
        gc.collect()
        c0, t0 = time.process_time(), time.perf_counter()
        out = fn()
        t1, c1 = time.perf_counter(), time.process_time()
        walls.append(t1 - t0)
        cpus.append(c1 - c0)
    return out, {"median": float(np.median(walls)), "times": walls, "repeat_used": len(walls),
                 "cpu_median": float(np.median(cpus)), "cpu_times": cpus}


def run_tool(fn, repeat, warmup=1, warmup_fn=None, budget=None):
    try:
        with warnings.catch_warnings():
            # trimesh's barycentric code divides by zero on degenerate triangles
            warnings.simplefilter("ignore", RuntimeWarning)
            out, t = timed(fn, repeat, warmup, warmup_fn, budget)
        return out, dict(status="ok", **t)
    except MemoryError:
        return None, {"status": "error", "error": "MemoryError"}
    except Exception as e:
        return None, {"status": "error", "error": f"{type(e).__name__}: {e}",
                      "traceback": traceback.format_exc(limit=4)}


# --------------------------------------------------------------------------- signed distance

class MeshCtx:
    """One mesh as every tool takes it, built outside the timed calls."""

    def __init__(self, name, verts, tris, mods):
        self.name, self.V, self.F = name, np.ascontiguousarray(verts, np.float64), np.ascontiguousarray(tris, np.int64)
        self.diag = float(np.linalg.norm(self.V.max(0) - self.V.min(0)))
        self.mods = mods
        self.vmesh = mods["volga"].Mesh(self.V, self.F) if mods.get("volga") else None
        o3d = mods.get("open3d")
        if o3d is not None:
            self.o3d_legacy = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(self.V),
                                                        o3d.utility.Vector3iVector(self.F.astype(np.int32)))
            self.o3d_t = o3d.t.geometry.TriangleMesh.from_legacy(self.o3d_legacy)


def sdf_calls(ctx, P, P_tm, only=None):
    """{tool: zero-argument timed call returning distances, negative inside} of the main
    comparison, where every call builds the tool's acceleration structure (a volga.Mesh
    keeps the structures its queries build, so the call makes a fresh one), and
    {tool: call} of the same queries on a structure built before (query only) for the
    tools that can keep one: volga (a reused Mesh), Open3D (a reused RaycastingScene),
    pysdf (a reused SDF object)."""
    m = {t: (mod if only is None or t == only else None) for t, mod in ctx.mods.items()}
    calls, reused = {}, {}
    if m["volga"] is not None:
        volga = m["volga"]
        calls["volga"] = lambda: np.asarray(volga.signed_distance(volga.Mesh(ctx.V, ctx.F), P))
        reused["volga"] = lambda: np.asarray(volga.signed_distance(ctx.vmesh, P))
    if m["libigl"] is not None:
        igl = m["libigl"]
        # returns (S, I, C, N); S is kept, C (closest points) is looked at afterwards
        calls["libigl"] = lambda: igl.signed_distance(
            P, ctx.V, ctx.F, sign_type=igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)
    if m["open3d"] is not None:
        o3d = m["open3d"]
        P32 = o3d.core.Tensor(np.ascontiguousarray(P, np.float32))

        def o3d_call():
            scene = o3d.t.geometry.RaycastingScene()
            scene.add_triangles(ctx.o3d_t)
            return scene.compute_signed_distance(P32).numpy()
        calls["open3d"] = o3d_call
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(ctx.o3d_t)
        reused["open3d"] = lambda: scene.compute_signed_distance(P32).numpy()
    if m["pysdf"] is not None:
        pysdf = m["pysdf"]
        # pysdf takes float32 vertices and points, uint32 faces (converted outside the
        # timed call); it runs n_threads=2 threads by default (this machine has 2 cores)
        V32, F32 = np.ascontiguousarray(ctx.V, np.float32), np.ascontiguousarray(ctx.F, np.uint32)
        Pf = np.ascontiguousarray(P, np.float32)
        calls["pysdf"] = lambda: -np.asarray(pysdf.SDF(V32, F32)(Pf))  # positive inside
        sdf_obj = pysdf.SDF(V32, F32)
        reused["pysdf"] = lambda: -np.asarray(sdf_obj(Pf))
    if m["trimesh"] is not None:
        trimesh = m["trimesh"]
        calls["trimesh"] = lambda: -np.asarray(trimesh.proximity.signed_distance(
            trimesh.Trimesh(ctx.V, ctx.F, process=False), P_tm))  # positive inside
        # its warm-up runs on 1,000 points: the call is 4 ms a point on the bunny
        calls["trimesh"].warmup = lambda: trimesh.proximity.signed_distance(
            trimesh.Trimesh(ctx.V, ctx.F, process=False), P_tm[:1000])
    return calls, reused


def choose_points(ctx, P, P_tm, tool, max_call):
    """How many of the points the tool's timed calls use: all, unless a probe predicts
    one call over max_call seconds; then a prefix sized to take about max_call. Probe:
    one call on 1,000 points (t1) and, when affordable, on 10,000 (t2); predicted time
    t1 + (t2 - t1)/9,000 · (n - 1,000), or t1 · n/1,000 without t2."""
    n = len(P)
    n1 = min(1000, n)

    def t_of(k):
        c = sdf_calls(ctx, P[:k], P_tm, only=tool)[0][tool]
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            c()
        return time.perf_counter() - t0
    try:
        t1 = t_of(n1)
        probe = {"points": [n1], "seconds": [t1]}
        if n1 == n or t1 * n / n1 <= max_call:
            return n, probe
        n2 = min(10 * n1, n)
        slope = t1 / n1
        if t1 * n2 / n1 <= max_call / 2:
            t2 = t_of(n2)
            probe["points"].append(n2)
            probe["seconds"].append(t2)
            slope = max((t2 - t1) / (n2 - n1), 1e-12)
            if t1 + slope * (n - n1) <= max_call:
                return n, probe
        k = int(n1 + max(0.0, max_call - t1) / slope)
        return int(min(n, max(n1, k))), probe
    except Exception as e:  # the real run reports the error
        return n, {"error": f"{type(e).__name__}: {e}"}


def bench_sdf_mesh(ctx, args, log):
    rng = np.random.default_rng([args.seed, 7, sum(map(ord, ctx.name))])
    P, diag = sample_points(ctx.V, ctx.F, args.points, rng)
    n_tm = min(args.trimesh_points, len(P))
    n_chk = min(args.check_points, len(P))
    P_tm = P[:n_tm]              # points are shuffled: any prefix is a random subset
    chk = np.arange(n_chk)       # the same check subset for every tool

    t0 = time.perf_counter()
    w = winding_numbers(ctx.V, ctx.F, P[chk])
    wn_time = time.perf_counter() - t0
    res = {"mesh": ctx.name, "triangles": int(len(ctx.F)), "vertices": int(len(ctx.V)),
           "diagonal": diag, "edges": edge_stats(ctx.F), "points": int(len(P)),
           "trimesh_points": n_tm, "check_points": n_chk, "reference_seconds": wn_time,
           "reference_inside": int((w >= 0.5).sum()), "tools": {}}

    outputs, closest = {}, {}
    calls, _ = sdf_calls(ctx, P, P_tm)
    for tool, call in calls.items():
        if tool not in args.tools:
            continue
        log(f"  sdf {ctx.name:20s} {tool:8s} ...")
        n_used, probe = len(P), None
        if tool != "trimesh":
            n_used, probe = choose_points(ctx, P, P_tm, tool, args.max_call_seconds)
            if n_used < len(P):
                call = sdf_calls(ctx, P[:n_used], P_tm, only=tool)[0][tool]
                log(f"    too slow for {len(P):,} points within --max-call-seconds: "
                    f"{n_used:,} points, time extrapolated (probe {probe})")
        out, r = run_tool(call, args.repeat, warmup_fn=getattr(call, "warmup", None),
                          budget=args.budget_seconds)
        if probe is not None:
            r["probe"] = probe
        if out is not None and tool == "libigl":
            # libigl's S with the fast winding number sign is (1 - 2w)·distance, not
            # ±distance: also keep the distance to its closest points C.
            closest[tool] = np.linalg.norm(np.asarray(out[2]) - P[:n_used], axis=1)
            out = out[0]
        if out is not None:
            out = np.asarray(out, np.float64).reshape(-1)
            if tool == "trimesh":
                n_used = n_tm
            if n_used < len(P):
                r["subset_points"] = n_used
                r["seconds_per_point"] = r["median"] / n_used
                r["extrapolated_median"] = r["median"] * len(P) / n_used
            r["nonfinite"] = int((~np.isfinite(out)).sum())
            # e.g. pysdf's ±1.8e19 (2^64) on some points inside open meshes
            r["absurd_values"] = int((np.abs(out) > 10 * diag).sum())
            outputs[tool] = out
        res["tools"][tool] = r
        log(f"    {r.get('median', float('nan')):.4f} s  {r['status']} {r.get('error', '')}")
        gc.collect()

    # Exact unsigned distance for the ambiguity filter: volga's if it ran, else libigl's
    # point_mesh_squared_distance (exact, no sign), else none.
    dref, dref_src = np.full(n_chk, np.nan), []
    if "volga" in outputs:
        k = min(n_chk, len(outputs["volga"]))
        dref[:k] = np.abs(outputs["volga"][:k])
        dref_src.append("volga")
    if np.isnan(dref).any() and ctx.mods.get("libigl") is not None:
        miss = np.flatnonzero(np.isnan(dref))
        sq = ctx.mods["libigl"].point_mesh_squared_distance(P[chk[miss]], ctx.V, ctx.F)[0]
        dref[miss] = np.sqrt(sq)
        dref_src.append("libigl point_mesh_squared_distance")
    ambiguous = (np.abs(w - 0.5) < 1e-3) | (dref < 1e-9 * diag)
    ref_inside = w >= 0.5
    res.update(ambiguous=int(ambiguous.sum()), distance_reference=dref_src)

    for tool, out in outputs.items():
        r = res["tools"][tool]
        n_out = len(out)
        ok = (chk < n_out) & ~ambiguous
        idx = chk[ok]
        tool_inside = out[idx] < 0
        wrong = tool_inside != ref_inside[ok]
        r["sign_checked"] = int(ok.sum())
        r["wrong_signs"] = int(wrong.sum())
        r["wrong_inside_as_outside"] = int((wrong & ref_inside[ok]).sum())
        r["wrong_outside_as_inside"] = int((wrong & ~ref_inside[ok]).sum())
        if wrong.any():
            k = int(np.flatnonzero(wrong)[0])
            r["first_wrong"] = {"point": P[idx[k]].tolist(), "winding_number": float(w[ok][k]),
                                "distance": float(out[idx[k]])}
        if "volga" in outputs and tool != "volga":
            k = min(n_out, len(outputs["volga"]))   # the common prefix, if either ran on a subset
            err = np.abs(np.abs(out[:k]) - np.abs(outputs["volga"][:k]))
            r["distance_compared_points"] = k
            r["max_abs_distance_error"] = float(np.nanmax(err)) if k else None
            r["max_abs_distance_error_rel_diag"] = r["max_abs_distance_error"] / diag if k else None
            r["p99_abs_distance_error"] = float(np.nanpercentile(err, 99)) if k else None
            if tool in closest:
                k = min(len(closest[tool]), len(outputs["volga"]))
                err = np.abs(closest[tool][:k] - np.abs(outputs["volga"][:k]))
                r["closest_point_max_abs_distance_error"] = float(np.nanmax(err))
                r["closest_point_max_abs_distance_error_rel_diag"] = float(np.nanmax(err)) / diag
        if tool != "volga" and "volga" in res["tools"] and res["tools"]["volga"].get("status") == "ok":
            vr = res["tools"]["volga"]
            base = vr.get("extrapolated_median", vr["median"])
            t = r.get("extrapolated_median", r["median"])
            r["ratio_to_volga"] = t / base if base > 0 else None

    # Query only: the same points on a structure built beforehand (outside the timing).
    res["reused"] = {}
    for tool in ("volga", "open3d", "pysdf") if args.reused else ():
        if tool not in args.tools or tool not in outputs:
            continue
        n_used = res["tools"][tool].get("subset_points", len(P))
        call = sdf_calls(ctx, P[:n_used], P_tm, only=tool)[1][tool]
        log(f"  sdf {ctx.name:20s} {tool:8s} (structure reused) ...")
        out, r = run_tool(call, args.repeat, budget=args.budget_seconds)
        if out is not None:
            out = np.asarray(out, np.float64).reshape(-1)
            if n_used < len(P):
                r["subset_points"] = n_used
                r["extrapolated_median"] = r["median"] * len(P) / n_used
            r["max_abs_difference_to_fresh"] = float(np.nanmax(np.abs(out - outputs[tool][:len(out)])))
        res["reused"][tool] = r
        log(f"    {r.get('median', float('nan')):.4f} s  {r['status']} {r.get('error', '')}")
        del out
        gc.collect()
    base = res["reused"].get("volga", {})
    for tool, r in res["reused"].items():
        if tool != "volga" and r.get("status") == "ok" and base.get("status") == "ok" and base["median"] > 0:
            r["ratio_to_volga"] = (r.get("extrapolated_median", r["median"])
                                   / base.get("extrapolated_median", base["median"]))
    return res


# --------------------------------------------------------------------------- voxelization

def bool_grid(ijk, index_to_centre, pad=1):
    """A dense bool array holding voxels `ijk` (K,3), shifted so that the set starts at
    `pad` (an empty layer around it), and the 4x4 index -> world (voxel centres) transform
    of that array, given the tool's own index -> centre transform."""
    ijk = np.asarray(ijk, np.int64).reshape(-1, 3)
    lo = ijk.min(0)
    q = ijk - lo + pad
    arr = np.zeros(tuple(q.max(0) + 1 + pad), bool)
    arr[q[:, 0], q[:, 1], q[:, 2]] = True
    shift = np.eye(4)
    shift[:3, 3] = lo - pad
    return arr, np.asarray(index_to_centre, np.float64) @ shift


def vox_calls(ctx, h):
    m = ctx.mods
    calls = {}
    if m["volga"] is not None:
        volga = m["volga"]
        calls["volga"] = lambda: volga.voxelize(ctx.vmesh, pitch=h, mode="surface", separability=26)
    if m["trimesh"] is not None:
        trimesh = m["trimesh"]
        calls["trimesh"] = lambda: trimesh.Trimesh(ctx.V, ctx.F, process=False).voxelized(pitch=h)
    if m["open3d"] is not None:
        o3d = m["open3d"]
        calls["open3d"] = lambda: o3d.geometry.VoxelGrid.create_from_triangle_mesh(ctx.o3d_legacy, voxel_size=h)
    return calls


def peer_voxels(tool, out, h):
    """(ijk (K,3), index -> centre 4x4) of a peer's result."""
    if tool == "trimesh":
        return np.asarray(out.sparse_indices, np.int64), np.asarray(out.transform, np.float64)
    if tool == "open3d":
        ijk = np.array([v.grid_index for v in out.get_voxels()], np.int64).reshape(-1, 3)
        # Open3D's voxel (i, j, k) spans origin + [i, i+1)·h: its centre is origin + (i + ½)h.
        T = np.diag([h, h, h, 1.0])
        T[:3, 3] = np.asarray(out.origin, np.float64) + 0.5 * h
        return ijk, T
    raise ValueError(tool)


def summarize_validation(rep):
    report = rep.get("report") or {}
    mesh = report.get("mesh") or {}
    return {
        "passed": rep.get("passed"),
        "voxels": report.get("voxels"),
        "tunnel_count": mesh.get("tunnel_count"),
        "covers": mesh.get("covers"),
        "uncovered_triangle_count": mesh.get("uncovered_triangle_count"),
        "requirements": rep.get("requirements"),
    }


def bench_vox_mesh(ctx, n, args, log, state):
    volga = ctx.mods["volga"]
    h = float((ctx.V.max(0) - ctx.V.min(0)).max()) / n
    res = {"mesh": ctx.name, "resolution": n, "pitch": h, "tools": {}}
    require = ["separating", "cover"]
    for tool, call in vox_calls(ctx, h).items():
        if tool not in args.tools:
            continue
        log(f"  vox {ctx.name:16s} N={n:<4d} {tool:8s} ...")
        out, r = run_tool(call, args.repeat, budget=args.budget_seconds)
        res["tools"][tool] = r
        if out is None:
            log(f"    {r['status']} {r.get('error', '')}")
            continue
        try:
            if tool == "volga":
                ijk = np.asarray(out.sparse_indices).reshape(-1, 3)
                r["voxels"] = int(len(ijk))
                r["stats"] = out.stats if isinstance(out.stats, dict) else str(out.stats)
                r["shape"] = list(map(int, out.shape))
                t0 = time.perf_counter()
                rep = volga.validate(out, connectivity=26, mesh=ctx.vmesh, require=require)
                r["validate_seconds"] = time.perf_counter() - t0
                if not state.get("array_path_checked"):
                    # The bool-array path the peers go through, on volga's own grid: it
                    # must give the same verdict as validating the grid object.
                    rep2 = volga.validate(np.asarray(out.matrix, bool), connectivity=26, mesh=ctx.vmesh,
                                          transform=np.asarray(out.transform, np.float64), require=require)
                    state["array_path_checked"] = {
                        "mesh": ctx.name, "resolution": n,
                        "grid": summarize_validation(rep), "array": summarize_validation(rep2),
                        "agree": summarize_validation(rep) == summarize_validation(rep2)}
                    log(f"    array-path self-check agree={state['array_path_checked']['agree']}")
            else:
                ijk, T0 = peer_voxels(tool, out, h)
                r["voxels"] = int(len(ijk))
                if volga is not None and len(ijk):
                    arr, T = bool_grid(ijk, T0)
                    t0 = time.perf_counter()
                    rep = volga.validate(arr, connectivity=26, mesh=ctx.vmesh, transform=T, require=require)
                    r["validate_seconds"] = time.perf_counter() - t0
                else:
                    rep = None
            if rep is not None:
                if not state.get("printed_keys"):
                    state["printed_keys"] = True
                    log(f"    validate() keys: {sorted(rep.keys())}; report keys: {sorted((rep.get('report') or {}).keys())}; "
                        f"report.mesh keys: {sorted(((rep.get('report') or {}).get('mesh') or {}).keys())}")
                r["validation"] = summarize_validation(rep)
        except Exception as e:
            r["validation_error"] = f"{type(e).__name__}: {e}"
            r["validation_traceback"] = traceback.format_exc(limit=4)
        v = r.get("validation") or {}
        log(f"    {r['median']:.4f} s  voxels={r.get('voxels')} passed={v.get('passed')} "
            f"tunnels={v.get('tunnel_count')} covers={v.get('covers')} {r.get('validation_error', '')}")
        del out
        gc.collect()
    base = res["tools"].get("volga", {})
    for tool, r in res["tools"].items():
        if tool != "volga" and r.get("status") == "ok" and base.get("status") == "ok" and base["median"] > 0:
            r["ratio_to_volga"] = r["median"] / base["median"]
    return res


# --------------------------------------------------------------------------- output

def fmt_t(r, key="median"):
    if r is None:
        return "missing"
    if r.get("status") != "ok":
        return "error"
    return f"{r[key]:.3f}" if r[key] >= 0.01 else f"{r[key]:.4f}"


def fmt_sdf(r, tool, repeat):
    """A signed-distance time cell: extrapolated times marked * (trimesh's fixed subset)
    or † (a subset chosen by --max-call-seconds), fewer repeats than asked ‡."""
    if r is None:
        return "—"
    if r.get("status") != "ok":
        return "error"
    if "extrapolated_median" in r:
        c = fmt_t(r, "extrapolated_median") + ("*" if tool == "trimesh" else "†")
    else:
        c = fmt_t(r)
    if r.get("repeat_used", repeat) < repeat:
        c += "‡"
    return c + ("" if tool == "volga" else fmt_ratio(r))


def fmt_ratio(r):
    x = (r or {}).get("ratio_to_volga")
    if x is None:
        return ""
    return f" ({x:.0f}×)" if x >= 100 else f" ({x:.1f}×)" if x >= 10 else f" ({x:.2f}×)" if x >= 0.1 else f" ({x:.2g}×)"


def markdown(results, missing, repeat):
    lines = []
    sdf = results.get("signed_distance", [])
    if sdf:
        pts = sdf[0]["points"]
        lines += [f"### Signed distance, {pts:,} points (median seconds; in brackets peer / volga)", "",
                  "| mesh | triangles | " + " | ".join(SDF_TOOLS) + " |",
                  "|---|---:|" + "---:|" * len(SDF_TOOLS)]
        for m in sdf:
            cells = []
            for tool in SDF_TOOLS:
                r = m["tools"].get(tool)
                if r is None:
                    cells.append("missing" if tool in missing else "—")
                else:
                    cells.append(fmt_sdf(r, tool, repeat))
            lines.append(f"| {m['mesh']} | {m['triangles']:,} | " + " | ".join(cells) + " |")
        tm = sdf[0]["trimesh_points"]
        subs = sorted({f"{t} on {m['mesh']}: {m['tools'][t]['subset_points']:,}" for m in sdf
                       for t in SDF_TOOLS if t != "trimesh" and "subset_points" in m["tools"].get(t, {})})
        lines += ["", f"\\* trimesh ran on {tm:,} of the points; its time is extrapolated linearly "
                      f"(seconds per point × {pts:,}).",
                  "† a probe predicted one call over --max-call-seconds: the tool ran on fewer points "
                  "(" + ("; ".join(subs) if subs else "none") + "), time extrapolated linearly.",
                  f"‡ fewer than {repeat} timed calls (--budget-seconds). Every call includes building the "
                  "tool's acceleration structure.", ""]
        rtools = [t for t in ("volga", "open3d", "pysdf") if any(t in m.get("reused", {}) for m in sdf)]
        if rtools:
            lines += [f"### Signed distance, query only: structure built before, {pts:,} points (median seconds; peer / volga)", "",
                      "| mesh | " + " | ".join(rtools) + " |", "|---|" + "---:|" * len(rtools)]
            for m in sdf:
                cells = []
                for tool in rtools:
                    r = m.get("reused", {}).get(tool)
                    cells.append(fmt_sdf(r, tool, repeat))
                lines.append(f"| {m['mesh']} | " + " | ".join(cells) + " |")
            lines.append("")
        lines += ["### Signs and distances (wrong signs / points checked against the brute-force "
                  "winding number; max | |d| − |d_volga| | as a fraction of the bounding-box diagonal)", "",
                  "| mesh | ambiguous left out | " + " | ".join(SDF_TOOLS) + " |",
                  "|---|---:|" + "---|" * len(SDF_TOOLS)]
        for m in sdf:
            cells = []
            for tool in SDF_TOOLS:
                r = m["tools"].get(tool)
                if r is None or r.get("status") != "ok":
                    cells.append("missing" if r is None else "error")
                    continue
                c = f"{r['wrong_signs']} / {r['sign_checked']}"
                e = r.get("max_abs_distance_error_rel_diag")
                if e is not None:
                    c += f"; err {e:.1e}"
                e = r.get("closest_point_max_abs_distance_error_rel_diag")
                if e is not None:
                    c += f" (closest points: {e:.1e})"
                cells.append(c)
            lines.append(f"| {m['mesh']} | {m['ambiguous']} | " + " | ".join(cells) + " |")
        lines.append("")
    vox = results.get("voxelize", [])
    if vox:
        lines += ["### Surface voxelization (median seconds; peer / volga; volga.validate at 26-connectivity "
                  "against the mesh)", "",
                  "| mesh | N | tool | seconds | voxels | passed | 26-tunnels | covers |",
                  "|---|---:|---|---:|---:|---|---:|---|"]
        for m in vox:
            for tool in VOX_TOOLS:
                r = m["tools"].get(tool)
                if r is None:
                    lines.append(f"| {m['mesh']} | {m['resolution']} | {tool} | "
                                 f"{'missing' if tool in missing else '—'} | | | | |")
                    continue
                v = r.get("validation") or {}
                vox_n = "" if r.get("voxels") is None else f"{r['voxels']:,}"
                tun = "" if v.get("tunnel_count") is None else f"{v['tunnel_count']:,}"
                passed = v.get("passed", r.get("validation_error", ""))
                lines.append(
                    f"| {m['mesh']} | {m['resolution']} | {tool} | {fmt_t(r)}{fmt_ratio(r)} | "
                    f"{vox_n} | {passed} | {tun} | {v.get('covers', '')} |")
        lines.append("")
    return "\n".join(lines)


# --------------------------------------------------------------------------- main

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--data", default=os.path.join(ROOT, "tests", "data"))
    ap.add_argument("--trimesh-points", type=int, default=20_000)
    ap.add_argument("--check-points", type=int, default=2000)
    ap.add_argument("--resolutions", type=int, nargs="+", default=[128, 256])
    ap.add_argument("--json-out", default=None,
                    help="default bench/results/python_peers_<date>.json under the repository")
    ap.add_argument("--seed", type=int, default=20240601)
    ap.add_argument("--meshes", nargs="+", default=None,
                    help=f"subset of {SHARED_MESHES + GENERATED_MESHES}")
    ap.add_argument("--tools", nargs="+", default=SDF_TOOLS, help="subset of " + " ".join(SDF_TOOLS))
    ap.add_argument("--max-call-seconds", type=float, default=60.0,
                    help="a tool whose single signed-distance call a probe predicts over this runs on "
                         "fewer points, its time extrapolated linearly (flagged †)")
    ap.add_argument("--budget-seconds", type=float, default=120.0,
                    help="per tool and case: timed repeats stop once the next would pass this "
                         "(at least one; flagged ‡ when fewer than --repeat)")
    ap.add_argument("--reused", action="store_true",
                    help="also time queries on a structure built beforehand (volga Mesh, Open3D scene, pysdf SDF)")
    ap.add_argument("--resume", action="store_true",
                    help="keep the cases already in --json-out (from an interrupted run) and run the rest")
    ap.add_argument("--skip-sdf", action="store_true")
    ap.add_argument("--skip-voxelize", action="store_true")
    ap.add_argument("--self-check", action="store_true", help="only run the reference self-checks")
    args = ap.parse_args(argv)

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    self_check_winding()
    gen_stats = self_check_meshes(args.seed)
    log("self-checks passed (winding number on a tetrahedron / sphere; generated meshes: "
        + ", ".join(f"{k}: {v['boundary_edges']} boundary, {v['same_direction_edges']} same-direction, "
                    f"{v['degenerate_edges']} degenerate edges" for k, v in gen_stats.items()) + ")")
    if args.self_check:
        return 0

    mods, errors = import_tools()
    missing = sorted(errors)
    for t in missing:
        log(f"missing: {t} ({errors[t]})")
    date = datetime.datetime.now().strftime("%Y-%m-%d")
    json_out = args.json_out or os.path.join(ROOT, "bench", "results", f"python_peers_{date}.json")
    results = {
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "command": [sys.executable] + sys.argv,
        "args": vars(args),
        "machine": machine_info(),
        "versions": versions(),
        "missing": {t: errors[t] for t in missing},
        "generated_mesh_edges": gen_stats,
        "notes": [
            "times are medians of --repeat calls after one warm-up; only the library call is timed",
            "each signed-distance call includes building the tool's acceleration structure",
            "trimesh signed distance runs on --trimesh-points points; extrapolated_median = median * points / trimesh_points",
            "pysdf and trimesh return positive inside; they are negated",
            "Open3D gets float32 points",
            "wrong signs: against the brute-force generalized winding number (inside iff w >= 1/2) on --check-points points",
        ],
    }

    names = args.meshes or (SHARED_MESHES + GENERATED_MESHES)
    meshes = {}
    for name in names:
        if name in GENERATED_MESHES:
            meshes[name] = generated_mesh(name, args.seed)
        else:
            meshes[name] = load_obj(os.path.join(args.data, name + ".obj"))

    os.makedirs(os.path.dirname(os.path.abspath(json_out)), exist_ok=True)

    def save():
        # written after every case, so an interrupted run keeps what it measured
        results["markdown"] = markdown(results, missing, args.repeat)
        tmp = json_out + ".tmp"
        with open(tmp, "w") as f:
            json.dump(results, f, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
        os.replace(tmp, json_out)

    # --resume: keep the cases an interrupted run already wrote to --json-out (same
    # options assumed), run the others, and note the restart.
    prev = {}
    if args.resume and os.path.exists(json_out):
        with open(json_out) as f:
            prev = json.load(f)
        keep = {k: prev[k] for k in ("date", "command", "machine", "voxelize", "signed_distance",
                                     "validate_array_path_self_check", "loadavg_after_voxelize") if k in prev}
        restart = {"date": results["date"], "command": results["command"], "machine": results["machine"],
                   "kept_voxelize": len(prev.get("voxelize", [])),
                   "kept_signed_distance": [m["mesh"] for m in prev.get("signed_distance", [])]}
        results.update(keep)
        results["resumed"] = prev.get("resumed", []) + [restart]
        log(f"resuming {json_out}: keeping {restart['kept_voxelize']} voxelization cases and "
            f"signed distance on {restart['kept_signed_distance']}")
    done_vox = {(m["mesh"], m["resolution"]) for m in prev.get("voxelize", [])}
    done_sdf = {m["mesh"] for m in prev.get("signed_distance", [])}

    # Voxelization first: it is short, and the signed-distance part is the long one.
    if not args.skip_voxelize:
        results["voxelize"] = list(prev.get("voxelize", []))
        state = {"array_path_checked": prev.get("validate_array_path_self_check"),
                 "printed_keys": bool(prev)}
        for name in names:
            if name not in SHARED_MESHES or all((name, n) in done_vox for n in args.resolutions):
                continue
            ctx = MeshCtx(name, *meshes[name], mods)
            for n in args.resolutions:
                if (name, n) in done_vox:
                    continue
                results["voxelize"].append(bench_vox_mesh(ctx, n, args, log, state))
                results["validate_array_path_self_check"] = state.get("array_path_checked")
                save()
        results["loadavg_after_voxelize"] = list(os.getloadavg())

    if not args.skip_sdf:
        results["signed_distance"] = list(prev.get("signed_distance", []))
        for name, (v, f) in meshes.items():
            if name in done_sdf:
                continue
            ctx = MeshCtx(name, v, f, mods)
            log(f"signed distance: {name} ({len(f):,} triangles)")
            results["signed_distance"].append(bench_sdf_mesh(ctx, args, log))
            results["loadavg_now"] = list(os.getloadavg())
            save()
            del ctx
            gc.collect()
    results["loadavg_at_end"] = list(os.getloadavg())
    results["complete"] = True

    save()
    print(results["markdown"])
    log(f"wrote {json_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
