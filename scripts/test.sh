#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite, each stage ending with its runner's summary:
#   release   the Release build and every test (unit, integration, stress, golden, Python
#             client and grading kit, preview page in Chromium, the quick load and fault run)
#   asan      the same under ASan+UBSan
#   tsan      the concurrency tests (connections, registry, caches, jobs, batches on many
#             threads, renders) under ThreadSanitizer
# Flags: --release-only (the first stage alone), --long (the long load run as well).
# Fuzzing (tests/fuzz/run.sh) follows the sanitizer stages where the fuzz preset exists.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# Formatting first: it takes a second and names the one command that fixes it.
scripts/check_format.sh
jobs="$(nproc)"
presets=(release asan tsan)
long=0
for arg in "$@"; do
    case "$arg" in
        --release-only) presets=(release) ;;
        --long) long=1 ;;
        *) echo "test.sh: unknown option $arg" >&2; exit 2 ;;
    esac
done
for preset in "${presets[@]}"; do
    echo "=== ${preset}: configure and build" >&2
    cmake --preset "$preset" >/dev/null
    cmake --build --preset "$preset" -j"$jobs"
    echo "=== ${preset}: test" >&2
    ctest --preset "$preset" -j"$jobs" --timeout 600
done
if ((long)); then
    echo "=== long load and fault run" >&2
    /usr/bin/python3 tests/load/run.py --long --server build/release/server/raycastd \
        --shared "$(cd .. && pwd)/shared" --report docs/reliability.md
fi
