#!/usr/bin/env python3
"""scikit-image marching cubes on a raw little-endian f32 volume (x fastest), timed.

Usage: skimage_mc.py RAW NX NY NZ LEVEL REPEAT  -> one JSON line
(median seconds of REPEAT timed runs after one warm-up; only the marching_cubes call is
timed). Called by `volga bench sculpt --skimage-python PY`; see bench/sculpt/run.sh.
"""
import json
import sys
import time

import numpy as np
from skimage.measure import marching_cubes

raw, nx, ny, nz, level, repeat = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
volume = np.fromfile(raw, dtype="<f4").reshape(nz, ny, nx)
verts, faces, _, _ = marching_cubes(volume, level)
times = []
for _ in range(repeat):
    t = time.perf_counter()
    verts, faces, _, _ = marching_cubes(volume, level)
    times.append(time.perf_counter() - t)
times.sort()
import skimage
print(json.dumps({"median_s": times[len(times) // 2], "triangles": int(len(faces)), "vertices": int(len(verts)),
                  "skimage": skimage.__version__, "threads": 1}))
