#!/usr/bin/env bash
# Fails, naming the files, when a tracked C/C++ file differs from what clang-format 14 makes of it
# with the repository's .clang-format (STYLE.md: Formatting). `--fix` reformats them in place.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || { echo "check_format: clang-format not found (scripts/setup.sh installs it)" >&2; exit 1; }
mapfile -t files < <(git ls-files -- '*.c' '*.cpp' '*.h' '*.cpp.in' | while read -r f; do [[ -f "$f" ]] && echo "$f"; done)
if [[ "${1:-}" == "--fix" ]]; then
    clang-format -i "${files[@]}"
    exit 0
fi
bad=()
for f in "${files[@]}"; do
    clang-format --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if ((${#bad[@]})); then
    echo "check_format: ${#bad[@]} file(s) not formatted with .clang-format:" >&2
    printf '  %s\n' "${bad[@]}" >&2
    echo "check_format: fix them with: scripts/check_format.sh --fix" >&2
    exit 1
fi
echo "check_format: ${#files[@]} files formatted"
