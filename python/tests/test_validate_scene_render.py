"""volga.validate (the CLI's JSON), volga.build (files and dicts), volga.render."""

from __future__ import annotations

import json

import numpy as np
import pytest
import volga

from conftest import REPO, uv_sphere, write_obj


def test_validate_gives_the_cli_json(tmp_path, volga_cli, sphere_obj):
    obj, v, f = sphere_obj
    for n in (6, 18, 26):
        g = volga.voxelize(volga.load_mesh(obj), resolution=24, mode="surface", separability=n)
        g.save(tmp_path / f"s{n}.nrrd")
        out = volga_cli(
            "validate", tmp_path / f"s{n}.nrrd", "--mesh", obj, "--connectivity", n,
            "--require", "separating,cover", "--json", check=False,
        )
        cli = json.loads(out.stdout)
        py = volga.validate(g, connectivity=n, mesh=(v, f), require=["separating", "cover"])
        # N-separating by construction; the thinner 6- and 18-separating surfaces need not cover
        assert py["requirements"][0]["holds"] and cli["requirements"][0]["holds"]
        assert py["passed"] == cli["passed"] == (out.returncode == 0)
        if n == 26:
            assert py["passed"]
        for key in ("report", "requirements", "passed", "values", "padded", "origin", "spacing"):
            assert py[key] == cli[key], key
        assert py["mesh"]["triangles"] == cli["mesh"]["triangles"] == len(f)
        assert py["format"] == "grid" and py["model"] is None
        # the same verdict from the dense array and the grid's transform
        arr = volga.validate(g.matrix, connectivity=n, mesh=(v, f), transform=g.transform, require=["separating", "cover"])
        assert arr["passed"] == py["passed"]
        assert arr["report"] == py["report"] and arr["format"] == "array"


def test_validate_finds_a_tunnel_and_a_simple_voxel():
    # A closed 6-connected cube shell: separating for 26-paths? No: 26-paths leak through
    # its diagonal-free corners only if they are missing; remove one voxel to make a hole.
    a = np.zeros((7, 7, 7), bool)
    a[1:6, 1:6, 1:6] = True
    a[2:5, 2:5, 2:5] = False
    full = volga.validate(a, connectivity=26, require=["separating"])
    assert full["passed"] and full["report"]["white_component_count"] == 2
    a[3, 3, 1] = False  # a hole through the shell
    holed = volga.validate(a, connectivity=26, require=["separating"])
    assert not holed["passed"] and holed["report"]["white_component_count"] == 1
    thick = np.zeros((7, 7, 7), bool)
    thick[1:6, 1:6, 1:6] = True
    thick[3, 3, 3] = False
    r = volga.validate(thick, connectivity=26, require=["minimal"])
    assert not r["passed"] and r["report"]["simple_voxel_count"] > 0
    # densities are thresholded at 0.5
    assert volga.validate(a.astype(np.float32) * 0.7)["report"] == holed["report"]


def test_validate_refuses_bad_input():
    a = np.ones((3, 3, 3), bool)
    with pytest.raises(ValueError, match="connectivity"):
        volga.validate(a, connectivity=8)
    with pytest.raises(ValueError, match="cover"):
        volga.validate(a, require=["cover"])
    with pytest.raises(ValueError, match="requirement"):
        volga.validate(a, require=["watertight"])
    with pytest.raises(ValueError, match="3-D"):
        volga.validate(np.ones((3, 3), bool))
    with pytest.raises(ValueError, match="scale and translation"):
        t = np.eye(4)
        t[0, 1] = 0.5
        volga.validate(a, mesh=uv_sphere(), transform=t)
    v, f = uv_sphere()
    d = volga.voxelize((v, f), resolution=8, mode="distance")
    with pytest.raises(ValueError, match="distances"):
        volga.validate(d)


def test_build_from_a_file_and_from_a_dict_give_the_same_outputs(tmp_path):
    scene = json.loads((REPO / "scenes" / "hello.json").read_text())
    scene["grid"]["resolution"] = 48
    for image in scene["outputs"]["images"]:
        image["width"] = image["height"] = 64
    (tmp_path / "s.json").write_text(json.dumps(scene))
    a = volga.build(tmp_path / "s.json", tmp_path / "a")
    b = volga.build(scene, tmp_path / "b")
    assert [s["name"] for s in a["stages"]] == [s["name"] for s in b["stages"]]
    assert a["voxels"] == b["voxels"]
    files = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert files == sorted(p.name for p in (tmp_path / "b").iterdir())
    assert "hello_iso.png" in files and "report.json" in files
    for name in files:
        if name != "report.json":
            assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def test_build_errors_name_the_field(tmp_path):
    scene = json.loads((REPO / "scenes" / "hello.json").read_text())
    scene["objects"][0]["shape"]["Sphere"]["radius"] = -1.0
    with pytest.raises(ValueError, match=r"objects\[0\]\.shape\.radius"):
        volga.build(scene, tmp_path / "o")
    with pytest.raises(ValueError, match=r"scene\.grid\.resolution: invalid type: string \"x\""):
        volga.build({"grid": {"bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}, "resolution": "x"}}, tmp_path / "o")
    with pytest.raises(ValueError, match="unknown field"):
        volga.build({"grid": {"bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}, "resolution": 8}, "objectz": []}, tmp_path / "o")
    with pytest.raises(OSError):
        volga.build(tmp_path / "missing.ron", tmp_path / "o")
    big = json.loads((REPO / "scenes" / "hello.json").read_text())
    big["grid"]["resolution"] = 2048
    with pytest.raises(MemoryError, match="memory"):
        volga.build(big, tmp_path / "o", memory_limit=1 << 26)
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_a_dict_scene_reads_meshes_from_base_dir(tmp_path):
    v, f = uv_sphere()
    write_obj(tmp_path / "ball.obj", v, f)
    scene = {"grid": {"bounds": {"min": [-1.5, -1.5, -1.5], "max": [1.5, 1.5, 1.5]}, "resolution": 24},
             "objects": [{"shape": {"Mesh": {"path": "ball.obj"}}}],
             "cameras": [], "outputs": {"volumes": [{"name": "ball"}]}}
    report = volga.build(scene, tmp_path / "out", base_dir=tmp_path)
    assert report["voxels"]["active"] > 0 and (tmp_path / "out" / "ball.nrrd").exists()


def test_render_returns_rgba_images():
    v, f = uv_sphere()
    g = volga.voxelize((v, f), resolution=32, mode="distance")
    img = volga.render(g, 48, 32)
    assert img.shape == (32, 48, 4) and img.dtype == np.uint8
    assert (img[16, 24] != img[0, 0]).any()  # the sphere in the middle, the background in the corner
    assert (volga.render(g, 48, 32, threads=1) == img).all()
    mip = volga.render(volga.voxelize((v, f), resolution=32, mode="anti_aliased", solid=True), 32, 32, mode="mip")
    assert mip[16, 16, 0] > mip[0, 0, 0]
    side = volga.render(g, 32, 32, eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), colour=(1, 0, 0))
    assert side[16, 16, 0] > side[16, 16, 2]
    for kwargs, msg in [({"width": 0}, "width"), ({"mode": "dvr"}, "mode"), ({"fov_deg": 200}, "fov"),
                        ({"eye": (0, 0)}, "eye"), ({"iso": float("inf")}, "iso")]:
        with pytest.raises(ValueError, match=msg):
            volga.render(g, **kwargs)
    with pytest.raises(ValueError, match="expected"):
        volga.render(np.zeros((4, 4, 4)))


def test_a_scene_reads_only_files_in_its_folder_unless_allowed(tmp_path):
    v, f = uv_sphere()
    write_obj(tmp_path / "ball.obj", v, f)
    (tmp_path / "scenes").mkdir()
    scene = {"grid": {"bounds": {"min": [-1.5, -1.5, -1.5], "max": [1.5, 1.5, 1.5]}, "resolution": 16},
             "objects": [{"shape": {"Mesh": {"path": "../ball.obj"}}}],
             "cameras": [], "outputs": {"volumes": [{"name": "ball"}]}}
    with pytest.raises(ValueError, match="allow-outside-paths"):
        volga.build(scene, tmp_path / "out", base_dir=tmp_path / "scenes")
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    report = volga.build(scene, tmp_path / "out", base_dir=tmp_path / "scenes", allow_outside_paths=True)
    assert report["voxels"]["active"] > 0
