"""volga.voxelize and VoxelGrid: layout, modes, bit-for-bit agreement with `volga
voxelize`, signs against the brute-force winding number, pickling, errors."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import volga

from conftest import brute_winding, read_nrrd_raw, unclean_corpus, uv_sphere, write_obj

MODES = [
    ("surface", {"separability": 6}, ["--separability", "6"]),
    ("surface", {"separability": 18}, ["--separability", "18"]),
    ("surface", {"separability": 26}, ["--separability", "26"]),
    ("solid", {"separability": 26}, ["--separability", "26", "--solid"]),
    ("anti_aliased", {}, ["--anti-aliased"]),
    ("anti_aliased", {"solid": True}, ["--anti-aliased", "--solid"]),
    ("anti_aliased", {"thickness": 2.5}, ["--anti-aliased", "--thickness", "2.5"]),
    ("distance", {"band": 3.0}, ["--distance", "3"]),
    ("distance", {"band": 2.0, "signed": False}, ["--distance", "2", "--unsigned"]),
]


@pytest.mark.parametrize("mode,kwargs,flags", MODES)
def test_voxelize_equals_the_cli_bit_for_bit(tmp_path, volga_cli, mode, kwargs, flags):
    # An open, self-intersecting mesh: the hard case for signs.
    v, f = unclean_corpus()["overlapping"]
    v, f = v, f[: len(f) - 30]
    obj = write_obj(tmp_path / "m.obj", v, f)
    volga_cli("voxelize", obj, "--resolution", 40, *flags, "--out", tmp_path / "cli.nrrd")
    cli = read_nrrd_raw(tmp_path / "cli.nrrd")
    grid = volga.voxelize(volga.load_mesh(obj), resolution=40, mode=mode, **kwargs)
    dense = grid.dense()
    assert dense.shape == cli.shape == grid.shape
    if grid.kind == "binary":
        assert dense.dtype == np.bool_
        np.testing.assert_array_equal(dense, cli >= 0.5)
        assert set(np.unique(cli)) <= {0.0, 1.0}
    else:
        assert dense.dtype == np.float32
        np.testing.assert_array_equal(dense.view(np.uint32), cli.view(np.uint32))
    # The grid's own writer gives the same file.
    written = grid.save(tmp_path / "py.nrrd")
    assert [p.name for p in written] == ["py.nrrd", "py.raw"]
    assert (tmp_path / "py.raw").read_bytes() == (tmp_path / "cli.raw").read_bytes()


def test_grid_members_agree():
    v, f = uv_sphere((0.3, 0.1, -0.2), 1.0, 12, 24)
    g = volga.voxelize((v, f), resolution=24, mode="solid")
    m = g.matrix
    assert m.shape == g.shape and m.dtype == np.bool_
    idx = g.sparse_indices
    assert idx.dtype == np.int64 and idx.shape[1] == 3
    np.testing.assert_array_equal(idx, np.argwhere(m))  # C order, like np.nonzero
    assert g.values.dtype == np.bool_ and g.values.all()
    t = g.transform
    assert t.shape == (4, 4)
    np.testing.assert_allclose(t[:3, :3], np.eye(3) * g.pitch)
    np.testing.assert_array_equal(t[:3, 3], g.origin)
    np.testing.assert_array_equal(g.spacing, [g.pitch] * 3)
    # voxel centres of the solid lie inside the padded mesh box; the centre voxel is inside
    centres = idx @ t[:3, :3].T + t[:3, 3]
    assert (np.linalg.norm(centres - (0.3, 0.1, -0.2), axis=1) < 1.0 + g.pitch).all()
    lo, hi = g.bounds
    np.testing.assert_allclose(lo, g.origin - g.pitch / 2)
    np.testing.assert_allclose(hi, g.origin + (np.array(g.shape) - 0.5) * g.pitch)
    assert g.kind == "binary" and g.background == 0.0 and "solid" in g.mode
    s = g.stats
    assert s["closed"] and s["boundary_edges"] == 0 and s["sign"]["unclean_triangles"] == 0
    assert s["active_voxels"] == m.sum()
    np.testing.assert_allclose(g.sample(centres[:10]), 1.0)


def test_distance_band_values_are_the_signed_distances():
    v, f = unclean_corpus()["open_cap"]
    g = volga.voxelize((v, f), resolution=32, mode="distance", band=3.0)
    assert g.kind == "distance"
    assert g.background == pytest.approx(3.0 * g.pitch)
    idx, vals = g.sparse_indices, g.values
    assert (np.abs(vals) < g.background).all()
    centres = idx * g.pitch + g.origin
    d = volga.signed_distance((v, f), centres)
    np.testing.assert_array_equal(np.sign(vals), np.sign(d.astype(np.float32)))
    np.testing.assert_allclose(vals, d, rtol=1e-6, atol=1e-7 * g.pitch)
    dense = g.matrix
    np.testing.assert_array_equal(dense[tuple(idx.T)], vals)


@pytest.mark.parametrize("name", ["open_cap", "overlapping", "flipped_half", "sheet"])
def test_solid_is_the_winding_number_inside_on_unclean_meshes(name):
    v, f = unclean_corpus()[name]
    g = volga.voxelize((v, f), resolution=20, mode="anti_aliased", solid=True)
    dense = g.matrix
    ijk = np.argwhere(np.ones(g.shape, bool))
    centres = ijk * g.pitch + g.origin
    w = brute_winding(v, f, centres)
    d = volga.signed_distance((v, f), centres)
    far = np.abs(d) > 2 * g.pitch  # beyond the filter's ramp the density is 0 or 1
    inside = w >= 0.5
    vals = dense[tuple(ijk.T)]
    np.testing.assert_array_equal(vals[far & inside], 1.0)
    np.testing.assert_array_equal(vals[far & ~inside], 0.0)


def test_pitch_and_bounds_lay_out_the_grid():
    v, f = uv_sphere()
    a = volga.voxelize((v, f), resolution=16)
    b = volga.voxelize((v, f), pitch=a.pitch)
    np.testing.assert_array_equal(a.matrix, b.matrix)
    np.testing.assert_array_equal(a.transform, b.transform)
    lo, hi = np.array([-1.5, -1.5, -1.5]), np.array([1.5, 1.5, 1.0])
    c = volga.voxelize((v, f), pitch=0.25, bounds=(lo, hi))
    assert c.shape == (12, 12, 10)
    np.testing.assert_allclose(c.origin, lo + 0.125)
    d = volga.voxelize((v, f), resolution=12, bounds=(lo, hi))
    assert d.pitch == 0.25 and d.shape == c.shape
    # the part of the sphere above z = 1 is cut off by the bounds, the rest is there
    assert c.matrix[:, :, -1].any()


def test_voxelize_refuses_bad_input_and_memory():
    v, f = uv_sphere()
    m = volga.Mesh(v, f)
    for kwargs, msg in [
        ({}, "resolution"),
        ({"resolution": 8, "pitch": 0.1}, "not both"),
        ({"resolution": 0}, "resolution"),
        ({"pitch": -1.0}, "pitch"),
        ({"pitch": 1e-12}, r"pitch 0\.000000000001: .* more than a grid can hold"),
        ({"resolution": 8, "mode": "fuzzy"}, "mode"),
        ({"resolution": 8, "separability": 7}, "separability"),
        ({"resolution": 8, "mode": "distance", "band": 0.0}, "band"),
        ({"resolution": 8, "mode": "anti_aliased", "thickness": float("nan")}, "thickness"),
        ({"resolution": 8, "bounds": ((1, 1, 1), (0, 0, 0))}, "bounds"),
        ({"resolution": 8, "threads": 0}, "threads"),
        ({"resolution": 8, "threads": 10**6}, "threads"),
        ({"resolution": 8, "solid": True}, "solid does not apply"),
        ({"resolution": 8, "band": 2.0}, "band does not apply"),
        ({"resolution": 8, "mode": "distance", "separability": 6}, "separability does not apply"),
        ({"resolution": 8, "mode": "anti_aliased", "solid": True, "thickness": 2.0}, "thickness does not apply"),
        ({"resolution": 8, "mode": "solid", "signed": False}, "signed does not apply"),
    ]:
        with pytest.raises(ValueError, match=msg):
            volga.voxelize(m, **kwargs)
    with pytest.raises(MemoryError, match=r"needs an estimated .*, more than memory_limit=1048576"):
        volga.voxelize(m, resolution=64, memory_limit=1 << 20)
    g = volga.voxelize(m, resolution=64)
    with pytest.raises(MemoryError, match="dense"):
        g.dense(memory_limit=1000)
    with pytest.raises(ValueError, match="binvox"):
        volga.voxelize(m, resolution=8, mode="distance").save("x.binvox")


def test_voxelize_is_identical_for_any_thread_count():
    v, f = unclean_corpus()["overlapping"]
    runs = [volga.voxelize((v, f), resolution=48, mode="distance", threads=t).dense() for t in (1, 2, 3)]
    for r in runs[1:]:
        np.testing.assert_array_equal(r.view(np.uint32), runs[0].view(np.uint32))


@pytest.mark.parametrize("mode", ["surface", "anti_aliased", "distance"])
def test_grids_pickle(mode):
    v, f = uv_sphere()
    g = volga.voxelize((v, f), resolution=20, mode=mode)
    h = pickle.loads(pickle.dumps(g))
    assert (h.kind, h.mode, h.shape, h.pitch, h.background) == (g.kind, g.mode, g.shape, g.pitch, g.background)
    np.testing.assert_array_equal(h.dense(), g.dense())
    np.testing.assert_array_equal(h.transform, g.transform)
    assert h.stats == g.stats


def test_load_volume_reads_what_save_wrote(tmp_path):
    v, f = uv_sphere()
    g = volga.voxelize((v, f), resolution=20, mode="surface")
    g.save(tmp_path / "s.binvox")
    back = volga.load_volume(tmp_path / "s.binvox")
    assert back.kind == "binary"
    m = back.matrix
    np.testing.assert_array_equal(m[: g.shape[0], : g.shape[1], : g.shape[2]], g.matrix)
    d = volga.voxelize((v, f), resolution=20, mode="distance")
    d.save(tmp_path / "d.nrrd")
    back = volga.load_volume(tmp_path / "d.nrrd")
    assert back.kind == "distance" and back.background == d.background
    np.testing.assert_array_equal(back.dense(), d.dense())
    with pytest.raises(OSError):
        volga.load_volume(tmp_path / "missing.nrrd")
    (tmp_path / "junk.binvox").write_bytes(b"not a binvox")
    with pytest.raises(ValueError, match="junk.binvox"):
        volga.load_volume(tmp_path / "junk.binvox")


def test_vdb_round_trip(tmp_path):
    v, f = uv_sphere()
    d = volga.voxelize((v, f), resolution=24, mode="distance")
    for compression in ["none", "zip", "blosc"]:
        path = tmp_path / f"d_{compression}.vdb"
        written = d.to_vdb(path, compression=compression)
        assert [str(p) for p in written] == [str(path)] and path.exists()
        back = volga.load_volume(path)
        assert back.kind == "distance" and back.background == d.background
        np.testing.assert_array_equal(back.dense(), d.dense())
    d.to_vdb(tmp_path / "half.vdb", half=True)
    half = volga.load_volume(tmp_path / "half.vdb").dense()
    np.testing.assert_array_equal(half, d.dense().astype(np.float16).astype(np.float32))
    a = volga.voxelize((v, f), resolution=24, mode="anti_aliased", solid=True)
    a.save(tmp_path / "a.vdb")
    back = volga.load_volume(tmp_path / "a.vdb")
    assert back.kind == "density"
    np.testing.assert_array_equal(back.dense(), a.dense())
    with pytest.raises(ValueError, match="compression"):
        d.to_vdb(tmp_path / "x.vdb", compression="lzma")
    with pytest.raises(ValueError, match="to_vdb"):
        d.to_vdb(tmp_path / "x.nrrd")
    (tmp_path / "junk.vdb").write_bytes(b"\x20BDV\0\0\0\0 not really")
    with pytest.raises(ValueError, match="junk.vdb"):
        volga.load_volume(tmp_path / "junk.vdb")


def test_extract_mesh_is_closed_and_on_the_surface():
    from conftest import edge_face_check

    v, f = uv_sphere(rings=24, segments=48)
    for mode, kwargs in [("distance", {}), ("anti_aliased", {"solid": True})]:
        g = volga.voxelize((v, f), resolution=32, mode=mode, **kwargs)
        V, F = volga.extract_mesh(g)
        assert V.dtype == np.float64 and F.dtype == np.int64 and len(F) > 100
        closed, oriented = edge_face_check(F)
        assert closed and oriented
        d = volga.signed_distance((v, f), V)
        assert np.abs(d).max() < 0.5 * g.pitch
    with pytest.raises(ValueError, match="iso"):
        volga.extract_mesh(g, iso=float("nan"))
    # Every method closed and oriented; adaptivity keeps that with fewer triangles.
    counts = {}
    for method in ("tetrahedra", "cubes", "dual"):
        for adaptivity in (0.0, 0.5):
            V, F = volga.extract_mesh(g, method=method, adaptivity=adaptivity)
            closed, oriented = edge_face_check(F)
            assert closed and oriented, (method, adaptivity)
            counts[method, adaptivity] = len(F)
    assert counts["cubes", 0.0] < 0.5 * counts["tetrahedra", 0.0]
    assert counts["cubes", 0.5] < counts["cubes", 0.0]
    with pytest.raises(ValueError, match="method"):
        volga.extract_mesh(g, method="surface-nets")
    with pytest.raises(ValueError, match="adaptivity"):
        volga.extract_mesh(g, adaptivity=-1.0)
