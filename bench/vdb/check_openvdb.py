#!/usr/bin/python3
"""Judge volga's .vdb files by OpenVDB itself, and volga's reader by OpenVDB's files.

Runs under Debian's /usr/bin/python3 with `apt-get install python3-openvdb
libopenvdb-tools` (OpenVDB 10.0.1: `import pyopenvdb`, `vdb_print`). Driven by
check_openvdb.sh; three commands:

  pairs DIR           every X.vdb in DIR beside an X.nrrd of the same volume (volga wrote
                      both): OpenVDB's reading of X.vdb must equal the NRRD voxel for voxel
                      (level sets: inactive voxels ±background; half grids: values rounded
                      to float16), with the class, background, active voxel count and box,
                      transform and metadata volga promises; `vdb_print -l` must report the
                      same active voxel count. X_colour.nrrd, when present, is compared with
                      the Vec3f grid `color`.
  reverse DIR VOLGA   OpenVDB writes a sphere level set, the bunny's level set from
                      createLevelSetFromPolygons, a fog volume and a half-float sphere;
                      `volga convert` turns each into a NRRD, which must equal OpenVDB's values.
  reference DIR       small OpenVDB-written files and the figures OpenVDB reports for them
                      (JSON), for the CI test crates/volga-io/tests/vdb_files.rs.
"""
import json
import os
import re
import subprocess
import sys

import numpy as np
import pyopenvdb as vdb

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def read_nrrd(path):
    """A volga NRRD: (array indexed [x, y, z] (or [x, y, z, c]), origin, spacing, background)."""
    header = {}
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if not line or line.startswith("#") or line.startswith("NRRD"):
                continue
            key, _, value = line.partition(":")
            header[key.strip()] = value.lstrip("=").strip()
    sizes = [int(s) for s in header["sizes"].split()]
    data = np.fromfile(os.path.join(os.path.dirname(path), header["data file"]), dtype="<f4")
    dirs = re.findall(r"\(([^)]*)\)", header["space directions"])
    spacing = [float(d.split(",")[i]) for i, d in enumerate(dirs)]
    origin = [float(x) for x in header["space origin"].strip("()").split(",")]
    background = float(header.get("volga_background", 0.0))
    if len(sizes) == 4:
        arr = data.reshape(sizes[3], sizes[2], sizes[1], 3).transpose(2, 1, 0, 3)
    else:
        arr = data.reshape(sizes[2], sizes[1], sizes[0]).transpose(2, 1, 0)
    return arr, origin, spacing, background


def check(cond, message):
    if not cond:
        raise AssertionError(message)


def vdb_print_active(path):
    out = subprocess.run(["vdb_print", "-l", path], check=True, capture_output=True, text=True).stdout
    counts = [int(m.replace(",", "")) for m in re.findall(r"Number of active voxels:\s+([\d,]+)", out)]
    return counts, out


def compare_pair(vdb_path, nrrd_path):
    arr, origin, spacing, background = read_nrrd(nrrd_path)
    grids, _ = vdb.readAll(vdb_path)
    g = [g for g in grids if g.valueTypeName == "float"][0]
    half = bool(g.metadata.get("is_saved_as_half_float", False))
    level_set = g.gridClass == vdb.GridClass.LEVEL_SET
    bg = np.float32(background)
    if half:
        bg = np.float32(np.float16(bg))
    check(np.float32(g.background) == bg, f"background {g.background} vs {bg}")
    expected = arr.astype(np.float32).copy()
    if level_set:
        active = np.abs(expected) < np.float32(background)
        expected[~active] = np.copysign(np.float32(background), expected[~active])
        check(g.name == "surface", f"level set name {g.name}")
    else:
        active = expected != np.float32(background)
        check(
            g.gridClass == (vdb.GridClass.FOG_VOLUME if background == 0 else vdb.GridClass.UNKNOWN),
            f"class {g.gridClass}",
        )
    if half:
        expected = expected.astype(np.float16).astype(np.float32)
    got = np.zeros(expected.shape, np.float32)
    g.copyToArray(got, ijk=(0, 0, 0))
    bad = np.argwhere(got != expected)
    check(len(bad) == 0, f"{len(bad)} voxels differ, first {bad[:3].tolist()}: "
          f"{[float(got[tuple(b)]) for b in bad[:3]]} vs {[float(expected[tuple(b)]) for b in bad[:3]]}")
    n_active = int(active.sum())
    check(g.activeVoxelCount() == n_active, f"active voxels {g.activeVoxelCount()} vs {n_active}")
    # No active voxel outside the grid (copyToArray sees only the grid).
    idx = np.argwhere(active)
    if n_active:
        box = (tuple(int(v) for v in idx.min(0)), tuple(int(v) for v in idx.max(0)))
        check(g.evalActiveVoxelBoundingBox() == box, f"box {g.evalActiveVoxelBoundingBox()} vs {box}")
        check(tuple(g.metadata["file_bbox_min"]) == box[0] and tuple(g.metadata["file_bbox_max"]) == box[1],
              "file_bbox metadata")
    check(g.metadata["file_voxel_count"] == n_active, "file_voxel_count metadata")
    check(np.allclose(g.transform.voxelSize(), spacing, rtol=0, atol=0), f"voxel size {g.transform.voxelSize()}")
    check(np.allclose(g.transform.indexToWorld((0, 0, 0)), origin, rtol=0, atol=1e-12 * max(1, np.abs(origin).max())),
          f"origin {g.transform.indexToWorld((0, 0, 0))} vs {origin}")
    counts, _ = vdb_print_active(vdb_path)
    check(n_active in counts, f"vdb_print active voxels {counts}")
    report = {"file": os.path.basename(vdb_path), "class": str(g.gridClass), "half": half,
              "active_voxels": n_active, "background": float(g.background),
              "compression": g.metadata.get("file_compression")}
    colour_path = nrrd_path[:-5] + "_colour.nrrd"
    colours = [g for g in grids if g.valueTypeName == "vec3s"]
    if os.path.exists(colour_path):
        carr, _, _, _ = read_nrrd(colour_path)
        check(len(colours) == 1 and colours[0].name == "color", "colour grid `color`")
        c = colours[0]
        cgot = np.zeros(carr.shape, np.float32)
        c.copyToArray(cgot, ijk=(0, 0, 0))
        cexp = carr.astype(np.float32)
        if half:
            cexp = cexp.astype(np.float16).astype(np.float32)
        check(np.array_equal(cgot, cexp), f"{int((cgot != cexp).any(-1).sum())} colour voxels differ")
        nonblack = int((carr != 0).any(-1).sum())
        check(c.activeVoxelCount() == nonblack, f"colour active {c.activeVoxelCount()} vs {nonblack}")
        report["colour_active_voxels"] = nonblack
    return report


def pairs(directory):
    reports = []
    for name in sorted(os.listdir(directory)):
        if not name.endswith(".vdb"):
            continue
        stem = name[:-4]
        nrrd = os.path.join(directory, stem + ".nrrd")
        if not os.path.exists(nrrd):
            continue
        r = compare_pair(os.path.join(directory, name), nrrd)
        print("ok  ", json.dumps(r))
        reports.append(r)
    check(reports, f"no .vdb/.nrrd pairs in {directory}")
    return reports


def read_obj(path):
    verts, tris = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                verts.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                idx = [int(x.split("/")[0]) - 1 for x in p[1:]]
                for i in range(1, len(idx) - 1):
                    tris.append([idx[0], idx[i], idx[i + 1]])
    return np.array(verts, np.float32), np.array(tris, np.int32)


def openvdb_grids(scale=1.0):
    """The files OpenVDB writes: (name, grid, half)."""
    sphere = vdb.createLevelSetSphere(radius=5.0 * scale, center=(1.5, -2.0, 3.0), voxelSize=0.5, halfWidth=3.0)
    sphere.name = "sphere"
    v, t = read_obj(os.path.join(ROOT, "tests/data/stanford-bunny.obj"))
    diag = float(np.linalg.norm(v.max(0) - v.min(0)))
    bunny = vdb.FloatGrid.createLevelSetFromPolygons(
        v, triangles=t, transform=vdb.createLinearTransform(voxelSize=diag / (48 * scale)), halfWidth=3.0)
    bunny.name = "bunny"
    n = int(24 * scale)
    x, y, z = np.meshgrid(*[np.arange(n, dtype=np.float32)] * 3, indexing="ij")
    r = np.sqrt((x - n / 2) ** 2 + (y - n / 3) ** 2 + (z - n / 2) ** 2) / (n / 3)
    density = np.clip(1.0 - r, 0.0, 1.0).astype(np.float32)
    fog = vdb.FloatGrid(0.0)
    fog.copyFromArray(density, ijk=(-5, 7, -3), tolerance=0.0)
    fog.gridClass = vdb.GridClass.FOG_VOLUME
    fog.transform = vdb.createLinearTransform(voxelSize=0.2)
    fog.name = "density"
    half = vdb.createLevelSetSphere(radius=4.0 * scale, center=(0.0, 0.0, 0.0), voxelSize=0.25, halfWidth=3.0)
    half.name = "half_sphere"
    half.saveFloatAsHalf = True
    return [("openvdb_sphere", sphere), ("openvdb_bunny", bunny), ("openvdb_fog", fog), ("openvdb_half", half)]


def figures(g, samples=400, seed=1):
    """What OpenVDB reports of a grid it read: the JSON the CI test compares against."""
    lo, hi = g.evalActiveVoxelBoundingBox()
    dims = tuple(h - l + 1 for l, h in zip(lo, hi))
    arr = np.zeros(dims, np.float32)
    g.copyToArray(arr, ijk=lo)
    mask = np.zeros(dims, bool)
    for it in g.citerOnValues():
        # Voxels and active tiles alike.
        a = np.array(it.min) - lo
        b = np.array(it.max) - lo + 1
        mask[a[0]:b[0], a[1]:b[1], a[2]:b[2]] = True
    act = arr[mask].astype(np.float64)
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, np.array(dims), size=(samples, 3))
    sample_list = [[int(p[0] + lo[0]), int(p[1] + lo[1]), int(p[2] + lo[2]), float(arr[tuple(p)])] for p in picks]
    return {
        "class": {vdb.GridClass.LEVEL_SET: "level set", vdb.GridClass.FOG_VOLUME: "fog volume"}.get(g.gridClass, "unknown"),
        "background": float(g.background),
        "half": bool(g.saveFloatAsHalf),
        "active_voxels": int(g.activeVoxelCount()),
        "bbox_min": list(lo),
        "bbox_max": list(hi),
        "voxel_size": list(g.transform.voxelSize()),
        "origin": list(g.transform.indexToWorld((0, 0, 0))),
        "active_sum": float(act.sum()),
        "active_sum_squares": float((act * act).sum()),
        "samples": sample_list,
    }


def reference(directory):
    os.makedirs(directory, exist_ok=True)
    for name, g in openvdb_grids():
        path = os.path.join(directory, name + ".vdb")
        vdb.write(path, grids=[g])
        back = vdb.read(path, g.name)
        with open(os.path.join(directory, name + ".json"), "w") as f:
            json.dump(figures(back), f, indent=1)
            f.write("\n")
        print("wrote", path, os.path.getsize(path), "bytes,", back.activeVoxelCount(), "active voxels")


def reverse(directory, volga):
    os.makedirs(directory, exist_ok=True)
    reports = []
    for name, g in openvdb_grids(scale=4.0):
        path = os.path.join(directory, name + ".vdb")
        vdb.write(path, grids=[g])
        g = vdb.read(path, g.name)
        nrrd = os.path.join(directory, name + "_volga.nrrd")
        subprocess.run([volga, "convert", path, nrrd], check=True, capture_output=True)
        arr, origin, spacing, background = read_nrrd(nrrd)
        h = np.array(g.transform.voxelSize())
        offset = np.rint((np.array(origin) - np.array(g.transform.indexToWorld((0, 0, 0)))) / h).astype(int)
        check(np.allclose(spacing, h, rtol=0, atol=0), f"{name}: spacing {spacing} vs {h}")
        want = np.zeros(arr.shape, np.float32)
        g.copyToArray(want, ijk=tuple(int(o) for o in offset))
        bad = np.argwhere(want != arr)
        check(len(bad) == 0, f"{name}: {len(bad)} voxels differ, first {bad[:3].tolist()}")
        check(np.float32(background) == np.float32(g.background), f"{name}: background")
        lo, hi = g.evalActiveVoxelBoundingBox()
        check(all(offset[i] <= lo[i] and hi[i] < offset[i] + arr.shape[i] for i in range(3)),
              f"{name}: the active box {lo}..{hi} lies in volga's grid")
        r = {"file": name + ".vdb", "active_voxels": int(g.activeVoxelCount()),
             "voxels_compared": int(arr.size), "half": bool(g.saveFloatAsHalf)}
        print("ok  ", json.dumps(r))
        reports.append(r)
    return reports


if __name__ == "__main__":
    command = sys.argv[1] if len(sys.argv) > 1 else ""
    if command == "pairs":
        pairs(sys.argv[2])
    elif command == "reverse":
        reverse(sys.argv[2], sys.argv[3])
    elif command == "reference":
        reference(sys.argv[2])
    else:
        sys.exit(__doc__)
