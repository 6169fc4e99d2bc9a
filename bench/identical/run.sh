#!/usr/bin/env bash
# Nothing lost: runs two volga binaries on the same jobs and compares every output
# byte for byte. Jobs: every committed scene (`volga build`: PNG, NRRD/raw)
# and `volga voxelize` of the five meshes of tests/data at N = 128 and 256 in
# every mode (sizes: SIZES="128 256" by default; 6/18/26-separating surfaces, 26-separating solid, anti-aliased surface
# and solid, signed distance ±3). Reports differ only in timings and are not compared.
#
#   bench/identical/run.sh BASE_BIN NEW_BIN [WORKDIR]
#
# BASE_BIN is typically main's binary before a change (`git worktree add /tmp/base
# <commit> && cargo build --release` there), NEW_BIN `target/release/volga`.
# Exit 0 when every output is identical, 1 otherwise (the differing files are listed).
set -euo pipefail
base="$(realpath "$1")"
new="$(realpath "$2")"
work="${3:-$(mktemp -d)}"
repo="$(cd "$(dirname "$0")/../.." && pwd)"
data="$repo/tests/data"
cd "$repo"

# Scenes the base binary cannot read (added after it) are compared only when both can.
scenes=()
for s in scenes/*.ron scenes/*.json; do
    if "$base" plan "$s" >/dev/null 2>&1; then
        scenes+=("$s")
    else
        echo "skipped $s: the base binary does not read it (a newer scene)"
    fi
done

run_all() {
    local bin="$1" out="$2"
    mkdir -p "$out"
    for s in "${scenes[@]}"; do
        local name
        name="$(basename "$s" | tr . _)"
        "$bin" --threads 2 build "$s" --out "$out/scene_$name" >/dev/null
        rm -f "$out/scene_$name/report.json"
    done
    for mesh in stanford-bunny spot teapot fandisk rocker-arm; do
        for n in ${SIZES:-128 256}; do
            local stem="$out/${mesh}_$n"
            for s in 6 18 26; do
                "$bin" voxelize "$data/$mesh.obj" --resolution $n --separability $s --out "${stem}_sep$s.binvox" >/dev/null
            done
            "$bin" voxelize "$data/$mesh.obj" --resolution $n --separability 26 --solid --out "${stem}_solid26.binvox" >/dev/null
            "$bin" voxelize "$data/$mesh.obj" --resolution $n --anti-aliased --out "${stem}_aa.nrrd" >/dev/null
            "$bin" voxelize "$data/$mesh.obj" --resolution $n --anti-aliased --solid --out "${stem}_aasolid.nrrd" >/dev/null
            "$bin" voxelize "$data/$mesh.obj" --resolution $n --distance 3 --out "${stem}_dist3.nrrd" >/dev/null
        done
    done
}

echo "base: $base -> $work/base"
run_all "$base" "$work/base"
echo "new:  $new -> $work/new"
run_all "$new" "$work/new"

total=0
differ=0
while IFS= read -r -d '' f; do
    rel="${f#"$work/base/"}"
    total=$((total + 1))
    if ! cmp -s "$f" "$work/new/$rel"; then
        echo "DIFFERS: $rel"
        differ=$((differ + 1))
    fi
done < <(find "$work/base" -type f -print0 | sort -z)
extra=$(cd "$work/new" && find . -type f | wc -l)
echo "compared $total files (new run wrote $extra): $differ differ"
[ "$differ" -eq 0 ] && [ "$extra" -eq "$total" ]
