#!/usr/bin/env python3
"""Fit the confidence calibration by leave-one-sequence-out, report held-out scores, write the defaults.

For every labelled sequence with frames (default: the full-length ones in the
shared data folder) the tracker runs up to the unconfirmed output; every box
is labelled true or false by TrackEval's matching. Then, holding out one
sequence at a time, the detector-family score maps (isotonic, plus the
label-only sequences such as ``MOT16-labels/*``), the two box models (logistic;
one for calibrated confidences, one for quantile ones) and their confirmation
thresholds (the best mean MOTA over the training sequences among thresholds
with which none of them loses more than 0.5 HOTA or IDF1) are fitted on the
others and the held-out sequence is scored. A held-out sequence whose detector
family appears nowhere else gets a map fitted on itself (``auto`` falls back to
``self``, with the calibrated model). Finally everything is fitted on all sequences: with
``--write`` that is the packaged default.

    .venv/bin/python scripts/fit_confidence.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --json fit_confidence.json --write sotmot/data/confidence.json

Appearance features are cached under ``--cache`` (default ``.cache/features``),
keyed by sequence, model file and preprocessing.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from common import DEFAULT_DATA, add_confirmation_fit_arguments, label_only_sequences
from sotmot.benchmarks import before_confirmation
from sotmot.fitting.confidence import fit, held_out_tracks, labelled_data, score, unconfirmed_tracks
from sotmot.confidence.calibration import OWN_MODELS, model_kind
from sotmot.config import TrackerConfig, load_config
from sotmot.scoring import METRICS
from sotmot.io import read_seqinfo, write_text_atomic

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDSW", "FP", "FN")


def labelled_sequences(data: Path, min_length: int) -> list[Path]:
    """Folders with frames and ground truth and at least ``min_length`` frames."""
    out = []
    for p in sorted(data.iterdir()):
        if (p / "seqinfo.ini").is_file() and (p / "img1").exists() and (p / "gt" / "gt.txt").is_file():
            if read_seqinfo(p).length >= min_length:
                out.append(p)
    return out


def table(title: str, rows: list[tuple[str, dict[str, float]]]) -> str:
    head = f"{title:<28}" + "".join(f"{c:>8}" for c in COLUMNS)
    lines = [head, "-" * len(head)]
    for name, values in rows:
        lines.append(f"{name:<28}" + "".join(
            f"{values[c]:8.1f}" if METRICS[c][2] else f"{values[c]:8.0f}" for c in COLUMNS))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--min-length", type=int, default=100,
                        help="use labelled sequences with at least this many frames (default: %(default)s)")
    parser.add_argument("--labels-only", type=Path, nargs="*",
                        help="sequence folders without frames whose detections and ground truth add to the "
                             "detector-family maps (default: DATA/MOT16-labels/* and the FRCNN and SDP ones of "
                             "DATA/MOT17-labels/; its DPM ones hold MOT16's detections again)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--config", type=Path, help="tracker configuration file (default: the defaults)")
    parser.add_argument("--methods", default="auto,quantile,self",
                        help="[preprocess] confidence methods to compare held out, comma-separated "
                             "(default: %(default)s)")
    parser.add_argument("--cache", type=Path, default=ROOT / ".cache" / "features",
                        help="feature cache folder (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write every number here")
    parser.add_argument("--write", type=Path, help="write the calibration fitted on all sequences here "
                                                   "(sotmot/data/confidence.json is the packaged default)")
    add_confirmation_fit_arguments(parser)
    args = parser.parse_args(argv)

    start = time.perf_counter()
    config = load_config(args.config) if args.config else TrackerConfig()
    # the confidence is recomputed per fold below; "quantile" needs no stored calibration
    config = config.replace("appearance", model=args.model).replace("preprocess", confidence="quantile")
    config = config.replace("confirm", enabled=False)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    thresholds = [float(t) for t in args.thresholds.split(",")]
    seq_dirs = labelled_sequences(args.data, args.min_length)
    if len(seq_dirs) < 2:
        print(f"need at least two labelled sequences under {args.data}; found {len(seq_dirs)}", file=sys.stderr)
        return 1
    label_dirs = label_only_sequences(args.data) if args.labels_only is None else args.labels_only
    with tempfile.TemporaryDirectory(prefix="sotmot-labels-") as tmp:
        seqs, detection_samples, extra = labelled_data(seq_dirs, label_dirs, config, args.solver, args.cache,
                                                       Path(tmp), lambda line: print(line, file=sys.stderr))

    old = before_confirmation(config)
    before = score(seqs, lambda s: unconfirmed_tracks(s, old))
    base = score(seqs, lambda s: unconfirmed_tracks(s, config))
    report: dict = {"sequences": [s.name for s in seqs], "labels_only": [str(p) for p in label_dirs],
                    "solver": args.solver, "thresholds": thresholds, "before": before.to_dict(),
                    "interpolation_bound_only": base.to_dict(), "methods": {}, "folds": {}}
    print(table("before (no confirmation, every gap interpolated)",
                list(before.sequences.items()) + [("COMBINED", before.combined)]))
    print()
    print(table(f"interpolate <= {config.postprocess.interpolate_max_seconds} s only",
                list(base.sequences.items()) + [("COMBINED", base.combined)]))
    fits = {}
    for k, held in enumerate(seqs):
        train = [s for j, s in enumerate(seqs) if j != k]
        fits[held.name] = fit(train, extra, detection_samples, thresholds, config, base, args.l2)
        c = fits[held.name].calibration
        report["folds"][held.name] = {"thresholds": c.thresholds,
                                      "threshold_scores": c.provenance["threshold_scores"],
                                      "box_models": {k: m.to_dict() for k, m in c.box_models.items()}}
    for method in methods:
        held_tracks, used = {}, {}
        for seq in seqs:
            used[seq.name], held_tracks[seq.name] = held_out_tracks(seq, method, fits[seq.name].calibration, config)
        after = score(seqs, lambda s: held_tracks[s.name])
        interp = {s.name: {"before": int(unconfirmed_tracks(s, old).interpolated.sum()),
                           "after": int(held_tracks[s.name].interpolated.sum())} for s in seqs}
        report["methods"][method] = {"held_out": after.to_dict(), "confidence_used": used,
                                     "interpolated_boxes": interp}
        rows = []
        for n, v in after.sequences.items():
            kind = model_kind(used[n])
            rows.append((f"{n} [{used[n]}, t={fits[n].calibration.thresholds[kind]:.2f}]", v))
        print()
        print(table(f"held out, confidence={method}", rows + [("COMBINED", after.combined)]))
    final = fit(seqs, extra, detection_samples, thresholds, config, base, args.l2)
    final.calibration.provenance.update({
        "script": "scripts/fit_confidence.py", "model": Path(args.model).name, "solver": args.solver,
        "labels_only": [p.name for p in label_dirs], "l2": args.l2,
        "interpolate_max_seconds": config.postprocess.interpolate_max_seconds,
    })
    report["final"] = final.calibration.to_dict()
    print(f"\nfitted on all: thresholds {final.calibration.thresholds}, families "
          f"{', '.join(sorted(final.calibration.families))}; {time.perf_counter() - start:.0f} s")
    if args.write:
        data = final.calibration.to_dict()
        if args.write.is_file():  # the built-in detector's family is fitted by fit_detector_confidence.py: kept
            old = json.loads(args.write.read_text(encoding="utf-8"))
            for family in (f for f in OWN_MODELS if f in old.get("families", {})):
                data["families"][family] = old["families"][family]
                for part in ("box_models", "thresholds", "provenance"):
                    if family in old.get(part, {}):
                        data[part][family] = old[part][family]
        write_text_atomic(args.write, json.dumps(data, indent=1) + "\n")
        print(f"calibration written to {args.write}")
    if args.json:
        write_text_atomic(args.json, json.dumps(report, indent=1, default=float) + "\n")
        print(f"report written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
