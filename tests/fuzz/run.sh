#!/usr/bin/env bash
# Runs the libFuzzer targets of tests/fuzz (built by the `asan` preset, or the `fuzz` one) and reports on them.
#   tests/fuzz/run.sh [--seconds N | --long] [--target NAME] [--jobs N] [--build-dir DIR] [--models DIR]
# For each target: writes its seed corpus into BUILD/corpus/<target>/ (generated documents and
# requests, the models of shared/data/models when present, and the committed crashers of
# tests/fuzz/regressions/<target>/), fuzzes it for N seconds (default 30; --long: 600), then
# replays regressions/<target>/ as plain inputs under the sanitizers, and writes a JSON summary
# to BUILD/summary/<target>.json (tests/load/report.py --fuzz-summary reads the folder). A crash
# prints the reproducer and the command that reruns it. The targets are fuzzed --jobs at a time
# (default: one a core; each has a core to itself for its N seconds). Exits non-zero when a
# target failed; the last line is "fuzz: N passed, M failed".
set -uo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
seconds=30
only=""
jobs="$(nproc)"
build="$repo/build/asan"
models="$repo/../shared/data/models"
while (($#)); do
    case "$1" in
        --seconds) seconds="$2"; shift 2 ;;
        --long) seconds=600; shift ;;
        --target) only="${2#fuzz_}"; shift 2 ;;
        --jobs) jobs="$2"; shift 2 ;;
        --build-dir) build="$2"; shift 2 ;;
        --models) models="$2"; shift 2 ;;
        -h|--help) sed -n '2,/^[^#]/{/^#/s/^# \{0,1\}//p}' "$0"; exit 0 ;;
        *) echo "run.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
done

# target, -max_len, extra libFuzzer flags. max_len fits the largest seed the target takes
# (make_seeds.py's MAX_MODEL_SEED; 128 float64 records + 1 byte for binary_rays).
targets=(
    "scene_doc 32768 -dict=$repo/tests/fuzz/json.dict"
    "gltf 65536"
    "mesh_formats 32768"
    "binary_rays 8193"
    "ray_scanner 4096 -dict=$repo/tests/fuzz/json.dict"
    "http_routes 16384 -dict=$repo/tests/fuzz/json.dict"
)
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || { echo "run.sh: --jobs needs a positive integer, not '$jobs'" >&2; exit 2; }
bin_dir="$build/tests/fuzz"
regressions="$repo/tests/fuzz/regressions"
mkdir -p "$build/corpus" "$build/summary" "$build/logs" "$build/artifacts"

if [[ -d "$models" ]]; then
    python3 "$repo/tests/fuzz/make_seeds.py" --out "$build/corpus" --models "$models"
else
    echo "run.sh: no models at $models: seeding from generated inputs and regressions only" >&2
    python3 "$repo/tests/fuzz/make_seeds.py" --out "$build/corpus" --models /nonexistent 2>/dev/null
fi

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
# The number after a libFuzzer final-stats key (-print_final_stats=1), or 0.
stat() { sed -n "s/^stat::$1: *\([0-9]*\).*/\1/p" "$2" | tail -1 | grep . || echo 0; }

# Fuzzes one target and replays its regressions; writes BUILD/summary/<target>.json and, into
# BUILD/logs/<target>.report, what is to be printed of it (printed in order once all are done,
# so that targets fuzzed side by side do not interleave their reports).
fuzz_one() {
    local name="$1" max_len="$2" extra="$3"
    local bin="$bin_dir/fuzz_$name" corpus="$build/corpus/$name" log="$build/logs/$name.log"
    local report="$build/logs/$name.report"
    exec 3>&2 2>"$report"
    if [[ ! -x "$bin" ]]; then
        echo "run.sh: $bin is not built: cmake --preset asan && cmake --build --preset asan (or the fuzz preset, with --build-dir build/fuzz)" >&2
        return
    fi
    mkdir -p "$corpus" "$build/artifacts/$name"
    [[ -d "$regressions/$name" ]] && cp -n "$regressions/$name"/* "$corpus"/ 2>/dev/null
    echo "=== fuzz $name: ${seconds}s, $(ls "$corpus" | wc -l) inputs in $corpus" >&3
    local start rc elapsed reproducer=""
    start=$(date +%s)
    # shellcheck disable=SC2086  # $extra is a list of flags
    "$bin" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len="$max_len" \
        -print_final_stats=1 -artifact_prefix="$build/artifacts/$name/" $extra "$corpus" \
        >"$log" 2>&1
    rc=$?
    elapsed=$(($(date +%s) - start))
    if ((rc != 0)); then
        reproducer="$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$log" | tail -1)"
        grep -E -A25 "ERROR: (AddressSanitizer|libFuzzer|LeakSanitizer)|runtime error|fuzz property broken" \
            "$log" | head -60 >&2
        echo "run.sh: $name FAILED (exit $rc); log: $log" >&2
        [[ -n "$reproducer" ]] && {
            echo "run.sh: reproducer: $reproducer" >&2
            echo "run.sh: rerun with: $bin $reproducer" >&2
        }
    fi
    local replay_ok=true replay_count
    replay_count=$(ls "$regressions/$name" 2>/dev/null | wc -l)
    "$repo/tests/fuzz/replay.sh" "$bin_dir" "$regressions" "$name" >>"$log" 2>&1 || {
        replay_ok=false
        grep "^replay:" "$log" >&2
    }
    local execs rate result=pass
    execs=$(stat number_of_executed_units "$log")
    rate=$(stat average_exec_per_sec "$log")
    { ((rc != 0)) || ! $replay_ok; } && result=fail
    cat >"$build/summary/$name.json" <<JSON
{"target": "$name", "result": "$result", "seconds": $elapsed, "max_total_time": $seconds,
 "execs": $execs, "execs_per_second": $rate, "new_units": $(stat new_units_added "$log"),
 "corpus_size": $(ls "$corpus" | wc -l), "peak_rss_mb": $(stat peak_rss_mb "$log"),
 "crashes": $((rc != 0 ? 1 : 0)), "reproducer": ${reproducer:+\"}${reproducer:-null}${reproducer:+\"},
 "regressions": $replay_count, "regressions_passed": $($replay_ok && echo true || echo false)}
JSON
    echo "fuzz $name: $result, $execs execs in ${elapsed}s ($rate/s), corpus $(ls "$corpus" | wc -l), $replay_count regression input(s)" >&2
}

# The targets run $jobs at a time (default: one a core), each for the whole of its seconds.
names=()
for spec in "${targets[@]}"; do
    read -r name max_len extra <<<"$spec"
    [[ -n "$only" && "$only" != "$name" ]] && continue
    names+=("$name")
    rm -f "$build/summary/$name.json"
    while (($(jobs -rp | wc -l) >= jobs)); do wait -n || true; done
    fuzz_one "$name" "$max_len" "$extra" &
done
wait
ran=${#names[@]}
passed=0 failed=0
for name in "${names[@]}"; do
    cat "$build/logs/$name.report" >&2
    if grep -q '"result": "pass"' "$build/summary/$name.json" 2>/dev/null; then
        passed=$((passed + 1))
    else
        failed=$((failed + 1))
    fi
done
if ((ran == 0)); then
    echo "run.sh: no target named $only" >&2
    exit 2
fi
echo "fuzz: $passed passed, $failed failed"
((failed == 0))
