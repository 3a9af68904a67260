#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite, each stage ending with its runner's summary,
# and the end repeating them together:
#   release   the Release build and every test (unit, integration, stress, golden, Python
#             client and grading kit, preview page in Chromium, the quick load and fault run)
#   asan      the same under ASan+UBSan, built by clang with libFuzzer's coverage, so that the
#             same build holds the libFuzzer targets: the committed crashers are replayed in its
#             ctest, then each target is fuzzed for FUZZ_SECONDS (default 20)
#   tsan      the server's concurrency tests (connections, registry, caches, jobs) under
#             ThreadSanitizer (tests/tsan/suppressions.txt: the uninstrumented TBB and Embree)
# Sanitizer builds use clang at -O1 with line tables only: they compile in about half the time
# of gcc's -O2 -g, and CI has two cores. The tests' own code is built lighter still
# (cmake/test_code.cmake; docs/testing.md has where the minutes go).
# Flags: --release-only (the first stage alone), --long (the long load and fault run, and
# fuzzing for 10 minutes a target).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# Formatting first: it takes a second and names the one command that fixes it.
scripts/check_format.sh
jobs="$(nproc)"
failed=0
presets=(release asan tsan)
fuzz=1
long=0
for arg in "$@"; do
    case "$arg" in
        --release-only) presets=(release); fuzz=0 ;;
        --long) long=1 ;;
        *) echo "test.sh: unknown option $arg" >&2; exit 2 ;;
    esac
done
summary="$(mktemp)"
trap 'rm -f "$summary" "$summary.log" "$summary.times"' EXIT
: >"$summary.times"
# Each stage's build and test times go into the summary, so that CI's log says where its
# minutes went.
stage_start=$SECONDS
lap() { echo "$1 $((SECONDS - stage_start)) s" >>"$summary.times"; stage_start=$SECONDS; }
for preset in "${presets[@]}"; do
    echo "=== ${preset}: configure and build" >&2
    scripts/configure.sh "$preset"
    cmake --build --preset "$preset" -j"$jobs"
    lap "${preset}: build"
    echo "=== ${preset}: test" >&2
    # A failing stage does not stop the later ones (their failures are worth seeing in the same
    # run); the script fails at the end.
    ctest --preset "$preset" -j"$jobs" --timeout 600 | tee "$summary.log" || failed=1
    lap "${preset}: test"
    sed -n "s/^\([0-9]*% tests passed.*\)/${preset}: \1/p" "$summary.log" >>"$summary"
    if [[ "$preset" == asan ]] && ((fuzz)); then
        # The asan build (clang, fuzzer-no-link) holds the libFuzzer targets too; its ctest has
        # replayed the committed crashers (fuzz_regressions). Each target then runs for
        # FUZZ_SECONDS (20 s), one target a core at a time (tests/fuzz/run.sh --jobs).
        echo "=== fuzz: run" >&2
        seconds="${FUZZ_SECONDS:-20}"
        ((long)) && seconds=600
        tests/fuzz/run.sh --seconds "$seconds" --build-dir build/asan | tee "$summary.log" ||
            failed=1
        sed -n 's/^\(fuzz: .*\)/\1/p' "$summary.log" >>"$summary"
        lap "fuzz: run"
    fi
done
if ((long)); then
    echo "=== long load and fault run" >&2
    /usr/bin/python3 tests/load/run.py --long --server build/release/server/raycastd \
        --shared "$(cd .. && pwd)/shared" --report docs/reliability.md \
        --fuzz-summary build/asan/summary | tee "$summary.log" ||
        failed=1
    sed -n 's/^\(load: .*\)/\1/p' "$summary.log" >>"$summary"
fi
echo "=== summary" >&2
cat "$summary"
echo "times: $(paste -sd, "$summary.times" | sed 's/,/, /g'); total ${SECONDS} s"
exit "$failed"
