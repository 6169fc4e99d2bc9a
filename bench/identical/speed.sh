#!/usr/bin/env bash
# Speed of two binaries (a base and a changed one), taking turns round by round:
# `volga bench voxelize` of the Stanford bunny on the peer benchmark's two jobs (signed
# distance ±3 voxels, 26-separating surface) at N = 128, 256, 512, then `volga bench
# render` (iso and DVR frames per second of the CT phantom and the bunny at 256, 512²
# pixels; the packed paths). Prints one line per job with each binary's median of the
# round medians and their ratio. Since the peers are not changed, unchanged volga medians
# mean unchanged peer ratios.
#
#   bench/identical/speed.sh BASE_BIN NEW_BIN [ROUNDS=3] [REPEAT=9]
set -euo pipefail
base="$(realpath "$1")"
new="$(realpath "$2")"
rounds="${3:-3}"
repeat="${4:-9}"
repo="$(cd "$(dirname "$0")/../.." && pwd)"
mesh="$repo/tests/data/stanford-bunny.obj"

median() { python3 -c 'import sys,statistics; print(statistics.median(float(x) for x in sys.argv[1:]))' "$@"; }
run() { "$1" bench voxelize "$mesh" --resolution "$2" $3 --repeat "$repeat" 2>/dev/null |
    python3 -c 'import json,sys; print(json.load(sys.stdin)["median_s"])'; }

for mode in "--distance 3" "--separability 26"; do
    for n in 128 256 512; do
        b=(); w=()
        for _ in $(seq "$rounds"); do
            b+=("$(run "$base" "$n" "$mode")")
            w+=("$(run "$new" "$n" "$mode")")
        done
        mb=$(median "${b[@]}"); mw=$(median "${w[@]}")
        python3 -c "print(f'{\"$mode\":18} N={$n:4}  base {$mb:.4f} s  new {$mw:.4f} s  new/base {$mw/$mb:.3f}')"
    done
done

render() { "$1" bench render --json --mesh "$mesh" --repeat 5 --modes iso,dvr 2>/dev/null; }
fps() { python3 -c 'import json,sys; r=json.loads(sys.argv[1]); print(r["volumes"][int(sys.argv[2])][sys.argv[3]])' "$@"; }
declare -A rb rw
for _ in $(seq "$rounds"); do
    jb="$(render "$base")"; jw="$(render "$new")"
    for v in 0 1; do
        for k in iso_fps dvr_fps; do
            rb[$v$k]+=" $(fps "$jb" $v $k)"; rw[$v$k]+=" $(fps "$jw" $v $k)"
        done
    done
done
for v in 0 1; do
    for k in iso_fps dvr_fps; do
        # shellcheck disable=SC2086
        mb=$(median ${rb[$v$k]}); mw=$(median ${rw[$v$k]})
        name=$([ "$v" = 0 ] && echo ct || echo bunny)
        python3 -c "print(f'render {\"$name\":5} {\"$k\":8}  base {$mb:.2f}  new {$mw:.2f}  new/base {$mw/$mb:.3f}')"
    done
done
