#!/usr/bin/env bash
# Fuzzes every reader of volga for a bounded time: fuzz/run.sh [SECONDS_PER_TARGET] [TARGET...]
#
# Installs cargo-fuzz if missing, builds the libFuzzer targets (release, debug assertions
# on, so integer overflow is a crash too; no sanitizer: the readers are safe Rust), runs
# each target for SECONDS_PER_TARGET (default 300) starting from the committed seeds in
# fuzz/corpus/<target>/, and prints per target: seconds, executions, coverage, crashes.
# New inputs the fuzzer finds go to fuzz/target/corpus/<target>/ (not committed); a
# crash, out-of-memory (> 2 GiB RSS or one allocation > 2 GiB) or timeout (> 10 s per
# input) is saved under fuzz/artifacts/<target>/ and makes the script exit 1.
# Works on stable Rust: cargo-fuzz's nightly flags are enabled with RUSTC_BOOTSTRAP=1.
# docs/FUZZING.md says what each target covers and how to reproduce a crash.
set -uo pipefail
cd "$(dirname "$0")"

seconds=${1:-300}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(obj gltf binvox nrrd scene_ron scene_json)

if ! command -v cargo-fuzz >/dev/null 2>&1; then
    echo "installing cargo-fuzz" >&2
    cargo install cargo-fuzz --locked || exit 2
fi
export RUSTC_BOOTSTRAP=1
flags=(-O -a -s none)
cargo fuzz build "${flags[@]}" || exit 2

summary=()
failed=0
for t in "${targets[@]}"; do
    work=target/corpus/$t
    mkdir -p "$work" "artifacts/$t"
    log=target/fuzz-$t.log
    before=$(ls "artifacts/$t" | wc -l)
    start=$(date +%s)
    cargo fuzz run "${flags[@]}" "$t" "$work" "corpus/$t" -- \
        -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
        -max_len=65536 -print_final_stats=1 >"$log" 2>&1
    status=$?
    elapsed=$(( $(date +%s) - start ))
    # libFuzzer's own figures: "Done N runs in S second(s)" (build time excluded).
    fuzzed=$(grep -o 'Done [0-9]* runs in [0-9]* second' "$log" | tail -n 1 | awk '{print $5}')
    [ -n "$fuzzed" ] && elapsed=$fuzzed
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1)
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*')
    crashes=$(( $(ls "artifacts/$t" | wc -l) - before ))
    if [ "$status" -ne 0 ] && [ "$crashes" -eq 0 ]; then crashes="? (exit $status, see $log)"; fi
    [ "$status" -ne 0 ] && failed=1
    line=$(printf '%-11s %6ss %12s execs %7s edges  crashes: %s' "$t" "$elapsed" "${execs:-?}" "${cov:-?}" "$crashes")
    echo "$line"
    summary+=("$line")
done
echo
echo "== fuzz summary ($seconds s per target, $(date -u +%FT%TZ))"
printf '%s\n' "${summary[@]}"
exit $failed
