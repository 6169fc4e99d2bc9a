"""Validates voxelizations of the bunny and spot by volga, Open3D and trimesh with
`volga validate`, and writes the comparison table into docs/VALIDATE.md.

    bench/validate/run.sh [--size 256] [--workdir DIR] [--no-docs]

Each tool's result is exported to .binvox (volga writes its own; Open3D's VoxelGrid and
trimesh's `voxelized` are converted with bench/peers/common.write_binvox, which keeps the
world mapping), then `volga validate X.binvox --mesh MESH --connectivity N --json` checks
it against the source mesh at N = 6 and 26: tunnels (white N-adjacent pairs whose segment
meets the surface; none means N-separating), N-simple voxels, and whether the voxels cover
the surface. Not a timing benchmark; outside CI.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "bench", "peers"))
import numpy as np  # noqa: E402

from common import load_obj, voxel_size, write_binvox  # noqa: E402

VOLGA = os.path.join(ROOT, "target", "release", "volga")
MESHES = {
    "bunny": os.path.join(ROOT, "tests", "data", "stanford-bunny.obj"),
    "spot": os.path.join(ROOT, "tests", "data", "spot.obj"),
}
BEGIN, END = "<!-- validate-table:begin -->", "<!-- validate-table:end -->"


def volga_binvox(mesh, n, sep, out):
    subprocess.run([VOLGA, "voxelize", mesh, "--resolution", str(n), "--separability", str(sep),
                    "--out", out], check=True, capture_output=True)


def open3d_binvox(verts, tris, h, out):
    import open3d as o3d

    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(verts), o3d.utility.Vector3iVector(tris))
    grid = o3d.geometry.VoxelGrid.create_from_triangle_mesh(m, voxel_size=h)
    ijk = np.array([v.grid_index for v in grid.get_voxels()], np.int64)
    # Open3D's voxel (i, j, k) spans origin + [i, i+1)·h: its centre is origin + (i + ½)h.
    write_binvox(out, ijk, np.asarray(grid.origin) + 0.5 * h, h)


def trimesh_binvox(verts, tris, h, out):
    import trimesh

    g = trimesh.Trimesh(verts, tris, process=False).voxelized(pitch=h)
    ijk = np.asarray(g.sparse_indices, np.int64)
    # trimesh's transform maps voxel indices to their centres.
    write_binvox(out, ijk, (g.transform @ np.array([0.0, 0.0, 0.0, 1.0]))[:3], h)


def validate(model, mesh, conn):
    r = subprocess.run([VOLGA, "validate", model, "--mesh", mesh, "--connectivity", str(conn), "--json",
                        "--require", "separating"], capture_output=True, text=True)
    if r.returncode not in (0, 1):
        raise RuntimeError(f"volga validate {model}: {r.stderr}")
    return json.loads(r.stdout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--workdir")
    ap.add_argument("--no-docs", action="store_true")
    args = ap.parse_args()
    work = args.workdir or tempfile.mkdtemp(prefix="volga-validate-")
    os.makedirs(work, exist_ok=True)
    rows = []
    for name, path in MESHES.items():
        verts, tris = load_obj(path)
        h = voxel_size(verts, args.size)
        models = {}
        for sep in (6, 26):
            out = os.path.join(work, f"{name}-volga{sep}.binvox")
            volga_binvox(path, args.size, sep, out)
            models[f"volga, 26-separating" if sep == 26 else "volga, 6-separating"] = out
        out = os.path.join(work, f"{name}-open3d.binvox")
        open3d_binvox(verts, tris, h, out)
        models["Open3D VoxelGrid"] = out
        out = os.path.join(work, f"{name}-trimesh.binvox")
        trimesh_binvox(verts, tris, h, out)
        models["trimesh voxelized"] = out
        for tool, model in models.items():
            r6, r26 = validate(model, path, 6)["report"], validate(model, path, 26)["report"]
            m6, m26 = r6["mesh"], r26["mesh"]
            rows.append({
                "mesh": name, "tool": tool, "voxels": r26["voxels"],
                "tunnels6": m6["tunnel_count"], "tunnels26": m26["tunnel_count"],
                "simple6": r6.get("simple_voxel_count"), "simple26": r26.get("simple_voxel_count"),
                "covers": m26["covers"],
            })
            print(rows[-1], flush=True)

    def yn(b):
        return "yes" if b else "no"

    def simple(v):
        return "n/a (not separating as a set)" if v is None else f"{v:,}"

    lines = [
        f"Bunny (open, 223 boundary edges) and spot (closed) at N = {args.size} voxels along the longest side.",
        "Tunnels are white N-adjacent pairs whose segment meets the mesh (0 = N-separating with",
        "respect to the mesh); simple voxels are counted on the white-component view (a set that",
        "does not split the white voxels — the open bunny — has none to count); cover is exact.",
        "",
        "| mesh | tool | voxels | 6-separating? (tunnels) | 26-separating? (tunnels) | 6-simple voxels | 26-simple voxels | covers the surface? |",
        "|---|---|---:|---|---|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['mesh']} | {r['tool']} | {r['voxels']:,} | {yn(r['tunnels6'] == 0)} ({r['tunnels6']:,}) | "
            f"{yn(r['tunnels26'] == 0)} ({r['tunnels26']:,}) | {simple(r['simple6'])} | {simple(r['simple26'])} | {yn(r['covers'])} |")
    lines += ["", f"Made by `bench/validate/run.sh --size {args.size}` (work files in a temporary directory)."]
    table = "\n".join(lines)
    print(table)
    if not args.no_docs:
        doc = os.path.join(ROOT, "docs", "VALIDATE.md")
        text = open(doc).read()
        block = f"{BEGIN}\n{table}\n{END}"
        if BEGIN in text:
            text = text[: text.index(BEGIN)] + block + text[text.index(END) + len(END):]
        else:
            text += "\n## Other voxelizers, validated\n\n" + block + "\n"
        open(doc, "w").write(text)


if __name__ == "__main__":
    main()
