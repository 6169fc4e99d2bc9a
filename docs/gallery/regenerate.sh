#!/bin/sh
# Regenerates docs/gallery from the committed scenes (survey figures 41, 43, 44):
# builds each scene with the release binary, copies its images and its report.json
# (stage times: lazy against baked renders, noise evaluations per node).
#   sh docs/gallery/regenerate.sh
set -eu
cd "$(dirname "$0")/../.."
cargo build --release --bin volga -j1
VOLGA=${CARGO_TARGET_DIR:-target}/release/volga
for scene in fig41 fig43 fig44_noise fig44_fire fig44_fur; do
    out=$(mktemp -d)
    "$VOLGA" build "scenes/cvg/$scene.ron" --out "$out" --threads 2
    cp "$out"/*.png docs/gallery/
    cp "$out/report.json" "docs/gallery/$scene.report.json"
    rm -r "$out"
done
