#!/usr/bin/env python3
"""How well does each re-ID model separate same-person from different-person pairs? (paper Sec. 5.1)

Samples positive pairs (two ground-truth boxes of one identity in different
frames) and negative pairs (boxes of two identities), uniformly over the
sequence, from pedestrians with visibility >= 0.5 where the ground truth
gives it. For every model it reports the accuracy on positive pairs
(affinity > threshold) and on negative pairs (affinity <= threshold) at the
thresholds the tracker uses, the ROC AUC, and the threshold that balances the
two accuracies. The paper reports 97.4% / 98.5% on MOT16-04 for its model.

Affinity is sotmot's: ``1 - ||f1 - f2|| / 2`` on flip-averaged unit features.

    python scripts/appearance_analysis.py ../shared/data/PETS09-S2L1 ../shared/data/MOT16-04-clip30 \\
        --models ../shared/models/*.onnx --json appearance.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from sotmot.appearance import affinity_rows, make_embedder, roc_auc
from sotmot.config import AppearanceConfig, AssociationConfig, TrackletConfig
from sotmot.io import FrameReader, read_ground_truth, read_seqinfo, write_text_atomic
from sotmot.progress import progress_bar
from sotmot.versions import machine


def sample_pairs(ids: np.ndarray, frames: np.ndarray, n: int, rng: np.random.Generator
                 ) -> tuple[np.ndarray, np.ndarray]:
    """``(n, 2)`` positive and ``(n, 2)`` negative index pairs into the box arrays."""
    by_id = {i: np.flatnonzero(ids == i) for i in np.unique(ids)}
    eligible = np.array([k for k in range(len(ids)) if len(by_id[ids[k]]) > 1])
    pos = np.empty((n, 2), np.int64)
    for row in range(n):
        a = rng.choice(eligible)
        others = by_id[ids[a]][frames[by_id[ids[a]]] != frames[a]]
        pos[row] = a, rng.choice(others)
    neg = np.empty((n, 2), np.int64)
    for row in range(n):
        while True:
            a, b = rng.integers(0, len(ids), size=2)
            if ids[a] != ids[b]:
                neg[row] = a, b
                break
    return pos, neg


def balanced_threshold(pos: np.ndarray, neg: np.ndarray) -> float:
    """Threshold where accuracy on positives (> t) and on negatives (<= t) are closest."""
    grid = np.unique(np.concatenate([pos, neg]))
    tpr = 1.0 - np.searchsorted(np.sort(pos), grid, side="right") / len(pos)
    tnr = np.searchsorted(np.sort(neg), grid, side="right") / len(neg)
    return float(grid[np.argmin(np.abs(tpr - tnr))])


def analyse(seq_dir: Path, models: list[Path], n_pairs: int, seed: int, progress: bool,
            tuned: Path | None = None, variants: tuple[str, ...] = ("onnx",)) -> list[dict]:
    info = read_seqinfo(seq_dir)
    gt = read_ground_truth(info.gt_path, info.length).pedestrians(min_visibility=0.5)
    rng = np.random.default_rng(seed)
    pos, neg = sample_pairs(gt.ids, gt.frames, n_pairs, rng)
    needed = np.unique(np.concatenate([pos.ravel(), neg.ravel()]))
    thresholds = sorted({0.5, 0.75, TrackletConfig().min_affinity, AssociationConfig().min_affinity})
    rows = []
    runs = [(m, m.name if variants == ("onnx",) else f"{m.name} [{v}]", None, v) for m in models for v in variants]
    if tuned is not None:
        import torch

        base = Path(torch.load(tuned, map_location="cpu", weights_only=True)["onnx_model"])
        runs.append((base, f"{base.stem} fine-tuned ({tuned.name})", tuned, "torch"))
    for model, label, weights, variant in runs:
        if weights is None:
            backend, _, noflip = variant.partition(":")
            embedder = make_embedder(AppearanceConfig(model=str(model), backend=backend, flip=noflip != "noflip"))
        else:
            from sotmot.appearance.torch import TorchReidEmbedder

            embedder = TorchReidEmbedder(AppearanceConfig(model=str(model), backend="torch", weights=str(weights)))
        reader = FrameReader(info, cache_size=1)
        features = np.zeros((len(gt.frames), embedder.dim), np.float32)
        start = time.perf_counter()
        frames = np.unique(gt.frames[needed])
        for frame in progress_bar(frames, f"{info.name} {label}", progress, len(frames)):
            idx = needed[gt.frames[needed] == frame]
            features[idx] = embedder.embed(reader(int(frame)), gt.boxes[idx])
        seconds = time.perf_counter() - start
        aff_pos = affinity_rows(features[pos[:, 0]], features[pos[:, 1]])
        aff_neg = affinity_rows(features[neg[:, 0]], features[neg[:, 1]])
        row = {
            "sequence": info.name, "model": label, "pairs": n_pairs, "seed": seed,
            "boxes_embedded": int(len(needed)), "embed_seconds": round(seconds, 2),
            "boxes_per_second": round(len(needed) / seconds, 1),
            "auc": roc_auc(aff_pos, aff_neg), "balanced_threshold": balanced_threshold(aff_pos, aff_neg),
            "positive_mean": float(aff_pos.mean()), "negative_mean": float(aff_neg.mean()),
            "at_threshold": {f"{t:.2f}": {"positive_acc": float((aff_pos > t).mean()),
                                          "negative_acc": float((aff_neg <= t).mean())} for t in thresholds},
        }
        bt = row["balanced_threshold"]
        row["at_balanced"] = {"positive_acc": float((aff_pos > bt).mean()),
                              "negative_acc": float((aff_neg <= bt).mean())}
        rows.append(row)
    return rows


def format_rows(rows: list[dict]) -> str:
    thresholds = list(rows[0]["at_threshold"]) if rows else []
    head = (f"{'sequence':<18} {'model':<60} {'AUC':>6} {'bal.t':>6} {'pos/neg@bal':>12} "
            + " ".join(f"{'pos/neg@' + t:>13}" for t in thresholds))
    lines = [head, "-" * len(head)]
    for r in rows:
        cells = " ".join(f"{100 * v['positive_acc']:5.1f}/{100 * v['negative_acc']:5.1f}  "
                         for v in r["at_threshold"].values())
        bal = r["at_balanced"]
        lines.append(f"{r['sequence']:<18} {r['model']:<60} {r['auc']:6.3f} {r['balanced_threshold']:6.3f} "
                     f"{100 * bal['positive_acc']:5.1f}/{100 * bal['negative_acc']:5.1f} {cells}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("seq_dirs", nargs="+", type=Path, help="sequences with gt/gt.txt and img1/")
    parser.add_argument("--models", nargs="+", type=Path, required=True, help="ONNX re-ID models")
    parser.add_argument("--pairs", type=int, default=3000, help="positive and negative pairs each (paper: 3000)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--tuned", type=Path, help="also a checkpoint from 'sotmot train-appearance' (torch)")
    parser.add_argument("--variants", default="onnx",
                        help="comma-separated appearance backends to run each model with, a ':noflip' suffix "
                             "turning flip-averaging off, e.g. onnx,openvino,openvino:noflip (default: %(default)s); "
                             "boxes_per_second in the JSON includes reading the frames")
    parser.add_argument("--json", type=Path, help="write the rows as JSON here")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    rows = []
    for seq in args.seq_dirs:
        rows.extend(analyse(seq, args.models, args.pairs, args.seed, not args.quiet, args.tuned,
                            tuple(v.strip() for v in args.variants.split(",") if v.strip())))
    print(format_rows(rows))
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
