#!/usr/bin/env bash
# Builds the Gradescope autograder zip for a question folder:
#   clients/grading/gradescope/make_autograder.sh clients/grading/tutorial7 [out.zip]
# It holds setup.sh, run_autograder, python/raycastd, questions/ (the folder given) and
# bin/raycastd: $RAYCASTD_SERVER when it is set (it must then be an executable file), else
# build/release/server/raycastd. With no binary there the zip is not built (exit status 1)
# unless --without-binary says to build it without one (setup.sh then needs --with-source).
# With --with-source it also carries the repository's sources (raycastd-src/) so that
# setup.sh can build the server on an image where the bundled binary does not run.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../../.." && pwd)"
usage="usage: make_autograder.sh [--with-source] [--without-binary] QUESTION_DIR [OUT.zip]"
with_source=0
without_binary=0
while [[ "${1:-}" == --* ]]; do
    case "$1" in
        --with-source) with_source=1 ;;
        --without-binary) without_binary=1 ;;
        *) echo "make_autograder.sh: unknown option $1; $usage" >&2; exit 2 ;;
    esac
    shift
done
questions="${1:?$usage}"
if [[ -n "${RAYCASTD_SERVER:-}" ]]; then
    server="$RAYCASTD_SERVER"
    if [[ ! -f "$server" || ! -x "$server" ]]; then
        echo "make_autograder.sh: \$RAYCASTD_SERVER=$server is not an executable file" >&2
        exit 1
    fi
else
    server="$repo/build/release/server/raycastd"
    if [[ ! -f "$server" || ! -x "$server" ]]; then
        if ((without_binary)); then
            server=""
            echo "make_autograder.sh: building without bin/raycastd (--without-binary)" >&2
        else
            echo "make_autograder.sh: no raycastd server binary: $server does not exist and" \
                "\$RAYCASTD_SERVER is not set. Build the server (cmake --build --preset release)," \
                "set \$RAYCASTD_SERVER, or pass --without-binary (with --with-source, setup.sh" \
                "builds it on the image)" >&2
            exit 1
        fi
    fi
fi
out="$(realpath -m "${2:-autograder.zip}")"
stage="$(mktemp -d)"
trap 'rm -rf "$stage"' EXIT
cp "$here/setup.sh" "$here/run_autograder" "$stage/"
mkdir -p "$stage/python" "$stage/bin"
cp -r "$repo/clients/python/raycastd" "$stage/python/"
find "$stage/python" -name __pycache__ -prune -exec rm -rf {} +
cp -r "$questions" "$stage/questions"
rm -rf "$stage/questions/submissions"
if [[ -n "$server" ]]; then cp "$server" "$stage/bin/raycastd"; fi
if ((with_source)); then git -C "$repo" archive --prefix=raycastd-src/ HEAD | tar -x -C "$stage"; fi
rm -f "$out"
(cd "$stage" && python3 -m zipfile -c "$out" ./*)
echo "wrote $out"
