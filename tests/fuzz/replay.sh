#!/usr/bin/env bash
# Replays the committed crashers: each target's binary runs every file of regressions/<target>/
# once, as a plain input, under the sanitizers it was built with (ctest's fuzz_regressions and
# tests/fuzz/run.sh). Exits non-zero, naming the input and the command, when one fails.
#   replay.sh BIN_DIR REGRESSIONS_DIR TARGET...
set -uo pipefail
bin_dir="$1" regressions="$2"
shift 2
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
failed=0 replayed=0
for target in "$@"; do
    bin="$bin_dir/fuzz_$target"
    [[ -x "$bin" ]] || { echo "replay: $bin not built" >&2; failed=$((failed + 1)); continue; }
    shopt -s nullglob
    inputs=("$regressions/$target"/*)
    shopt -u nullglob
    if ((${#inputs[@]} == 0)); then
        echo "replay: $target: no regression inputs"
        continue
    fi
    for input in "${inputs[@]}"; do
        replayed=$((replayed + 1))
        if ! out="$("$bin" -runs=1 "$input" 2>&1)"; then
            failed=$((failed + 1))
            printf '%s\n' "$out" | tail -40 >&2
            echo "replay: FAILED $input" >&2
            echo "replay: rerun with: $bin $input" >&2
        fi
    done
    echo "replay: $target: ${#inputs[@]} input(s) replayed"
done
echo "replay: $replayed input(s), $failed failed"
((failed == 0))
