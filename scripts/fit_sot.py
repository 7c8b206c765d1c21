#!/usr/bin/env python3
"""The gates of SOT after association (trajectory ends), fitted leave-one-sequence-out on the full-length sequences.

Each labelled sequence of at least ``--min-length`` frames under ``--data`` is
tracked once with the configuration (appearance cached under ``--cache``),
then its confirmed trajectories' ends are extended once with the loosest gates
of the grid (``sotmot.sot.extend.extend_ends`` with a trace of every added box and
its re-ID affinity). Every grid point -- ``extend_min_confidence`` (the
trajectory's mean confirmation confidence), ``extend_min_affinity`` and
``extend_seconds`` -- is then the same run cut where its gates would have
stopped each end (an end stops at its first box that fails a gate, so cutting
the loose run reproduces the strict one, except that a box cut from one end
no longer blocks another track's end), and scored with TrackEval. Each grid
point is chosen leave-one-sequence-out: for each sequence, the point with the
best mean HOTA on the *other* sequences; the table gives what it does on the
held-out sequence, beside no extension. ``extend_seconds`` is capped by
``--max-seconds``.

    python scripts/fit_sot.py --model ../shared/models/person-reidentification-retail-0288.onnx --json fit_sot.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from sotmot.appearance import make_embedder
from common import add_fit_arguments, fit_setup
from sotmot.benchmarks import cached_features, machine
from sotmot.evaluate import evaluate_files
from sotmot.sot.extend import extend_ends, gated, with_added
from sotmot.io import FrameReader, results_path, write_results, write_text_atomic
from sotmot.pipeline import finish_sequence, prepare_sequence

ROOT = Path(__file__).resolve().parents[1]
SHOWN = ("HOTA", "MOTA", "IDF1", "FP", "FN", "IDSW")


def floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_fit_arguments(parser, ROOT / ".cache" / "features")
    parser.add_argument("--confidences", default="0,0.6,0.7,0.8",
                        help="candidate extend_min_confidence values (default: %(default)s)")
    parser.add_argument("--affinities", default="0.5,0.6,0.7",
                        help="candidate extend_min_affinity values (default: %(default)s)")
    parser.add_argument("--seconds", default="0.5,1.0", help="candidate extend_seconds values (default: %(default)s)")
    args = parser.parse_args(argv)

    config, seq_dirs = fit_setup(args)
    grid = list(itertools.product(floats(args.confidences), floats(args.affinities), floats(args.seconds)))
    loosest = config.replace("sot", extend_min_confidence=0.0, extend_min_affinity=min(g[1] for g in grid),
                             extend_seconds=max(g[2] for g in grid)).sot
    embedder_box: list = []
    traced: dict[str, tuple] = {}
    for seq_dir in seq_dirs:
        prepared = prepare_sequence(seq_dir, config, features=cached_features(seq_dir, config, args.cache,
                                                                                embedder_box))
        run = finish_sequence(prepared, config.replace("sot", extend_seconds=0.0))
        info = prepared.info
        identity = run.identities()
        if not embedder_box:
            embedder_box.append(make_embedder(config.appearance))
        trace: list[dict] = []
        extend_ends(run.tracks, identity, FrameReader(info, cache_size=8), info.length, info.frame_rate,
                    embedder_box[0], loosest, trace=trace)
        traced[info.name] = (info, run.tracks, trace)
        print(f"{info.name}: {len(trace)} end boxes at the loosest gates", file=sys.stderr, flush=True)
    names = list(traced)
    runs = {"none": None, **{f"conf>={c:g} aff>={a:g} {s:g}s": (c, a, s) for c, a, s in grid}}
    rows: dict[str, dict[str, dict]] = {name: {} for name in names}
    files: dict[str, list] = {run: [] for run in runs}
    with tempfile.TemporaryDirectory(prefix="sotmot-fit-sot-") as tmp:
        for index, (run, gates) in enumerate(runs.items()):
            for name in names:
                info, tracks, trace = traced[name]
                if gates is None:
                    out = tracks
                else:
                    c, a, s = gates
                    strict = config.replace("sot", extend_min_confidence=c, extend_min_affinity=a, extend_seconds=s)
                    out = with_added(tracks, [(b["frame"], b["track"], b["box"])
                                              for b in gated(trace, info.frame_rate, strict.sot)])
                path = results_path(Path(tmp) / f"run{index}", name)
                write_results(path, out)
                files[run].append((path, info.gt_path, info.length, name))
                rows[name][run] = {"added": int(out.from_sot.sum())}
        combined = {}
        for run in runs:
            report = evaluate_files(files[run])
            for name, scores in report.sequences.items():
                rows[name][run].update(scores)
            combined[run] = dict(report.combined)
        candidates = [r for r in runs if r != "none"]

        def mean_hota(run: str, seqs: list[str]) -> float:
            return float(np.mean([rows[s][run]["HOTA"] for s in seqs]))

        held_out, chosen_files = {}, []
        for name in names:
            train = [s for s in names if s != name]
            best = max(candidates, key=lambda r: (mean_hota(r, train), -candidates.index(r)))
            held_out[name] = best
            rows[name]["held out"] = dict(rows[name][best], chosen=best)
            chosen_files.append(next(f for f in files[best] if f[3] == name))
        combined["held out"] = dict(evaluate_files(chosen_files).combined)
        combined["held out"]["added"] = sum(rows[n]["held out"]["added"] for n in names)
        combined["none"]["added"] = 0
        fitted_on_all = max(candidates, key=lambda r: (mean_hota(r, names), -candidates.index(r)))
        combined[fitted_on_all]["added"] = sum(rows[n][fitted_on_all]["added"] for n in names)
    head = f"  {'gates':<28}" + "".join(f"{c:>8}" for c in SHOWN + ("added",))
    for name in names:
        print(f"\n{name} (held out: {held_out[name]})\n{head}")
        for run in ("none", "held out", fitted_on_all):
            v = rows[name][run]
            print(f"  {run:<28}" + "".join(f"{v[c]:8.2f}" if c in ("HOTA", "MOTA", "IDF1") else f"{v[c]:8.0f}"
                                           for c in SHOWN + ("added",)))
    print(f"\nall {len(names)} sequences, TrackEval combined\n{head}")
    for run in ("none", "held out", fitted_on_all):
        v = combined[run]
        print(f"  {run:<28}" + "".join(f"{v[c]:8.2f}" if c in ("HOTA", "MOTA", "IDF1") else f"{v[c]:8.0f}"
                                       for c in SHOWN + ("added",)))
    print(f"fitted on all sequences: {fitted_on_all}")
    print(f"machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "grid": grid, "rows": rows,
                                                 "combined": combined, "held_out": held_out,
                                                 "fitted_on_all": fitted_on_all}, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
