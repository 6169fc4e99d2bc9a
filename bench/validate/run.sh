#!/usr/bin/env bash
# Builds volga and validates volga's, Open3D's and trimesh's voxelizations of the bunny
# and spot (docs/VALIDATE.md, "Other voxelizers, validated"). Uses the peers' venv from
# bench/peers/run.sh (run that once first, or let this script make it). Outside CI.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="$root/bench/peers/.venv"
if [ ! -x "$venv/bin/python" ]; then
  apt-get install -y libusb-1.0-0 libgomp1 >/dev/null
  /usr/bin/python3 -m venv "$venv"
  "$venv/bin/pip" install -q open3d trimesh scipy numpy
fi
(cd "$root" && cargo build --release --bin volga)
"$venv/bin/python" "$here/compare.py" "$@"
