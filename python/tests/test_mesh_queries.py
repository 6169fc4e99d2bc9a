"""Meshes in, and the point queries: exact distances, certified signs and winding numbers
against brute-force numpy references, on clean and unclean meshes."""

from __future__ import annotations

import pickle
from types import SimpleNamespace

import numpy as np
import pytest
import volga

from conftest import brute_distance, brute_winding, cube, unclean_corpus, uv_sphere, write_obj


def box_distance(p, lo=-1.0, hi=1.0):
    c = 0.5 * (lo + hi)
    h = 0.5 * (hi - lo)
    q = np.abs(p - c) - h
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


def random_points(v, n, seed=0, pad=0.2):
    rng = np.random.default_rng(seed)
    lo, hi = v.min(0), v.max(0)
    ext = hi - lo
    ext = np.where(ext > 0, ext, 1.0)
    return lo - pad * ext + (1 + 2 * pad) * ext * rng.random((n, 3))


# ---------------------------------------------------------------- meshes in

@pytest.mark.parametrize("vdtype", [np.float64, np.float32, np.int64])
@pytest.mark.parametrize("fdtype", [np.int64, np.int32, np.uint32, np.uint64])
def test_mesh_accepts_any_dtype(vdtype, fdtype):
    v, f = cube()
    m = volga.Mesh(v.astype(vdtype), f.astype(fdtype))
    assert m.vertices.dtype == np.float64 and m.faces.dtype == np.int64
    np.testing.assert_array_equal(m.vertices, v.astype(vdtype).astype(np.float64))
    np.testing.assert_array_equal(m.faces, f)
    assert m.is_closed and m.boundary_edges == 0 and len(m) == 12


def test_mesh_accepts_non_contiguous_arrays_trimesh_objects_and_pairs():
    v, f = cube()
    wide = np.zeros((len(v), 6))
    wide[:, ::2] = v  # strided view
    fortran = np.asfortranarray(f)
    a = volga.Mesh(wide[:, ::2], fortran)
    np.testing.assert_array_equal(a.vertices, v)
    fake_trimesh = SimpleNamespace(vertices=v, faces=f)
    p = np.array([[0.3, 0.2, -0.4], [2.0, 0.0, 0.0]])
    ref = volga.signed_distance((v, f), p)
    np.testing.assert_array_equal(volga.signed_distance(fake_trimesh, p), ref)
    np.testing.assert_array_equal(volga.signed_distance(a, p), ref)
    np.testing.assert_array_equal(volga.signed_distance(a, np.asfortranarray(p)), ref)
    np.testing.assert_array_equal(volga.signed_distance(a, p.astype(np.float32)), volga.signed_distance(a, p.astype(np.float32).astype(np.float64)))
    np.testing.assert_array_equal(volga.signed_distance(a, p.tolist()), ref)


def test_mesh_bad_input_names_the_argument():
    v, f = cube()
    with pytest.raises(ValueError, match="vertices"):
        volga.Mesh(v[:, :2], f)
    with pytest.raises(ValueError, match=r"faces\[3\] names vertex 8"):
        bad = f.copy()
        bad[3, 1] = 8
        volga.Mesh(v, bad)
    with pytest.raises(ValueError, match=r"faces\[0\] names vertex -1"):
        bad = f.copy()
        bad[0, 0] = -1
        volga.Mesh(v, bad)
    with pytest.raises(ValueError, match=r"vertices\[2\] is not finite"):
        w = v.copy()
        w[2, 1] = np.nan
        volga.Mesh(w, f)
    with pytest.raises(ValueError, match="points"):
        volga.signed_distance((v, f), np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"points\[1\] is not finite"):
        volga.signed_distance((v, f), np.array([[0, 0, 0], [np.inf, 0, 0]]))
    with pytest.raises(ValueError, match="mesh"):
        volga.signed_distance(42, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="threads"):
        volga.signed_distance((v, f), np.zeros((1, 3)), threads=0)
    with pytest.raises(ValueError, match="tolerance"):
        volga.winding_number((v, f), np.zeros((1, 3)), tolerance=-1.0)
    with pytest.raises(ValueError, match="faces: expected integer vertex indices"):
        volga.Mesh(v, f + 0.5)
    with pytest.raises(ValueError, match="faces: expected integer vertex indices"):
        volga.Mesh(v, f.astype(bool))
    with pytest.raises(ValueError, match="vertices: expected real numbers"):
        volga.Mesh(v.astype(complex), f)
    with pytest.raises(ValueError, match="points: expected real numbers"):
        volga.signed_distance((v, f), [["a", "b", "c"]])


def test_load_mesh_reads_obj_and_reports_errors(tmp_path):
    v, f = uv_sphere()
    path = write_obj(tmp_path / "s.obj", v, f)
    m = volga.load_mesh(path)
    np.testing.assert_array_equal(m.vertices, v)
    np.testing.assert_array_equal(m.faces, f)
    assert m.is_closed
    assert volga.load_mesh(str(path)).faces.shape == f.shape
    with pytest.raises(OSError, match="missing.obj"):
        volga.load_mesh(tmp_path / "missing.obj")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    with pytest.raises(ValueError, match="bad.obj"):
        volga.load_mesh(bad)
    big = tmp_path / "big.obj"
    big.write_text("v 0 0 0\n" * 1000)
    with pytest.raises(MemoryError, match="big.obj"):
        volga.load_mesh(big, memory_limit=1000)


def test_mesh_pickles():
    v, f = uv_sphere()
    m = volga.Mesh(v, f)
    m2 = pickle.loads(pickle.dumps(m))
    np.testing.assert_array_equal(m2.vertices, m.vertices)
    np.testing.assert_array_equal(m2.faces, m.faces)
    assert "closed" in repr(m2)


# ---------------------------------------------------------------- exact references

def test_signed_distance_of_a_cube_is_the_exact_box_distance():
    v, f = cube()
    p = random_points(v, 3000, seed=1, pad=0.5)
    d = volga.signed_distance((v, f), p)
    np.testing.assert_allclose(d, box_distance(p), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", list(unclean_corpus()))
def test_signs_and_distances_match_brute_force_on_unclean_meshes(name):
    v, f = unclean_corpus()[name]
    p = random_points(v, 400, seed=hash(name) % 1000)
    # points near the surface too (the hard part of the sign)
    rng = np.random.default_rng(3)
    tri = v[f[rng.integers(0, len(f), 200)]]
    bary = rng.dirichlet([1, 1, 1], 200)
    near = (bary[:, :, None] * tri).sum(1) + rng.normal(0, 1e-3, (200, 3)) * np.ptp(v, axis=0).max()
    p = np.concatenate([p, near])
    w = brute_winding(v, f, p)
    d = volga.signed_distance((v, f), p)
    ins = volga.inside((v, f), p)
    decided = np.abs(w - 0.5) > 1e-6
    assert decided.sum() > 300
    np.testing.assert_array_equal(ins[decided], w[decided] >= 0.5)
    np.testing.assert_array_equal((d < 0)[decided], w[decided] >= 0.5)
    scale = max(1.0, np.abs(v).max())
    np.testing.assert_allclose(np.abs(d), brute_distance(v, f, p), rtol=1e-9, atol=1e-12 * scale)
    wn = volga.winding_number((v, f), p, tolerance=1e-9)
    np.testing.assert_allclose(wn, w, rtol=0, atol=1e-8)


def test_winding_number_tolerance_is_honoured():
    v, f = uv_sphere(rings=24, segments=48)
    p = random_points(v, 500, seed=4)
    exact = brute_winding(v, f, p)
    for tol in (1e-2, 1e-4, 1e-7):
        w = volga.winding_number((v, f), p, tolerance=tol)
        assert np.abs(w - exact).max() <= tol + 1e-12


def test_default_winding_number_is_the_fast_approximation():
    v, f = unclean_corpus()["open_cap"]
    p = random_points(v, 2000, seed=8)
    exact = brute_winding(v, f, p)
    fast = volga.winding_number((v, f), p)
    assert np.abs(fast - exact).max() < 5e-2
    np.testing.assert_array_equal(volga.winding_number((v, f), p, threads=1), fast)


def test_empty_mesh_is_infinitely_far():
    m = volga.Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
    assert np.isinf(volga.signed_distance(m, [[0.0, 0.0, 0.0]])).all()


# ---------------------------------------------------------------- threads and scale

def test_results_are_identical_for_any_thread_count():
    v, f = unclean_corpus()["overlapping"]
    p = random_points(v, 20000, seed=5)
    runs = [volga.signed_distance((v, f), p, threads=t) for t in (1, 2, 3)]
    for r in runs[1:]:
        np.testing.assert_array_equal(r.view(np.uint64), runs[0].view(np.uint64))
    wins = [volga.winding_number((v, f), p[:3000], threads=t) for t in (1, 3)]
    np.testing.assert_array_equal(wins[0], wins[1])
    assert volga.default_threads() >= 1


def test_many_points_stream_without_a_points_by_triangles_matrix():
    v, f = uv_sphere(rings=32, segments=64)  # ~4000 triangles
    p = random_points(v, 300_000, seed=6)
    d = volga.signed_distance((v, f), p)  # 300k × 4000 × 8 bytes would be 9.6 GB
    assert d.shape == (300_000,) and np.isfinite(d).all()
    r = np.linalg.norm(p - v.mean(0), axis=1)
    far = np.abs(r - 1.0) > 0.05
    np.testing.assert_array_equal((d < 0)[far], (r < 1.0)[far])


def test_heavy_calls_release_the_gil():
    import threading

    v, f = uv_sphere(rings=48, segments=96)
    p = random_points(v, 400_000, seed=7)
    done = threading.Event()
    result = {}

    def work():
        result["d"] = volga.signed_distance((v, f), p, threads=1)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    spins = 0
    while not done.is_set():
        spins += 1  # runs only while the worker does not hold the GIL
    t.join()
    assert result["d"].shape == (400_000,)
    # a call that held the GIL for its whole duration would leave this loop a few
    # switch intervals (5 ms each) at most: thousands of iterations, not millions
    assert spins > 100_000, spins
