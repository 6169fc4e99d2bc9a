#!/usr/bin/env bash
# Fuzzes every target of volga for a bounded time:
#   fuzz/run.sh [--engine auto|libfuzzer|stable] [SECONDS_PER_TARGET] [TARGET...]
#
# Engines (docs/FUZZING.md):
# * libfuzzer: cargo-fuzz's coverage-guided libFuzzer. Installs cargo-fuzz from crates.io
#   if missing, builds the targets (release, debug assertions on, so integer overflow is a
#   crash too; no sanitizer: the code under test is safe Rust) and runs each from the
#   committed seeds in fuzz/corpus/<target>/. New inputs go to fuzz/target/corpus/<target>/
#   (not committed). Limits: 10 s per input, 2 GiB resident or per allocation. Works on
#   stable Rust (cargo-fuzz's nightly flags are enabled with RUSTC_BOOTSTRAP=1) but needs
#   a C++ compiler for libFuzzer.
# * stable: the runner in fuzz/src/bin/stable.rs, plain stable Rust and nothing else: the
#   seeds and mutations of them, each target in a child process, every input under
#   catch_unwind, 10 s per input, allocations capped at 2 GiB (an abort is a crash).
# * auto (default, or $VOLGA_FUZZ_ENGINE): libfuzzer when cargo-fuzz is installed or
#   installs and its build succeeds, else stable.
#
# Prints per target the seconds, executions and crashes (libfuzzer: edges covered;
# stable: inputs accepted). Crashes, timeouts and out-of-memory inputs are saved under
# fuzz/artifacts/<target>/; the script exits 1 when there is any, 2 when nothing ran.
set -uo pipefail
cd "$(dirname "$0")"

engine=${VOLGA_FUZZ_ENGINE:-auto}
if [ "${1:-}" = "--engine" ]; then
    engine=${2:?--engine needs auto, libfuzzer or stable}
    shift 2
fi
seconds=${1:-300}
shift || true
targets=("$@")
all=(obj gltf binvox nrrd vdb scene_ron scene_json sculpt_file strokes scene_build adf_build)
[ ${#targets[@]} -eq 0 ] && targets=("${all[@]}")

run_stable() {
    cargo build --profile fuzz-stable --no-default-features --bin stable || exit 2
    target/fuzz-stable/stable --seconds "$seconds" "${targets[@]}"
    exit $?
}

case $engine in
    stable) run_stable ;;
    libfuzzer | auto) ;;
    *) echo "unknown engine \`$engine\` (auto, libfuzzer or stable)" >&2; exit 2 ;;
esac

if ! command -v cargo-fuzz >/dev/null 2>&1; then
    echo "installing cargo-fuzz" >&2
    if ! cargo install cargo-fuzz --locked; then
        [ "$engine" = auto ] && { echo "cargo-fuzz did not install: the stable runner" >&2; run_stable; }
        exit 2
    fi
fi
export RUSTC_BOOTSTRAP=1
flags=(-O -a -s none)
# Target by target: a plain `cargo fuzz build` would also build the stable runner, which
# has no libFuzzer to link against.
for t in "${targets[@]}"; do
    if ! cargo fuzz build "${flags[@]}" "$t"; then
        [ "$engine" = auto ] && { echo "the libFuzzer build failed: the stable runner" >&2; run_stable; }
        exit 2
    fi
done

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
    line=$(printf '%-12s %6ss %12s execs %7s edges  crashes: %s' "$t" "$elapsed" "${execs:-?}" "${cov:-?}" "$crashes")
    echo "$line"
    summary+=("$line")
done
echo
echo "== libFuzzer summary ($seconds s per target, $(date -u +%FT%TZ))"
printf '%s\n' "${summary[@]}"
exit $failed
