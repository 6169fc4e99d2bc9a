#!/usr/bin/env bash
# Peak memory and time of the hostile inputs of docs/LIMITS.md, measured from the process
# (/usr/bin/time's maximum resident set size), not from volga's report:
#   bench/bounds/run.sh [VOLGA_BIN] > bench/results/bounds_DATE.txt
# Each line: case, exit code, wall seconds, peak RSS, and the first 160 characters of stderr.
set -uo pipefail
bin=${1:-target/release/volga}
repo=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

run() {
    local name=$1
    shift
    /usr/bin/time -f "%e %M" -o time.txt "$bin" "$@" > out.txt 2> err.txt
    local code=$?
    read -r secs kb < <(tail -n 1 time.txt)
    printf '%-34s exit %3s  %7s s  %8s KiB  %s\n' "$name" "$code" "$secs" "$kb" "$(grep -v '^Command' err.txt | head -c 160 | tr '\n' ' ')"
}

cam='cameras: [(name: "c", eye: (0, 0, 4), target: (0, 0, 0), projection: Perspective(fov_deg: 40.0))]'
img='(name: "i", camera: "c", mode: Iso(value: 0.5), width: 16, height: 16)'
grid='(bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 16)'

# NRRD headers claiming 8000³ and 1024³ voxels over sparse data files.
for n in 8000 1024; do
    printf 'NRRD0004\ntype: uchar\ndimension: 3\nsizes: %s %s %s\nencoding: raw\ndata file: v%s.raw\n\n' $n $n $n $n > v$n.nrrd
    truncate -s $((n * n * n)) v$n.raw
done
run "validate nrrd 8000^3" validate v8000.nrrd
echo "Scene(grid: $grid, root: Volume((path: \"v8000.nrrd\")), $cam, outputs: (images: [$img]))" > vol8000.ron
run "plan Volume 8000^3 --memory-limit 512M" plan vol8000.ron --memory-limit 512M
echo "Scene(grid: $grid, root: Volume((path: \"v1024.nrrd\")), $cam, outputs: (images: [$img]))" > vol1024.ron
run "build Volume 1024^3 --memory-limit 512M" build vol1024.ron --out o1 --memory-limit 512M

# A Sculpt node adding a box across a 16384³ grid.
echo "Scene(grid: (bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 16384), root: Sculpt(operand: Object(shape: Sphere(center: (0, 0, 0), radius: 0.01)), strokes: [(op: Add, tool: Box(min: (-0.9, -0.9, -0.9), max: (0.9, 0.9, 0.9)))]), $cam, outputs: (images: [(name: \"i\", camera: \"c\", mode: Iso(value: 0.5), width: 16, height: 16, source: Lazy)]))" > sculpt.ron
run "build Sculpt node 16384^3 --memory-limit 2G" build sculpt.ron --out o2 --memory-limit 2G

# A mesh output of a sphere on a 4000³ grid.
echo "Scene(grid: (bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 4000), objects: [(shape: Sphere(center: (0, 0, 0), radius: 0.9))], cameras: [], outputs: (meshes: [(name: \"m\", format: Obj)]))" > mesh.ron
run "build mesh output 4000^3 --memory-limit 1G" build mesh.ron --out o3 --memory-limit 1G

# One mesh tool named by 300 strokes.
cp "$repo/tests/data/spot.obj" spot.obj
strokes=$(for i in $(seq 300); do printf '(op: Carve, tool: Mesh(path: "spot.obj", scale: 0.2)), '; done)
echo "Scene(grid: $grid, root: Sculpt(operand: Object(shape: Sphere(center: (0, 0, 0), radius: 0.8)), strokes: [$strokes]), $cam, outputs: (images: [$img]))" > tools.ron
run "build 300 strokes of one mesh tool" build tools.ron --out o4 --memory-limit 512M

# A 17-level sculpt, full, written as voxels and as a mesh.
python3 - <<'PY'
import struct, zlib
b = b"VOLGASCT" + struct.pack("<I", 1) + struct.pack("<3d", 0, 0, 0) + struct.pack("<d", 1.0) + struct.pack("<I", 17)
b += bytes([0]) + struct.pack("<4f", 1.0, 0.5, 0.5, 0.5)
open("full.vsculpt", "wb").write(b + struct.pack("<I", zlib.crc32(b)))
PY
echo 'Strokes(strokes: [])' > none.ron
run "sculpt 17 levels --volume --memory-limit 1G" sculpt --strokes none.ron --sculpt full.vsculpt --volume v.nrrd --memory-limit 1G
run "sculpt 17 levels --mesh --memory-limit 1G" sculpt --strokes none.ron --sculpt full.vsculpt --mesh m.obj --memory-limit 1G

# Devices and pipes.
ln -s /dev/zero zero.obj
run "voxelize /dev/zero" voxelize zero.obj --resolution 64 --separability 26 --out z.binvox
mkfifo pipe.ron
run "plan FIFO" plan pipe.ron

# ADF runaway.
run "adf bunny 1e-7 --memory-limit 1G" adf "$repo/tests/data/stanford-bunny.obj" --tolerance 1e-7 --memory-limit 1G --out o5
run "adf --points 1000000000" adf "$repo/tests/data/stanford-bunny.obj" --points 1000000000 --out o6

echo "# $(date -u +%FT%TZ) commit $(git -C "$repo" rev-parse --short HEAD) bin $bin; $(nproc) cores, $(awk '/MemTotal/ {print $2}' /proc/meminfo) KiB"
