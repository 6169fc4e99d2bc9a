#!/usr/bin/python3
"""OpenVDB level-set peer for `volga bench adf` (outside CI; see docs/ADF.md).

    /usr/bin/python3 bench/adf/openvdb_adf_peer.py MESH.obj PROBES.json [N ...]

Builds OpenVDB level sets of MESH (`createLevelSetFromPolygons`, Debian's python3-openvdb
10.0.1, both cores through TBB) at N voxels along the mesh's longest side, for each N given
(default 256 512 1024 2048), and measures each against the exact signed distances that
`volga bench adf --probes-out PROBES.json` wrote (format `volga-adf-probes/1`, docs/ADF.md:
the same probe points volga's `max_error` uses, with the ADF's own values). The target is
the ADF's maximum error over those probes. The level set's value at a probe is the trilinear interpolation of its 8 voxel
values, as OpenVDB's `BoxSampler` does.

Two narrow bands per N:
  * `half_width` 3 (OpenVDB's default): errors over the probes inside its band only;
  * a band as wide as the probes' (|d| ≤ probes' band), so every probe is measured
    (only for N ≤ $PROBE_BAND_MAX_N, default 1024: its voxel count grows as N³).
OpenVDB needs a closed mesh for its sign (PEERS.md: on the open bunny almost the whole band
reads outside). Where its signs agree with the exact ones (at ≥ 99 % of the probes farther
than a voxel from the surface) the error is the signed one, |v − d|; otherwise (the open
bunny) it is the error of the unsigned distance, | |v| − |d| |, and `sign_agreement` says
how often the sign was right. The unsigned distance has a kink on the surface that
trilinear interpolation rounds off, so near the surface its error is of the order of the
voxel size.

Prints one JSON object: per (N, band) the voxel size, active voxels, memUsage bytes, build
seconds, points measured, max and RMS error relative to the diagonal, and whether the max
error meets the ADF's, and for each band
the smallest-memory grid that meets it.
"""
import json
import math
import os
import sys
import time

import numpy as np
import pyopenvdb as vdb


def load_obj(path):
    verts, tris = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(tok.split("/")[0]) for tok in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    tris.append([idx[0], idx[k], idx[k + 1]])
    return np.array(verts, dtype=np.float64), np.array(tris, dtype=np.int32)


def trilinear(acc, p, h):
    g = p / h
    i0 = np.floor(g).astype(np.int64)
    f = g - i0
    total = 0.0
    active = True
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                value, on = acc.probeValue((int(i0[0] + dx), int(i0[1] + dy), int(i0[2] + dz)))
                active = active and on
                w = (f[0] if dx else 1 - f[0]) * (f[1] if dy else 1 - f[1]) * (f[2] if dz else 1 - f[2])
                total += w * value
    return total, active


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    mesh, probes_path = sys.argv[1], sys.argv[2]
    sizes = [int(x) for x in sys.argv[3:]] or [256, 512, 1024, 2048]
    # The probe-wide band grows as 1/h³: above this N only the half-width-3 band is built.
    probe_band_max_n = int(os.environ.get("PROBE_BAND_MAX_N", "1024"))
    verts, tris = load_obj(mesh)
    probes = json.load(open(probes_path))
    if probes.get("format") != "volga-adf-probes/1":
        sys.exit(f"{probes_path}: not a volga-adf-probes/1 file")
    table = np.array(probes["probes"], dtype=np.float64)
    points, exact, adf_values = table[:, :3], table[:, 3], table[:, 4]
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    diagonal = float(probes["diagonal"])
    target = float(np.abs(adf_values - exact).max() / diagonal)
    adf_rms = float(np.sqrt(((adf_values - exact) ** 2).mean()) / diagonal)
    band = float(np.abs(exact).max())
    rows = []
    for n in sizes:
        h = float((hi - lo).max()) / n
        bands = [("half_width_3", 3.0)]
        if n <= probe_band_max_n:
            bands.append(("probe_band", math.ceil(band / h) + 2.0))
        for name, half_width in bands:
            t = time.perf_counter()
            grid = vdb.FloatGrid.createLevelSetFromPolygons(
                verts.astype(np.float32), triangles=tris,
                transform=vdb.createLinearTransform(voxelSize=h), halfWidth=half_width)
            build_s = time.perf_counter() - t
            acc = grid.getConstAccessor()
            signed, unsigned, agree, far = [], [], 0, 0
            for p, d in zip(points, exact):
                v, active = trilinear(acc, p, h)
                if active:
                    signed.append(abs(v - d))
                    unsigned.append(abs(abs(v) - abs(d)))
                    if abs(d) > h:
                        far += 1
                        agree += (v < 0) == (d < 0)
            sign_agreement = agree / far if far else None
            kind = "signed" if far and sign_agreement >= 0.99 else "unsigned"
            errs = np.array(signed if kind == "signed" else unsigned) if signed else np.array([math.nan])
            row = {
                "n": n, "band": name, "half_width_voxels": half_width, "voxel_size": h,
                "active_voxels": grid.activeVoxelCount(), "bytes": grid.memUsage(),
                "build_s": build_s, "error_kind": kind, "sign_agreement": sign_agreement, "points": int(np.isfinite(errs).sum()),
                "max_error": float(errs.max() / diagonal), "rms_error": float(np.sqrt((errs ** 2).mean()) / diagonal),
            }
            row["meets_target"] = bool(row["max_error"] <= target)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr)
            del grid
    best = {}
    for name in ("half_width_3", "probe_band"):
        ok = [r for r in rows if r["band"] == name and r["meets_target"]]
        best[name] = min(ok, key=lambda r: r["bytes"]) if ok else None
    print(json.dumps({"peer": "OpenVDB 10.0.1 (python3-openvdb)", "mesh": mesh, "diagonal": diagonal,
                      "target_max_error": target, "adf_rms_error": adf_rms, "probe_points": len(points), "probe_band": band,
                      "grids": rows, "smallest_meeting_target": best}, indent=1))


if __name__ == "__main__":
    main()
