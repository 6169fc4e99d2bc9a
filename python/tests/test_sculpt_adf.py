"""volga.Sculpt and volga.Adf: edits against independent formulas, the CLI's bytes,
undo/redo, files, pickling; ADF distances against exact references."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest
import volga

from conftest import cube, edge_face_check, uv_sphere

W = 2 * np.sqrt(3)  # the oriented box filter's width in voxels (survey §17.4)


def ramp(d, h):
    """Density of the filter at signed distance d (world) for voxels of side h."""
    return np.clip(0.5 - d / (W * h), 0.0, 1.0)


def box_sd(p, lo, hi):
    c, e = (np.asarray(lo) + hi) / 2, (np.asarray(hi) - lo) / 2
    q = np.abs(p - c) - e
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)


def voxel_centres(s, step=1):
    st = s.stats
    n = st["dims"]
    ijk = np.stack(np.meshgrid(*[np.arange(0, n, step)] * 3, indexing="ij"), -1).reshape(-1, 3)
    return np.asarray(st["origin"]) + ijk * st["voxel_size"]


BOX = {"Box": {"min": [-0.6, -0.6, -0.6], "max": [0.6, 0.6, 0.6]}}
BALL = {"Sphere": {"center": [0.6, 0.6, 0.6], "radius": 0.45}}


def test_carve_and_add_follow_the_filter_formula():
    h = 0.05
    s = volga.Sculpt(((-1, -1, -1), (1, 1, 1)), h, BOX, colour=(0.8, 0.7, 0.6))
    p = voxel_centres(s, step=3)
    block = ramp(box_sd(p, [-0.6] * 3, [0.6] * 3), h)
    before = s.value(p)
    np.testing.assert_allclose(before, block, atol=1e-6)
    report = s.carve(BALL)
    tool = ramp(np.linalg.norm(p - 0.6, axis=1) - 0.45, h)
    carved = np.minimum(block, 1 - tool)
    np.testing.assert_allclose(s.value(p), carved, atol=1e-6)
    lo, hi = np.array(report["changed_world"])
    moved = s.value(p) != before
    assert moved.any()
    assert (p[moved] >= lo).all() and (p[moved] <= hi).all()
    s.add({"Sphere": {"center": [-0.6, -0.6, -0.6], "radius": 0.3}})
    added = np.maximum(carved, ramp(np.linalg.norm(p + 0.6, axis=1) - 0.3, h))
    np.testing.assert_allclose(s.value(p), added, atol=1e-6)
    assert s.undo() and s.undo_len == 1
    np.testing.assert_allclose(s.value(p), carved, atol=1e-6)
    assert s.redo() and not s.redo()
    np.testing.assert_allclose(s.value(p), added, atol=1e-6)
    # an edit outside the grid changes nothing
    assert s.carve({"Sphere": {"center": [9, 9, 9], "radius": 0.1}}) == {"changed_voxels": None, "changed_world": None}


def test_spray_falloff_and_paint():
    h = 0.05
    s = volga.Sculpt(((-1, -1, -1), (1, 1, 1)), h, None)
    p = voxel_centres(s, step=2)
    assert (s.value(p) == 0).all()
    s.spray({"Sphere": {"center": [0, 0, 0], "radius": 0.4}}, strength=0.5, falloff=0.1)
    v = s.value(p)
    r = np.linalg.norm(p, axis=1)
    assert v[r < 0.2].min() == pytest.approx(0.5, abs=1e-6)
    assert (v[r > 0.4 + 0.1 + W * h] == 0).all()
    inner, outer = v[(r > 0.41) & (r < 0.44)], v[(r > 0.46) & (r < 0.49)]
    assert inner.size and outer.size and inner.min() > 0 and inner.mean() > outer.mean()
    s.paint({"Sphere": {"center": [0, 0, 0], "radius": 0.2}}, colour=(0.1, 0.9, 0.2))
    assert s.stats["coloured_bricks"] + s.stats["uniform"] > 0


def test_python_sculpt_equals_the_cli_sculpt(tmp_path, volga_cli):
    strokes = {
        "start": {"bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}, "voxel_size": 0.04,
                  "object": {"shape": BOX, "colour": [0.8, 0.7, 0.55]}},
        "strokes": [
            {"op": "Carve", "tool": BALL},
            {"op": "Carve", "tool": {"Sphere": {"center": [0, 0, 0], "radius": 0.08}},
             "path": [[-0.8, 0.3, 0.6], [0.0, 0.35, 0.6], [0.8, 0.3, 0.6]]},
            {"op": {"Spray": {"strength": 1.0, "falloff": 0.05}}, "tool": {"Sphere": {"center": [-0.35, -0.1, 0.62], "radius": 0.15}}},
            {"op": {"Paint": {"colour": [0.2, 0.35, 0.9], "strength": 1.0}}, "tool": {"Sphere": {"center": [-0.35, -0.1, 0.7], "radius": 0.25}}},
            {"op": {"Smooth": {"strength": 1.0}}, "tool": {"Sphere": {"center": [0.6, 0.6, 0.6], "radius": 0.6}},
             "rotation_deg": [0, 0, 30], "translate": [0.0, -0.1, 0.0]},
        ],
    }
    (tmp_path / "s.json").write_text(json.dumps(strokes))
    volga_cli("sculpt", "--strokes", tmp_path / "s.json", "--out", tmp_path / "cli.vsculpt")
    s = volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 0.04, BOX, colour=(0.8, 0.7, 0.55))
    s.carve(BALL)
    s.saw({"Sphere": {"center": [0, 0, 0], "radius": 0.08}}, path=[[-0.8, 0.3, 0.6], [0.0, 0.35, 0.6], [0.8, 0.3, 0.6]])
    s.spray({"Sphere": {"center": [-0.35, -0.1, 0.62], "radius": 0.15}}, strength=1.0, falloff=0.05)
    s.paint({"Sphere": {"center": [-0.35, -0.1, 0.7], "radius": 0.25}}, colour=(0.2, 0.35, 0.9))
    s.smooth({"Sphere": {"center": [0.6, 0.6, 0.6], "radius": 0.6}}, rotation_deg=[0, 0, 30], translate=[0.0, -0.1, 0.0])
    cli = volga.Sculpt.open(tmp_path / "cli.vsculpt")
    assert cli.to_bytes() == s.to_bytes()


def test_sculpt_files_pickles_meshes_grids_and_mesh_tools(tmp_path):
    s = volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 0.05, {"Sphere": {"center": [0, 0, 0], "radius": 0.7}})
    v, f = cube((-0.2, -0.2, 0.3), (0.2, 0.2, 1.2))
    s.carve((v, f))  # a closed mesh as the tool
    assert s.value([[0, 0, 0.6]])[0] == 0.0 and s.value([[0, 0, 0]])[0] == 1.0
    s.save(tmp_path / "a.vsculpt")
    t = volga.Sculpt.open(tmp_path / "a.vsculpt")
    assert t.to_bytes() == s.to_bytes()
    u = pickle.loads(pickle.dumps(s))
    assert u.to_bytes() == s.to_bytes()
    V, F = s.to_mesh()
    closed, oriented = edge_face_check(F)
    assert closed and oriented and len(F) > 100
    g = s.to_grid()
    assert g.kind == "density" and g.shape == (s.stats["dims"],) * 3
    img = s.render(32, 32)
    assert img.shape == (32, 32, 4) and img[..., 3].max() == 255


def test_sculpt_bad_input():
    with pytest.raises(ValueError, match="voxel_size"):
        volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 0.0)
    with pytest.raises(ValueError, match="16384"):
        volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 1e-5)
    with pytest.raises(MemoryError, match=r"4096³ sculpt needs an estimated .*, more than memory_limit=10000000"):
        volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 2 / 4000, {"Sphere": {"center": [0, 0, 0], "radius": 0.9}}, memory_limit=10_000_000)
    with pytest.raises(ValueError, match=r"start\.object\.shape\.Sphere: missing field `radius`"):
        volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 0.1, {"Sphere": {"center": [0, 0, 0]}})
    with pytest.raises(ValueError, match=r"start\.object\.shape\.radius|radius"):
        volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 0.1, {"Sphere": {"center": [0, 0, 0], "radius": -1}})
    s = volga.Sculpt(((-1, -1, -1), (1, 1, 1)), 0.1)
    with pytest.raises(ValueError, match=r"stroke\[0\]\.tool\.radius`: must be finite and > 0, got 0"):
        s.carve({"Sphere": {"center": [0, 0, 0], "radius": 0}})
    with pytest.raises(ValueError, match=r"stroke\.tool: unknown variant `Blob`"):
        s.carve({"Blob": {}})
    with pytest.raises(ValueError, match=r"stroke\.op\.Spray\.strength: nan is not a finite number"):
        s.spray({"Sphere": {"center": [0, 0, 0], "radius": 0.3}}, strength=float("nan"))
    with pytest.raises(ValueError, match=r"stroke\.path\[1\]\[0\]: inf is not a finite number"):
        s.saw({"Sphere": {"center": [0, 0, 0], "radius": 0.3}}, path=[[0, 0, 0], [np.inf, 0, 0]])
    with pytest.raises(ValueError, match=r"stroke\[0\]\.op`: .*strength"):
        s.spray({"Sphere": {"center": [0, 0, 0], "radius": 0.3}}, strength=-2.0)
    with pytest.raises(OSError):
        volga.Sculpt.open("/nonexistent/x.vsculpt")
    with pytest.raises(ValueError, match="magic"):
        volga.Sculpt.from_bytes(b"definitely not a sculpt file at all")


def test_adf_of_a_sphere_is_within_tolerance():
    a = volga.Adf.from_shape({"Sphere": {"center": [0.1, 0, 0], "radius": 1.0}}, tolerance=1e-4)
    rng = np.random.default_rng(0)
    p = rng.uniform(-1.3, 1.3, (5000, 3))
    exact = np.linalg.norm(p - (0.1, 0, 0), axis=1) - 1.0
    near = np.abs(exact) < 0.05
    tol = a.stats["tolerance_world"]
    assert np.abs(a.distance(p)[near] - exact[near]).max() < 2 * tol
    np.testing.assert_array_equal(a.inside(p)[np.abs(exact) > 0.01], (exact < 0)[np.abs(exact) > 0.01])
    g = a.gradient(p[near])
    n = (p[near] - (0.1, 0, 0)) / np.linalg.norm(p[near] - (0.1, 0, 0), axis=1)[:, None]
    assert np.median(np.einsum("ij,ij->i", g, n)) > 0.99
    c = a.closest_point(p[near])
    assert np.abs(np.linalg.norm(c - (0.1, 0, 0), axis=1) - 1.0).max() < 1e-2
    V, F = a.to_mesh()
    assert edge_face_check(F) == (True, True)
    # On its own leaves: closed, every vertex within the tolerance of the sphere.
    for method in ("cubes", "tetrahedra"):
        V, F = a.to_mesh(on_leaves=True, method=method)
        assert edge_face_check(F) == (True, True)
        assert np.abs(np.linalg.norm(V - (0.1, 0, 0), axis=1) - 1.0).max() <= tol
    with pytest.raises(ValueError, match="dual"):
        a.to_mesh(on_leaves=True, method="dual")
    with pytest.raises(ValueError, match="cell"):
        a.to_mesh(cell=0.1, on_leaves=True)


def test_adf_of_an_open_mesh_signs_match_the_mesh_and_pickles():
    v, f = uv_sphere((0, 0, 0), 1.0, 16, 32)
    cen = v[f].mean(1)
    f = f[cen[:, 2] < 0.8]  # open
    a = volga.Adf.from_mesh((v, f), tolerance=1e-3)
    rng = np.random.default_rng(1)
    p = rng.uniform(-1.2, 1.2, (3000, 3))
    sd = volga.signed_distance((v, f), p)
    far = np.abs(sd) > 0.05
    np.testing.assert_array_equal(a.inside(p)[far], (sd < 0)[far])
    b = pickle.loads(pickle.dumps(a))
    np.testing.assert_array_equal(b.distance(p), a.distance(p))
    assert b.cell_count == a.cell_count


def test_adf_csg_and_bad_input():
    big = volga.Adf.from_shape({"Sphere": {"center": [0, 0, 0], "radius": 1.0}}, tolerance=1e-3)
    small = volga.Adf.from_shape({"Sphere": {"center": [1, 0, 0], "radius": 0.5}}, tolerance=1e-3)
    d = big.difference(small)
    p = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.75, 0, 0], [-0.5, 0, 0]])
    np.testing.assert_allclose(d.distance(p), [-0.5, 0.5, 0.25, -0.5], atol=5e-3)
    u = big.union(small)
    assert u.distance([[1.4, 0, 0]])[0] < 0
    i = big.intersection(small)
    assert i.distance([[0.75, 0, 0]])[0] < 0 and i.distance([[0, 0, 0]])[0] > 0
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(d)).distance(p), d.distance(p))
    with pytest.raises(ValueError, match="tolerance"):
        volga.Adf.from_shape({"Sphere": {"center": [0, 0, 0], "radius": 1}}, tolerance=0)
    with pytest.raises(ValueError, match="max_depth"):
        volga.Adf.from_shape({"Sphere": {"center": [0, 0, 0], "radius": 1}}, max_depth=60)
    with pytest.raises(ValueError, match="radius"):
        volga.Adf.from_shape({"Sphere": {"center": [0, 0, 0], "radius": -1}})
    with pytest.raises(ValueError, match="op"):
        big._inner.combine(small._inner, "xor")
