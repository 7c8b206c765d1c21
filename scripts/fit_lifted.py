#!/usr/bin/env python3
"""The lifted and staged-flow solvers against greedy and flow on the full-length sequences, fitted leave-one-out.

Each labelled sequence of at least ``--min-length`` frames under ``--data``
goes once through cleaning, appearance (cached under ``--cache``) and
tracklets; then greedy, flow, the lifted solver with every candidate
``[association] lifted_threshold`` and the staged flow with every candidate
``flow_stage_gap`` run on those same tracklets, and the full pipeline after
association (interpolation, confirmation) is scored with TrackEval. Each
parameter is chosen leave-one-sequence-out: for each sequence, the value with
the best mean HOTA on the *other* sequences; the table reports what that value
gives on the held-out sequence, beside greedy and flow, and the lifted
objective and solver time of each.

The lifted solver's learned costs (``lifted_costs = "learned"``, the default)
are fitted the same way: each sequence's tracklets get ground-truth identities
(the CLEAR matching), their pairs within the lifted horizon are the samples
(:func:`sotmot.fitting.confidence.lifted_pair_samples`), and the row ``lifted learned``
runs each sequence with the coefficients fitted on the *other* sequences'
pairs (no HOTA is looked at). The coefficients fitted on all sequences are
printed: they are the default ``lifted_coefficients``. The threshold rows run
with ``lifted_costs = "threshold"``.

    python scripts/fit_lifted.py --model ../shared/models/person-reidentification-retail-0288.onnx \
        --json fit_lifted.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from sotmot.association.objective import lifted_objective
from sotmot.appearance import make_embedder
from common import add_fit_arguments, fit_setup
from sotmot.benchmarks import cached_features
from sotmot.fitting.lifted import fit_lifted_costs, lifted_pair_samples, tracklet_identities
from sotmot.scoring import evaluate_files
from sotmot.io import results_path, write_results, write_text_atomic
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.versions import machine

ROOT = Path(__file__).resolve().parents[1]
SHOWN = ("HOTA", "MOTA", "IDF1", "IDSW", "lifted_obj", "solver_s")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_fit_arguments(parser, ROOT / ".cache" / "features")
    parser.add_argument("--thresholds", default="0.45,0.5,0.55",
                        help="candidate lifted thresholds, comma-separated (default: %(default)s)")
    parser.add_argument("--stage-gaps", default="8,15,30",
                        help="candidate flow_stage_gap values of flow-staged, comma-separated (default: %(default)s)")
    args = parser.parse_args(argv)

    config, seq_dirs = fit_setup(args)
    thresholds = [float(t) for t in args.thresholds.split(",")]
    runs = {"greedy": ("greedy", config), "flow": ("flow", config), "lifted learned": ("lifted", config)}
    runs.update({f"lifted@{t:g}": ("lifted", config.replace("association", lifted_costs="threshold",
                                                             lifted_threshold=t)) for t in thresholds})
    gaps = [int(g) for g in args.stage_gaps.split(",") if g.strip()]
    runs.update({f"flow-staged@{g}": ("flow-staged", config.replace("association", flow_stage_gap=g)) for g in gaps})
    families = {"lifted": [f"lifted@{t:g}" for t in thresholds], "flow-staged": [f"flow-staged@{g}" for g in gaps]}
    rows: dict[str, dict[str, dict[str, float]]] = {}
    files: dict[str, list] = {name: [] for name in runs}
    embedder_box: list = [make_embedder(config.appearance)]  # for the sequences not cached, and the end extension
    with tempfile.TemporaryDirectory(prefix="sotmot-lifted-") as tmp:
        prepared_all, samples = [], {}
        for seq_dir in seq_dirs:
            features = cached_features(seq_dir, config, args.cache, embedder_box)
            prepared = prepare_sequence(seq_dir, config, features=features)
            identities = tracklet_identities(prepared.tracklets, prepared.info, Path(tmp) / "identities",
                                             prepared.motion)
            samples[prepared.info.name] = lifted_pair_samples(prepared.tracklets, identities,
                                                              config.association.at(prepared.info.frame_rate))
            prepared_all.append(prepared)
        learned = {seq: fit_lifted_costs([v for s, v in samples.items() if s != seq]) for seq in samples}
        learned_all = fit_lifted_costs(list(samples.values()))
        for prepared in prepared_all:
            seq = prepared.info.name
            limits = config.association.at(prepared.info.frame_rate)
            rows[seq] = {}
            for name, (solver, cfg) in runs.items():
                if name == "lifted learned":  # held out: the coefficients fitted without this sequence
                    cfg = cfg.replace("association", lifted_costs="learned", lifted_coefficients=learned[seq])
                run = finish_sequence(prepared, cfg.replace("association", solver=solver), embedder_box[0])
                path = results_path(Path(tmp) / name, seq)
                write_results(path, run.tracks)
                files[name].append((path, prepared.info.gt_path, prepared.info.length, seq))
                rows[seq][name] = {"lifted_obj": lifted_objective(prepared.tracklets, run.association.groups, limits),
                                   "solver_s": run.timings["association"], **run.association.stats}
            same = int(samples[seq][1].sum())
            print(f"{seq}: {len(prepared.tracklets)} tracklets, {len(samples[seq][1])} labelled pairs ({same} same "
                  f"person), learned without it: " + ", ".join(f"{c:.2f}" for c in learned[seq]),
                  file=sys.stderr, flush=True)
        combined = {}
        for name in runs:
            report = evaluate_files(files[name])
            for seq, scores in report.sequences.items():
                rows[seq][name].update(scores)
            combined[name] = report.combined
        names = list(rows)
        held_out: dict[str, dict[str, str]] = {family: {} for family in families}
        fitted_on_all = {}

        def mean_hota(run: str, seqs: list[str]) -> float:
            return float(np.mean([rows[s][run]["HOTA"] for s in seqs]))

        for family, candidates in families.items():
            chosen = []
            for seq in names:
                train = [s for s in names if s != seq]
                best = max(candidates, key=lambda run: (mean_hota(run, train), -candidates.index(run)))
                held_out[family][seq] = best
                rows[seq][f"{family} held out"] = dict(rows[seq][best], chosen=best)
                chosen.append(next(f for f in files[best] if f[3] == seq))
            combined[f"{family} held out"] = evaluate_files(chosen).combined  # the held-out results, together
            fitted_on_all[family] = max(candidates, key=lambda run: (mean_hota(run, names), -candidates.index(run)))
    for seq in names:
        print(f"\n{seq} (held out: " + ", ".join(held_out[f][seq] for f in families) + ")")
        print(f"  {'solver':<22}" + "".join(f"{c:>12}" for c in SHOWN))
        for name, values in rows[seq].items():
            print(f"  {name:<22}" + "".join(f"{values.get(c, float('nan')):12.{0 if c == 'IDSW' else 2}f}"
                                           for c in SHOWN))
    print(f"\nall {len(names)} sequences: TrackEval combined (held out: each sequence with the value chosen without it)")
    print(f"  {'solver':<22}" + "".join(f"{c:>12}" for c in ("HOTA", "MOTA", "IDF1")))
    for name in combined:
        print(f"  {name:<22}" + "".join(f"{combined[name][c]:12.2f}" for c in ("HOTA", "MOTA", "IDF1")))
    print("fitted on all sequences: " + ", ".join(f"{f} {run}" for f, run in fitted_on_all.items()))
    print("lifted_coefficients fitted on all sequences (the default): "
          + ", ".join(f"{c:.2f}" for c in learned_all))
    print(f"machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "thresholds": thresholds, "stage_gaps": gaps,
                                                 "lifted_coefficients": {"held_out": learned, "all": learned_all},
                                                 "rows": rows, "combined": combined, "held_out": held_out,
                                                 "fitted_on_all": fitted_on_all},
                                                indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
