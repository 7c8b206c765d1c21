#!/usr/bin/env bash
# Set up .venv from nothing: the package (editable) with its test and torch extras, pinned by constraints.txt,
# and TrackEval without its declared dependencies (see pyproject.toml for why).
# Safe to run again: an up-to-date .venv is left as it is.
#   --bench  also install the peers of scripts/bench_peers.py (SORT, ByteTrack, OC-SORT, DeepSORT, boxmot)
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
bench=0
for arg in "$@"; do
    case $arg in
        --bench) bench=1 ;;
        *) echo "bootstrap: unknown option $arg (known: --bench)" >&2; exit 2 ;;
    esac
done
stamp=.venv/.sotmot-bootstrap
digest() { (cat pyproject.toml constraints.txt scripts/bootstrap.sh; echo "bench=$1") | sha256sum | cut -d' ' -f1; }
want=$(digest "$bench")
have=$(cat "$stamp" 2>/dev/null || true)
# a .venv set up with --bench also serves a plain run
if [ -x .venv/bin/sotmot ] && { [ "$have" = "$want" ] || { [ "$bench" = 0 ] && [ "$have" = "$(digest 1)" ]; }; }; then
    exit 0
fi
echo "bootstrap: creating .venv and installing sotmot (first run takes a minute or two)" >&2
"$PY" -m venv .venv
extras=test,torch
[ "$bench" = 1 ] && extras=$extras,bench
.venv/bin/python -m pip install --quiet --disable-pip-version-check -c constraints.txt -e ".[$extras]"
.venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps -c constraints.txt \
    trackeval motmetrics
if [ "$bench" = 1 ]; then
    .venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps -c constraints.txt \
        trackers supervision deep-sort-realtime boxmot
fi
echo "$want" > "$stamp"
echo "bootstrap: done (.venv/bin/sotmot)" >&2
