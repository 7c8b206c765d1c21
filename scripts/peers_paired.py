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

Nothing is tracked here; the reports must hold the same trackers and sequences.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from sotmot.errors import InputError
from sotmot.inspect.compare import SPREAD_COLUMNS, paired_verdict
from sotmot.io import refuse_overwriting, write_text_atomic


def paired_rows(tables: list[dict], reference: str, metric: str) -> dict[str, dict[str, dict]]:
    """``tracker -> sequence -> {"runs": [value per report], "lead": [reference minus it per report] (not for the
    reference itself), "verdict": str}`` from ``bench_peers.py`` tables (``table[tracker][sequence][metric]``),
    the first on the boxes themselves."""
    first = tables[0]
    rows: dict[str, dict[str, dict]] = {}
    for tracker, by_sequence in first.items():
        rows[tracker] = {}
        for sequence in by_sequence:
            runs = [t[tracker][sequence][metric] for t in tables]
            row: dict = {"runs": runs}
            if tracker != reference:
                lead = [t[reference][sequence][metric] - t[tracker][sequence][metric] for t in tables]
                row.update(lead=lead, verdict=paired_verdict(lead))
            rows[tracker][sequence] = row
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("reports", nargs="+", type=Path, metavar="PEERS.json",
                        help="bench_peers.py reports: the boxes themselves first, then each offset copy")
    parser.add_argument("--reference", default="sotmot", help="the tracker whose lead is read (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON")
    args = parser.parse_args(argv)
    if len(args.reports) < 2:
        parser.error("give the report on the boxes themselves and at least one on an offset copy")
    if args.json:
        try:
            refuse_overwriting([args.json], args.reports, "choose another --json")
        except InputError as exc:
            parser.error(str(exc))
    tables = []
    for path in args.reports:
        try:
            tables.append(json.loads(path.read_text(encoding="utf-8"))["table"])
        except (OSError, ValueError, KeyError) as exc:
            parser.error(f"{path}: not a bench_peers.py report ({exc})")
    first = tables[0]
    if args.reference not in first:
        parser.error(f"{args.reports[0]}: no tracker {args.reference!r}; there are {', '.join(first)}")
    for path, table in zip(args.reports[1:], tables[1:]):
        for tracker, by_sequence in first.items():
            missing = set(by_sequence) - set(table.get(tracker, {}))
            if missing:
                parser.error(f"{path}: no {tracker} rows for {', '.join(sorted(missing))}, which "
                             f"{args.reports[0]} has: the reports must hold the same trackers and sequences")
    out = {}
    sequences = list(first[args.reference])
    for metric in SPREAD_COLUMNS:
        rows = paired_rows(tables, args.reference, metric)
        out[metric] = rows
        print(f"\n{metric}: on the boxes themselves (lowest - highest over {len(tables)} runs); "
              f"{args.reference}'s lead over it, run by run")
        print("| tracker | " + " | ".join(sequences) + " |")
        print("|---|" + "---|" * len(sequences))
        for tracker, by_sequence in rows.items():
            cells = []
            for sequence in sequences:
                row = by_sequence[sequence]
                cell = f"{row['runs'][0]:.1f} ({min(row['runs']):.1f} - {max(row['runs']):.1f})"
                if "lead" in row:
                    cell += (f"; {row['lead'][0]:+.2f} ({min(row['lead']):+.2f} to {max(row['lead']):+.2f}: "
                             f"{row['verdict']})")
                cells.append(cell)
            print(f"| {tracker} | " + " | ".join(cells) + " |")
    if args.json:
        write_text_atomic(args.json, json.dumps({"reports": [str(p) for p in args.reports],
                                                 "reference": args.reference, "rows": out}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
