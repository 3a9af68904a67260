#!/usr/bin/env bash
# Builds the Gradescope autograder zip for a question folder:
#   clients/grading/gradescope/make_autograder.sh clients/grading/tutorial7 [out.zip]
# It holds setup.sh, run_autograder, python/raycastd, questions/ (the folder given) and
# bin/raycastd (from $RAYCASTD_SERVER or build/release/server/raycastd, when there is one).
# With --with-source it also carries the repository's sources (raycastd-src/) so that
# setup.sh can build the server on an image where the bundled binary does not run.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../../.." && pwd)"
with_source=0
if [[ "${1:-}" == "--with-source" ]]; then with_source=1; shift; fi
questions="${1:?usage: make_autograder.sh [--with-source] QUESTION_DIR [OUT.zip]}"
out="$(realpath -m "${2:-autograder.zip}")"
stage="$(mktemp -d)"
trap 'rm -rf "$stage"' EXIT
cp "$here/setup.sh" "$here/run_autograder" "$stage/"
mkdir -p "$stage/python" "$stage/bin"
cp -r "$repo/clients/python/raycastd" "$stage/python/"
find "$stage/python" -name __pycache__ -prune -exec rm -rf {} +
cp -r "$questions" "$stage/questions"
rm -rf "$stage/questions/submissions"
server="${RAYCASTD_SERVER:-$repo/build/release/server/raycastd}"
if [[ -x "$server" ]]; then cp "$server" "$stage/bin/raycastd"; fi
if ((with_source)); then git -C "$repo" archive --prefix=raycastd-src/ HEAD | tar -x -C "$stage"; fi
rm -f "$out"
(cd "$stage" && python3 -m zipfile -c "$out" ./*)
echo "wrote $out"
