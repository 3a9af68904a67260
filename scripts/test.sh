#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite: the Release build, then the ASan+UBSan build,
# then the libFuzzer targets (clang; a short run of each and the committed crashers replayed).
# --release-only skips the last two. Each stage prints ctest's summary line (the fuzz stage,
# run.sh's "fuzz: N passed, M failed"), and the end repeats them together.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# Formatting first: it takes a second and names the one command that fixes it.
scripts/check_format.sh
jobs="$(nproc)"
presets=(release asan)
[[ "${1:-}" == "--release-only" ]] && presets=(release)
summary="$(mktemp)"
trap 'rm -f "$summary" "$summary.log"' EXIT
for preset in "${presets[@]}"; do
    echo "=== ${preset}: configure and build" >&2
    cmake --preset "$preset" >/dev/null
    cmake --build --preset "$preset" -j"$jobs"
    echo "=== ${preset}: test" >&2
    ctest --preset "$preset" -j"$jobs" --timeout 600 | tee "$summary.log"
    sed -n "s/^\([0-9]*% tests passed.*\)/${preset}: \1/p" "$summary.log" >>"$summary"
done
if [[ "${1:-}" != "--release-only" ]]; then
    # Fuzzing (tests/fuzz): only the targets and their dependencies are built (6.5 min on two
    # busy cores), and each target runs for FUZZ_SECONDS (20 s: 141 s for the six, seeding and
    # replays included).
    echo "=== fuzz: configure and build" >&2
    cmake --preset fuzz >/dev/null
    cmake --build --preset fuzz -j"$jobs"
    echo "=== fuzz: run" >&2
    tests/fuzz/run.sh --seconds "${FUZZ_SECONDS:-20}" | tee "$summary.log"
    sed -n 's/^\(fuzz: .*\)/\1/p' "$summary.log" >>"$summary"
    ctest --preset fuzz --timeout 600 | tee "$summary.log"
    sed -n "s/^\([0-9]*% tests passed.*\)/fuzz: \1/p" "$summary.log" >>"$summary"
fi
echo "=== summary" >&2
cat "$summary"
