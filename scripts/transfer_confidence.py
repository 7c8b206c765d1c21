#!/usr/bin/env python3
"""Does the confidence calibration transfer to a detector it was not fitted on? Leave one detector family out.

Two checks, each beside the in-family fit:

1. **Detections** (no frames needed): every label-only sequence of
   ``MOT17-labels`` (three videos under DPM, Faster R-CNN and SDP) gets
   confidences from (a) its own family's map fitted on that family's other
   label-only sequences (in family), (b) each other family's map (what a
   detector never seen gets when it is taken for that family), and (c) the
   score's rank (quantile). Reported: the Brier score (mean squared gap
   between confidence and the 0/1 label; lower is better) and a reliability
   table (confidence bins against the share of true detections).
2. **Tracking**: the MOT17-09 video under each detector (``MOT16-09`` DPM,
   ``MOT17-09-FRCNN``, ``MOT17-09-SDP``) is tracked with everything fitted
   (a) on all other sequences (in family, as ``fit_confidence.py`` holds it
   out), and (b) without any sequence or label-only data of its family
   (held out detector): its family then has no map, and it is tracked with
   ``auto`` (which falls back to ``self``: a map fitted on the sequence from
   the tracker's own trajectories), ``quantile`` (the score's rank) and each
   other family's map but ACF's (its scores run to 127: any [0, 1] score
   maps to about 0). Scores: HOTA, MOTA, IDF1, FP, FN against the in-family
   fit. The other sequences (other detectors) are tracked with their
   leave-one-sequence-out fit's ``auto``, with ``self`` and with
   ``quantile``, to see what ``self`` costs where a map fits.

    .venv/bin/python scripts/transfer_confidence.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --json docs/results/transfer.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA, ROOT, add_confirmation_fit_arguments, label_only_sequences
from sotmot.confidence.calibration import Calibration
from sotmot.confidence.maps import detection_confidence, quantile_map
from sotmot.config import TrackerConfig
from sotmot.fitting.confidence import (
    detection_labels,
    fit,
    fit_families,
    held_out_tracks,
    labelled_data,
    score,
    unconfirmed_tracks,
)
from sotmot.io import write_text_atomic
from sotmot.versions import machine

#: The video under each detector: the tracking check's held-out sequences, by family.
VIDEO = {"dpm": "MOT16-09", "frcnn": "MOT17-09-FRCNN", "sdp": "MOT17-09-SDP"}
#: The issue's targets: held-out detector against the in-family fit.
TARGETS = {"mota_within": 1.0, "hota_within": 0.5}
SHOWN = ("HOTA", "MOTA", "IDF1", "FP", "FN")
BINS = np.linspace(0.0, 1.0, 11)


def brier(confidence: np.ndarray, labels: np.ndarray) -> float:
    return float(np.mean((confidence - labels) ** 2))


def reliability(confidence: np.ndarray, labels: np.ndarray) -> list[dict[str, float]]:
    """Per confidence bin of width 0.1: detections, mean confidence, share that are true."""
    rows = []
    which = np.clip(np.digitize(confidence, BINS) - 1, 0, len(BINS) - 2)
    for b in range(len(BINS) - 1):
        inside = which == b
        if inside.any():
            rows.append({"bin": f"{BINS[b]:.1f}-{BINS[b + 1]:.1f}", "n": int(inside.sum()),
                         "confidence": float(confidence[inside].mean()), "true": float(labels[inside].mean())})
    return rows


def detection_check(data: Path, config: TrackerConfig, work: Path) -> dict:
    """Brier scores and reliability tables of every MOT17 label-only sequence under every map."""
    samples: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]] = {}
    for seq in sorted(data.glob("MOT17-labels/MOT17-*")):
        family, scores, labels = detection_labels(seq, config, work)
        keep = labels >= 0
        samples.setdefault(family, {})[seq.name] = (scores[keep], labels[keep].astype(np.float64))
    everyone = fit_families({f: list(v.values()) for f, v in samples.items()})
    out: dict = {}
    for family, seqs in samples.items():
        for name, (scores, labels) in seqs.items():
            own = fit_families({family: [v for n, v in seqs.items() if n != name]})[family]
            maps = {"in family": own, **{f"{f} map": everyone[f] for f in everyone if f != family}}
            row = {"family": family, "detections": int(len(labels)), "true_share": float(labels.mean())}
            for label, knots in maps.items():
                p = detection_confidence(scores, (np.asarray(knots[0]), np.asarray(knots[1])))
                row[label] = {"brier": brier(p, labels), "reliability": reliability(p, labels)}
            p = detection_confidence(scores, quantile_map(scores))
            row["quantile"] = {"brier": brier(p, labels), "reliability": reliability(p, labels)}
            out[name] = row
    return out


def without_family(calibration: Calibration, family: str) -> Calibration:
    return Calibration({f: k for f, k in calibration.families.items() if f != family}, calibration.box_models,
                       calibration.thresholds, calibration.provenance)


def with_map(calibration: Calibration, family: str, knots) -> Calibration:
    return Calibration({**calibration.families, family: knots}, calibration.box_models, calibration.thresholds,
                       calibration.provenance)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--sequences", default="MOT16-09,MOT17-09-FRCNN,MOT17-09-SDP,PETS09-S2L1,TUD-Stadtmitte",
                        help="labelled sequences with frames the fits use (default: %(default)s)")
    parser.add_argument("--cache", type=Path, default=ROOT / ".cache" / "features",
                        help="feature cache folder (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write every number here")
    add_confirmation_fit_arguments(parser)
    args = parser.parse_args(argv)
    config = (TrackerConfig().replace("appearance", model=args.model).replace("preprocess", confidence="quantile")
              .replace("confirm", enabled=False))
    thresholds = [float(t) for t in args.thresholds.split(",")]
    with tempfile.TemporaryDirectory(prefix="sotmot-transfer-") as tmp:
        work = Path(tmp)
        detections = detection_check(args.data, config, work)
        seqs, samples, extra = labelled_data([args.data / n for n in args.sequences.split(",")],
                                             label_only_sequences(args.data), config, args.solver, args.cache, work)
    base = score(seqs, lambda s: unconfirmed_tracks(s, config))
    tracking: dict = {}
    for family, name in VIDEO.items():
        held = next(s for s in seqs if s.name == name)
        others = [s for s in seqs if s.name != name]
        in_family = fit(others, extra, samples, thresholds, config, base, args.l2).calibration
        rows = {"in family": held_out_tracks(held, "auto", in_family, config)}
        train = [s for s in others if s.family != family]
        unseen = fit(train, {f: v for f, v in extra.items() if f != family}, samples, thresholds, config, base,
                     args.l2).calibration
        unseen = without_family(unseen, family)  # no map of its own (none was fitted without its data anyway)
        rows["held out: auto"] = held_out_tracks(held, "auto", unseen, config)
        rows["held out: quantile"] = held_out_tracks(held, "quantile", unseen, config)
        for other, knots in unseen.families.items():
            if other not in ("pd0202", "acf"):  # ACF's scores run to 127: any [0, 1] score maps to ~0
                rows[f"held out: {other} map"] = held_out_tracks(held, "auto", with_map(unseen, family, knots),
                                                                 config)
        tracking[name] = {label: {"method": used, **score([held], lambda s, t=tracks: t).sequences[name]}
                          for label, (used, tracks) in rows.items()}
        print(f"{name} ({family}) done", file=sys.stderr)
    for held in (s for s in seqs if s.name not in VIDEO.values()):  # the other detectors: the map or the sequence
        calibration = fit([s for s in seqs if s is not held], extra, samples, thresholds, config, base,
                          args.l2).calibration
        rows = {"in family": held_out_tracks(held, "auto", calibration, config),
                "self": held_out_tracks(held, "self", calibration, config),
                "quantile": held_out_tracks(held, "quantile", calibration, config)}
        tracking[held.name] = {label: {"method": used, **score([held], lambda s, t=tracks: t).sequences[held.name]}
                               for label, (used, tracks) in rows.items()}

    print(f"machine: {machine()}")
    print("\nDetections: Brier score (lower is better)")
    maps = sorted({k for r in detections.values() for k in r if isinstance(r[k], dict)})
    print(f"{'sequence':<16}" + "".join(f"{m:>14}" for m in maps))
    for name, row in detections.items():
        print(f"{name:<16}" + "".join(f"{row[m]['brier']:14.4f}" if m in row else f"{'':>14}" for m in maps))
    print("\nTracking the MOT17-09 video: held-out detector against the in-family fit")
    print(f"{'sequence':<16}{'run':<24}{'method':<10}" + "".join(f"{c:>8}" for c in SHOWN))
    for name, runs in tracking.items():
        for label, r in runs.items():
            print(f"{name:<16}{label:<24}{r['method']:<10}" + "".join(
                f"{r[c]:8.1f}" if c in ("HOTA", "MOTA", "IDF1") else f"{r[c]:8.0f}" for c in SHOWN))
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "model": args.model, "targets": TARGETS,
                                                 "detections": detections, "tracking": tracking}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
