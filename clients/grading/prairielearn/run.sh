#!/usr/bin/env bash
# PrairieLearn external-grader entrypoint (info.json: "externalGradingOptions":
# {"image": <an image with python3 and raycastd's libraries>, "entrypoint": "/grade/serverFilesCourse/raycastd/run.sh",
#  "serverFilesCourse": ["raycastd/"]}). The course's serverFilesCourse/raycastd/ holds this
# script, python/raycastd (the package) and bin/raycastd; the question's tests/ folder holds
# questions.toml and its scenes. The student's files are in /grade/student; the results go
# to /grade/results/results.json. GRADE_ROOT replaces /grade, to try it locally; $PYTHON replaces
# python3.
set -uo pipefail
root="${GRADE_ROOT:-/grade}"
kit="$root/serverFilesCourse/raycastd"
export PYTHONPATH="$kit/python${PYTHONPATH:+:$PYTHONPATH}"
# The bundled server when there is one; a $RAYCASTD_SERVER set outside is used as given (the
# kit stops with an error naming it when it does not exist).
if [[ -z "${RAYCASTD_SERVER:-}" && -x "$kit/bin/raycastd" ]]; then
    export RAYCASTD_SERVER="$kit/bin/raycastd"
fi
mkdir -p "$root/results"
exec "${PYTHON:-python3}" -m raycastd grade "$root/tests/questions.toml" \
    --submission "$root/student" \
    --prairielearn "$root/results/results.json" \
    --report -
