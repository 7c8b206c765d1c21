"""The command-line side the scripts in ``scripts/`` share: default paths and common arguments.

Run a script as ``python scripts/NAME.py``; Python puts this folder on the
import path, so ``from common import ...`` finds this module. ``DEFAULT_DATA``
is ``../shared/data`` beside the project, or the environment variable
``SOTMOT_DATA``. What the scripts compute lives in the library
(:mod:`sotmot.benchmarks` and the stages themselves).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sotmot.benchmarks import GROUPS, fit_sequences, more_sequences, only_named, sequences
from sotmot.config import TrackerConfig, load_config
from sotmot.errors import InputError, SotmotError

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = Path(os.environ.get("SOTMOT_DATA", ROOT.parent / "shared" / "data"))
#: Where ``../shared/more/prepare.sh`` built the crowd and the vehicle (:data:`sotmot.benchmarks.MORE_SEQUENCES`):
#: the environment variable ``SOTMOT_MORE``; unset, they are left out (and the benchmark says so).
DEFAULT_MORE = Path(os.environ["SOTMOT_MORE"]) if os.environ.get("SOTMOT_MORE") else None


def add_more_argument(parser: argparse.ArgumentParser) -> None:
    """``--more DIR``: the folder ``../shared/more/prepare.sh`` built the crowd and the vehicle into."""
    parser.add_argument("--more", type=Path, default=DEFAULT_MORE, metavar="DIR",
                        help="folder holding MOT20-01, MOT16-13, MOT17-13-DPM and MOT17-13-FRCNN as "
                             "../shared/more/prepare.sh builds them (default: $SOTMOT_MORE; unset: left out, said)")


def more_found(args: argparse.Namespace) -> list[Path]:
    """The sequences ``--more`` holds, after saying on stderr which are missing and how to build them."""
    found, missing = more_sequences(args.more)
    if missing:
        print(f"{Path(sys.argv[0]).name}: {missing}", file=sys.stderr)
    return found


#: The label-only sequences (detections and ground truth, no frames) whose detections the family maps learn from:
#: MOT16's DPM sets and MOT17's Faster R-CNN and SDP sets (MOT17's DPM sets repeat MOT16's detections).
LABEL_ONLY = ("MOT16-labels/*", "MOT17-labels/*-FRCNN", "MOT17-labels/*-SDP")


def label_only_sequences(data: Path) -> list[Path]:
    """The :data:`LABEL_ONLY` sequence folders under ``data``."""
    return sorted(p for pattern in LABEL_ONLY for p in data.glob(pattern) if (p / "seqinfo.ini").is_file())


def add_confirmation_fit_arguments(parser: argparse.ArgumentParser) -> None:
    """What the confirmation fits share (``scripts/fit_confidence.py``, ``scripts/fit_detector_confidence.py``):
    the solver, the candidate confirmation thresholds and the box model's L2 penalty."""
    parser.add_argument("--solver", "--merger", dest="solver", default="greedy",
                        help="long-term association solver (default: %(default)s)")
    parser.add_argument("--thresholds", default="0.2,0.25,0.3,0.35,0.4,0.45,0.5,0.55,0.6",
                        help="candidate confirmation thresholds; 0 (keep all) is always tried (default: %(default)s)")
    parser.add_argument("--l2", type=float, default=1000.0, help="L2 penalty of the box model (default: %(default)s)")


def add_fit_arguments(parser: argparse.ArgumentParser, cache: Path) -> None:
    """The arguments every leave-one-sequence-out fit script takes: the model, the data and which of its sequences,
    a configuration, the feature cache (default ``cache``) and a JSON report."""
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--min-length", type=int, default=100,
                        help="use sequences with at least this many frames (default: %(default)s)")
    parser.add_argument("--sequences", default="", help="comma-separated sequence names to use (default: every one "
                        "long enough)")
    parser.add_argument("--config", type=Path, help="tracker configuration file (default: the defaults)")
    parser.add_argument("--cache", type=Path, default=cache, help="feature cache folder (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write every number here")


def fit_setup(args: argparse.Namespace) -> tuple[TrackerConfig, list[Path]]:
    """The configuration (with ``--model``) and the sequences of at least ``--min-length`` frames of a fit script;
    exits with the error's message when there are fewer than two (nothing to hold out)."""
    config = (load_config(args.config) if args.config else TrackerConfig()).replace("appearance", model=args.model)
    try:
        return config, fit_sequences(args.data, args.min_length, args.sequences)
    except SotmotError as exc:
        sys.exit(f"{Path(sys.argv[0]).name}: error: {exc}")


def named_sequences(parser: argparse.ArgumentParser, data: Path, only: str,
                    found: list[Path] | None = None) -> list[Path]:
    """Of ``found`` (default: the sequences with frames under ``data``, :func:`sotmot.benchmarks.sequences`), those
    that ``--sequences`` (``only``) names, every one when it names none (:func:`sotmot.benchmarks.only_named`); a
    name none of them has ends the script with the parser's error, naming ``data``."""
    try:
        return only_named(sequences(data) if found is None else found, only, data)
    except InputError as exc:
        parser.error(f"--sequences: {exc}")


def read_report(parser: argparse.ArgumentParser, path: Path, what: str, keys: tuple[str, ...] = ()) -> dict:
    """The JSON report at ``path`` (a script's ``--json`` or ``peers.json``), or ``parser.error`` naming ``what``
    (e.g. ``"--keep x.json"``) where it cannot be read or is not an object holding every one of ``keys``."""
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        parser.error(f"{what}: cannot read a report ({exc})")
    if not isinstance(report, dict):
        parser.error(f"{what}: not a report (a JSON object was expected, found {type(report).__name__})")
    missing = [k for k in keys if k not in report]
    if missing:
        parser.error(f"{what}: not a report of the kind asked for (no {', '.join(missing)})")
    return report


def comma_numbers(parser: argparse.ArgumentParser, flag: str, text: str, kind: type = float) -> list:
    """``text``, a comma-separated list of numbers of ``kind`` (a script's ``flag``), or ``parser.error``."""
    try:
        return [kind(v) for v in text.split(",")]
    except ValueError:
        what = "whole numbers" if kind is int else "numbers"
        parser.error(f"{flag}: {text!r} is not a comma-separated list of {what}")


def write_report(path: Path | None, script: str, argv: list[str] | None, **fields) -> dict:
    """The report of a benchmark run: this machine, the command that ran (``script`` with ``argv``, else the
    process's arguments) and ``fields``; written to ``path`` (a script's ``--json``, atomically) when given."""
    from sotmot.io import write_text_atomic
    from sotmot.versions import machine

    report = {"machine": machine(), "command": " ".join([f"scripts/{script}",
                                                         *(argv if argv is not None else sys.argv[1:])]), **fields}
    if path:
        write_text_atomic(path, json.dumps(report, indent=2) + "\n")
    return report


def run_timed(command: list[str], env: dict[str, str] | None = None) -> dict[str, float]:
    """Run ``command`` in a child process under ``/usr/bin/time`` (its own small parent, so the peak memory is the
    command's alone, not this process's pages shared at fork): wall seconds, CPU seconds (user + system) and peak
    resident memory (MB). Exits with the command's last error output when it fails."""
    with tempfile.TemporaryDirectory(prefix="sotmot-time-") as tmp:
        usage = Path(tmp) / "time.txt"
        start = time.perf_counter()
        done = subprocess.run(["/usr/bin/time", "-o", str(usage), "-f", "%U %S %M", *command],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
        seconds = time.perf_counter() - start
        if done.returncode:
            raise SystemExit(f"{' '.join(command)} failed with exit status {done.returncode}:\n{done.stderr[-3000:]}")
        user, system, peak_kb = usage.read_text().split()[-3:]
    return {"seconds": seconds, "cpu_seconds": float(user) + float(system), "peak_rss_mb": int(peak_kb) / 1024}


def validation_groups(spec: str) -> tuple[str, ...]:
    """``--groups``: comma-separated parts of the validation set (:data:`sotmot.benchmarks.GROUPS`)."""
    groups = tuple(spec.split(","))
    if not set(groups) <= set(GROUPS):
        raise argparse.ArgumentTypeError(f"choose from {', '.join(GROUPS)}, got {spec!r}")
    return groups


def named_config(spec: str) -> tuple[str, tuple[TrackerConfig, str]]:
    """``NAME=FILE`` -> ``(NAME, (configuration, what it is))``: the file's first line if it is a comment."""
    name, _, path = spec.partition("=")
    if not name:
        raise argparse.ArgumentTypeError(f"--config takes NAME=FILE (FILE empty: the defaults), got {spec!r}")
    if not path:
        return name, (TrackerConfig(), "today's defaults")
    first = Path(path).read_text(encoding="utf-8").partition("\n")[0]
    return name, (load_config(path), first.lstrip("# ").strip() if first.startswith("#") else path)
