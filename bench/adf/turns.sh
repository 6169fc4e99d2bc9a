#!/usr/bin/env bash
# The ADF build of the shared meshes with two volga binaries taking turns
# (`volga bench adf --repeat 1 --frames 1`, ROUNDS rounds, medians), at each TOLERANCE.
# The trees must be the same: each run's cells, bytes and maximum and RMS errors are
# compared between the binaries (`same` or DIFFER).
#
#   bench/adf/turns.sh BASE_BIN NEW_BIN [ROUNDS=3] [TOLERANCE ...]   (default 1e-3 1e-4)
#
# MESHES (default "stanford-bunny fandisk spot teapot") names meshes of ../shared/data
# (VOLGA_DATA overrides the folder).
set -euo pipefail
base="$(realpath "$1")"
new="$(realpath "$2")"
rounds="${3:-3}"
shift $(( $# > 3 ? 3 : $# ))
tolerances=("$@")
[[ ${#tolerances[@]} -gt 0 ]] || tolerances=(1e-3 1e-4)
repo="$(cd "$(dirname "$0")/../.." && pwd)"
data="${VOLGA_DATA:-$repo/../shared/data}"
meshes=(${MESHES:-stanford-bunny fandisk spot teapot})

median() { python3 -c 'import sys,statistics; print(statistics.median(float(x) for x in sys.argv[1:]))' "$@"; }
# Prints "build_s tree" where tree is the tree's cells, bytes and errors.
run() {
    "$1" bench adf "$2" --tolerance "$3" --repeat 1 --frames 1 --json 2>/dev/null |
        python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["build_s"], "%d/%d/%r/%r" % (d["cells"], d["bytes"], d["max_error"], d["rms_error"]))'
}

echo "# volga bench adf --repeat 1 --frames 1, build_s, median of $rounds rounds (turns)"
echo "# base $base, new $new; $(nproc) cores; load $(cut -d' ' -f1-3 /proc/loadavg); $(date -u +%F)"
printf '%-16s %9s %9s %9s %7s %s\n' mesh tolerance base_s new_s ratio tree
for mesh in "${meshes[@]}"; do
    for t in "${tolerances[@]}"; do
        b=(); w=(); same=same
        for _ in $(seq "$rounds"); do
            read -r sb tb < <(run "$base" "$data/$mesh.obj" "$t")
            read -r sw tw < <(run "$new" "$data/$mesh.obj" "$t")
            b+=("$sb"); w+=("$sw")
            [[ "$tb" == "$tw" ]] || same=DIFFER
        done
        mb=$(median "${b[@]}"); mw=$(median "${w[@]}")
        printf '%-16s %9s %9.3f %9.3f %7.2f %s\n' "$mesh" "$t" "$mb" "$mw" \
            "$(python3 -c "print($mb / $mw)")" "$same"
    done
done
