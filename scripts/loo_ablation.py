#!/usr/bin/env python3
"""Choose among ``scripts/ablation.py`` runs made with different configurations, leaving one video out.

Each ``RUN.json`` is an ``ablation.py --json`` report of the same sequences
under one configuration (for instance one point of a grid of ``[sot]
verify_iou`` and ``verify_min_score``, given with ``--config``). For every
row and every sequence, the run whose mean HOTA over the sequences of the
*other* videos is highest is chosen (MOT16-09 and MOT17-09-FRCNN / -SDP are
one video, left out together), and its numbers on the held-out sequence are
reported beside the ``--baseline`` row (default ``MOT``) of the first run.
Printed: per sequence the run chosen, HOTA, MOTA, IDF1, FP and FN against the
baseline; per row the mean HOTA and the combined MOTA over the held-out
sequences (from their FP, FN and IDSW; ground-truth counts recovered from
the baseline's MOTA), and the mean HOTA of every run as measured on all
sequences. The JSON also names, per run, the configuration fields that
differ between the runs.

    python scripts/loo_ablation.py --rows "SOT(deep)+MOT verified" default.json iou0.7.json --json loo.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from common import video_of
from sotmot.io import write_text_atomic

SHOWN = ("HOTA", "MOTA", "IDF1", "FP", "FN")


def ground_truth_boxes(scores: dict) -> float:
    """The ground-truth box count behind a row's MOTA: ``(FP + FN + IDSW) / (1 - MOTA)``."""
    return (scores["FP"] + scores["FN"] + scores["IDSW"]) / (1.0 - scores["MOTA"] / 100.0)


def differences(configs: dict[str, dict]) -> dict[str, dict[str, object]]:
    """Run name -> the configuration fields (``section.field``) whose value is not the same in every run."""
    flat = {run: {f"{section}.{key}": value for section, fields in config.items() if isinstance(fields, dict)
                  for key, value in fields.items()} for run, config in configs.items()}
    keys = sorted({k for fields in flat.values() for k in fields})
    varying = [k for k in keys if len({json.dumps(fields.get(k), sort_keys=True) for fields in flat.values()}) > 1]
    return {run: {k: fields.get(k) for k in varying} for run, fields in flat.items()}


def held_out(runs: dict[str, dict], row: str, baseline: str) -> dict:
    """For each sequence, the run chosen on the other videos and its scores; the combined held-out numbers."""
    first = next(iter(runs.values()))
    names = list(first)
    chosen = {}
    for name in names:
        train = [n for n in names if video_of(n) != video_of(name)]
        best = max(runs, key=lambda run: np.mean([runs[run][n][row]["HOTA"] for n in train]))
        scores, base = runs[best][name][row], first[name][baseline]
        chosen[name] = {"run": best, **{k: scores[k] for k in (*SHOWN, "IDSW")},
                        "baseline": {k: base[k] for k in (*SHOWN, "IDSW")}}
    gt = sum(ground_truth_boxes(c["baseline"]) for c in chosen.values())

    def mota(picked: list[dict]) -> float:
        return 100.0 * (1.0 - sum(p[k] for p in picked for k in ("FP", "FN", "IDSW")) / gt)

    return {"sequences": chosen,
            "mean_HOTA": float(np.mean([c["HOTA"] for c in chosen.values()])),
            "baseline_mean_HOTA": float(np.mean([c["baseline"]["HOTA"] for c in chosen.values()])),
            "MOTA": mota(list(chosen.values())), "baseline_MOTA": mota([c["baseline"] for c in chosen.values()]),
            "per_run_mean_HOTA": {run: float(np.mean([runs[run][n][row]["HOTA"] for n in names])) for run in runs}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN.json", help="ablation.py --json reports")
    parser.add_argument("--rows", required=True, help="comma-separated rows to choose for (in every run)")
    parser.add_argument("--baseline", default="MOT", help="row of the first run to compare with (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write the choices and scores here")
    args = parser.parse_args(argv)
    runs: dict[str, dict] = {}
    configs: dict[str, dict] = {}
    for path in args.runs:
        try:
            report = json.loads(path.read_text())
            runs[path.stem], configs[path.stem] = report["rows"], report.get("config", {})
        except (OSError, ValueError, KeyError) as exc:
            parser.error(f"{path}: not an ablation.py report ({exc})")
    rows = [r for r in args.rows.split(",") if r]
    names, first = list(next(iter(runs.values()))), next(iter(runs))
    for stem, rows_of in runs.items():  # every run has every row of every sequence; the first the baseline too
        needed = [*rows, args.baseline] if stem == first else rows
        absent = [f"{n}: {r}" for n in names for r in needed if r not in rows_of.get(n, {})]
        if absent:
            parser.error(f"{stem}.json lacks {', '.join(absent[:3])}")
    report = {row: held_out(runs, row, args.baseline) for row in rows}
    for row, r in report.items():
        print(f"\n{row}: held out, the run chosen on the other videos by mean HOTA")
        for name, c in r["sequences"].items():
            b = c["baseline"]
            print(f"  {name:<16} [{c['run']}] " + " ".join(
                f"{k} {c[k]:.1f} ({b[k]:.1f})" if k in ("HOTA", "MOTA", "IDF1") else f"{k} {c[k]:.0f} ({b[k]:.0f})"
                for k in SHOWN))
        print(f"  mean HOTA {r['mean_HOTA']:.2f} ({args.baseline} {r['baseline_mean_HOTA']:.2f}); combined MOTA "
              f"{r['MOTA']:.1f} ({r['baseline_MOTA']:.1f}); mean HOTA of each run on all sequences: "
              + ", ".join(f"{run} {v:.2f}" for run, v in r["per_run_mean_HOTA"].items()))
    if args.json:
        write_text_atomic(args.json, json.dumps({"baseline": args.baseline, "runs": differences(configs),
                                                 "rows": report}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
