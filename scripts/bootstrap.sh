#!/usr/bin/env bash
# Set up .venv from nothing: the package (editable) with its test and torch extras, pinned by constraints.txt,
# and TrackEval without its declared dependencies (see pyproject.toml for why).
# Safe to run again: an up-to-date .venv is left as it is.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
stamp=.venv/.sotmot-bootstrap
want=$(cat pyproject.toml constraints.txt scripts/bootstrap.sh | sha256sum | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x .venv/bin/sotmot ]; then
    exit 0
fi
echo "bootstrap: creating .venv and installing sotmot (first run takes a minute or two)" >&2
"$PY" -m venv .venv
.venv/bin/python -m pip install --quiet --disable-pip-version-check -c constraints.txt -e ".[test,torch]"
.venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps -c constraints.txt \
    trackeval motmetrics
echo "$want" > "$stamp"
echo "bootstrap: done (.venv/bin/sotmot)" >&2
