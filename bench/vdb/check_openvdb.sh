#!/usr/bin/env bash
# Every kind of .vdb volga writes, judged by OpenVDB itself; OpenVDB's own files read by
# volga. Outside CI: needs Debian's OpenVDB 10 (`apt-get install -y python3-openvdb
# libopenvdb-tools`) and a release build of volga.
#
#   bench/vdb/check_openvdb.sh [VOLGA]        # VOLGA defaults to target/release/volga
#
# 1. volga writes each volume twice, as .vdb and as .nrrd (the same voxels):
#    voxelize (level set in blosc (the default)/none/zip/half, anti-aliased fog, 26-separating binary),
#    a scene's baked volume with colour, a sculpt, and an ADF's narrow band (converted to
#    NRRD by `volga convert`); the golden files of crates/volga-io/tests/vdb_files.rs are
#    rewritten and must equal the committed ones. check_openvdb.py `pairs` compares
#    OpenVDB's reading of every .vdb with the NRRD, voxel for voxel.
# 2. check_openvdb.py `reverse`: OpenVDB writes level sets (a sphere, the bunny from
#    createLevelSetFromPolygons), a fog volume and a half-float grid; volga reads them.
set -euo pipefail
cd "$(dirname "$0")/../.."
VOLGA=${1:-target/release/volga}
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
mesh=tests/data/stanford-bunny.obj
P="$OUT/pairs"
mkdir -p "$P"
q() { "$@" > /dev/null 2>&1 || { echo "failed: $*" >&2; "$@"; exit 1; }; }

for ext in vdb nrrd; do
  q "$VOLGA" voxelize $mesh --resolution 128 --distance 3 --out "$P/bunny_ls.$ext"
  q "$VOLGA" voxelize tests/data/fandisk.obj --resolution 96 --distance 2 --out "$P/fandisk_ls.$ext"
  q "$VOLGA" voxelize $mesh --resolution 128 --anti-aliased --solid --out "$P/bunny_fog.$ext"
  q "$VOLGA" voxelize $mesh --resolution 128 --separability 26 --out "$P/bunny_binary.$ext"
  q "$VOLGA" sculpt --strokes scenes/sculpt_demo.ron --volume "$P/sculpt.$ext"
done
for c in none zip; do
  q "$VOLGA" voxelize $mesh --resolution 128 --distance 3 --out "$P/bunny_ls_$c.vdb" --vdb-compression $c
  cp "$P/bunny_ls.nrrd" "$P/bunny_ls_$c.nrrd"; cp "$P/bunny_ls.raw" "$P/bunny_ls_$c.raw"
  sed -i "s/bunny_ls.raw/bunny_ls_$c.raw/" "$P/bunny_ls_$c.nrrd"
done
q "$VOLGA" voxelize $mesh --resolution 128 --distance 3 --out "$P/bunny_ls_half.vdb" --vdb-half --vdb-compression blosc
cp "$P/bunny_ls.nrrd" "$P/bunny_ls_half.nrrd"; cp "$P/bunny_ls.raw" "$P/bunny_ls_half.raw"
sed -i "s/bunny_ls.raw/bunny_ls_half.raw/" "$P/bunny_ls_half.nrrd"

# A scene's baked volume with colour, as NRRD and as VDB in one build.
sed -e 's/(name: "hello", colour: false),/(name: "hello", colour: true), (name: "hello_vdb", colour: true, format: Vdb),/' \
    -e '/images: \[/,/\],/d' scenes/hello.ron > "$OUT/hello_vdb.ron"
sed -i 's/outputs: (/outputs: (\n        images: [],/' "$OUT/hello_vdb.ron"
q "$VOLGA" build "$OUT/hello_vdb.ron" --out "$OUT/scene"
for f in hello.nrrd hello.raw hello_colour.nrrd hello_colour.raw; do cp "$OUT/scene/$f" "$P/${f/hello/hello_vdb}"; done
sed -i 's/data file: hello/data file: hello_vdb/' "$P/hello_vdb.nrrd" "$P/hello_vdb_colour.nrrd"
cp "$OUT/scene/hello_vdb.vdb" "$P/"

# An ADF's narrow band (the NRRD through volga's reader).
q "$VOLGA" adf tests/data/fandisk.obj --tolerance 1e-3 --out "$OUT/adf" --vdb "$P/fandisk_adf.vdb" --vdb-resolution 128
q "$VOLGA" convert "$P/fandisk_adf.vdb" "$P/fandisk_adf.nrrd"

# The golden files of the CI test.
VOLGA_VDB_BLESS="$P" cargo test -q --release -p volga-io --test vdb_files volga_files > /dev/null
for f in tests/data/vdb/volga_*.vdb; do cmp "$f" "$P/$(basename "$f")"; done
echo "golden files: identical to tests/data/vdb/volga_*.vdb"

echo "== volga's files, judged by OpenVDB $(/usr/bin/python3 -c 'import pyopenvdb as v; print(v.LIBRARY_VERSION)')"
/usr/bin/python3 bench/vdb/check_openvdb.py pairs "$P"
echo "== OpenVDB's files, read by volga"
/usr/bin/python3 bench/vdb/check_openvdb.py reverse "$OUT/reverse" "$VOLGA"
echo "all checks passed"
