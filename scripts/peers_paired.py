"""sotmot against the peers, run by run: ``bench_peers.py`` reports of the same trackers on a sequence set and on
copies of it whose boxes moved by under half a pixel, read together.

One run of a sequence is a noisy measurement (the validation set's noise floor: half-pixel box offsets move
MOT16-09 by 1.8 HOTA), for sotmot and for the peers alike. Given the report on the boxes themselves first and
the reports on offset copies after it (``bench_peers.py --data`` on the folders ``bench_validation.py --noise``
makes, ``.cache/validation/jitter1`` and ``jitter2``), this prints, per metric, each tracker's value on the boxes
themselves with its lowest and highest over the runs, and the reference tracker's lead over it in each run with
the verdict of :func:`sotmot.inspect.compare.paired_verdict` (the lead keeps one sign in every run, or not)::

    R=../shared/models/person-reidentification-retail-0288.onnx
    S=MOT16-09,MOT17-09-FRCNN,MOT17-09-SDP,PETS09-S2L1,TUD-Stadtmitte
    T="sotmot,ByteTrack +GSI 4s,BoT-SORT +GSI 4s,StrongSORT +GSI 4s,BoostTrack++ +GSI 4s,OccluBoost +GSI 4s"
    .venv/bin/python scripts/bench_peers.py --model $R --runs 1 --sequences $S --trackers "$T" --out peers_j0
    for k in 1 2; do .venv/bin/python scripts/bench_peers.py --model $R --runs 1 --data .cache/validation/jitter$k \\
        --sequences $S --trackers "$T" --out peers_j$k; done
    .venv/bin/python scripts/peers_paired.py peers_j0/peers.json peers_j1/peers.json peers_j2/peers.json

``bench_peers.py --jitter 2`` makes such copies itself (of each sequence's detections file, not of its folder)
and keeps their runs in its one report, which this reads alone (``peers_paired.py peers/peers.json``); its
``peers.md`` ends with the same tables. Nothing is tracked here; the reports must hold the same trackers and
sequences.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from common import read_report
from sotmot.errors import InputError
from sotmot.inspect.compare import SPREAD_COLUMNS, paired_rows
from sotmot.io import refuse_overwriting, write_text_atomic
from sotmot.peers import report_tables


def paired_text(tables: list[dict], reference: str) -> tuple[str, dict[str, dict]]:
    """Per metric of :data:`SPREAD_COLUMNS`, a table of each tracker on the boxes themselves (lowest - highest over
    the runs) and ``reference``'s lead over it run by run; and those rows (:func:`paired_rows`) by metric."""
    lines, out = [], {}
    sequences = list(tables[0][reference])
    for metric in SPREAD_COLUMNS:
        rows = out[metric] = paired_rows(tables, reference, metric)
        lines += ["", f"{metric}: on the boxes themselves (lowest - highest over {len(tables)} runs); "
                      f"{reference}'s lead over it, run by run",
                  "| tracker | " + " | ".join(sequences) + " |", "|---|" + "---|" * len(sequences)]
        for tracker, by_sequence in rows.items():
            cells = []
            for sequence in sequences:
                row = by_sequence[sequence]
                cell = f"{row['runs'][0]:.1f} ({min(row['runs']):.1f} - {max(row['runs']):.1f})"
                if "lead" in row:
                    cell += (f"; {row['lead'][0]:+.2f} ({min(row['lead']):+.2f} to {max(row['lead']):+.2f}: "
                             f"{row['verdict']})")
                cells.append(cell)
            lines.append(f"| {tracker} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n", out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("reports", nargs="+", type=Path, metavar="PEERS.json",
                        help="bench_peers.py reports: the boxes themselves first, then each offset copy; or one "
                             "report of bench_peers.py --jitter, which holds its copies' runs")
    parser.add_argument("--reference", default="sotmot", help="the tracker whose lead is read (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    args = parser.parse_args(argv)
    if args.json:
        try:
            refuse_overwriting([args.json], args.reports, "choose another --json")
        except InputError as exc:
            parser.error(str(exc))
    reports = []
    for path in args.reports:
        reports.append(read_report(parser, path, str(path), ("table",)))
    if len(reports) == 1:
        tables = report_tables(reports[0])
        if len(tables) == 1:
            parser.error(f"{args.reports[0]} holds no runs on offset copies (bench_peers.py --jitter); give the "
                         "reports on the offset copies after it")
    else:
        tables = [r["table"] for r in reports]
    first = tables[0]
    if args.reference not in first:
        parser.error(f"{args.reports[0]}: no tracker {args.reference!r}; there are {', '.join(first)}")
    for k, table in enumerate(tables[1:], 1):
        where = args.reports[k] if len(reports) > 1 else f"{args.reports[0]}'s copy {k}"
        for tracker, by_sequence in first.items():
            missing = set(by_sequence) - set(table.get(tracker, {}))
            if missing:
                parser.error(f"{where}: no {tracker} rows for {', '.join(sorted(missing))}, which "
                             f"{args.reports[0]} has: the reports must hold the same trackers and sequences")
    text, out = paired_text(tables, args.reference)
    print(text, end="")
    if args.json:
        write_text_atomic(args.json, json.dumps({"reports": [str(p) for p in args.reports],
                                                 "reference": args.reference, "rows": out}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
