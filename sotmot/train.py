"""Fine-tune the re-ID model with a batch-hard triplet loss on ground-truth crops (paper Sec. 4).

Crops: considered pedestrians with visibility >= ``min_visibility`` where the
ground truth gives it, at most ``per_identity`` per identity spread over its
track, identities keyed by (sequence, id). A fraction of the *identities*
(never of frames of one identity) is held out for validation. Each step
takes ``ids_per_batch`` identities x ``crops_per_id`` crops; for each
anchor the farthest positive and the nearest negative give
``max(0, d(a, p) - d(a, n) + margin)`` on unit features. Only the last
``train_last`` weight tensors are trained by default (early layers frozen),
so a few epochs run on a CPU in minutes. The checkpoint with the best
validation AUC is written atomically after every epoch.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from sotmot.appearance.base import crop_boxes
from sotmot.config import AppearanceConfig
from sotmot.errors import SotmotError
from sotmot.io import FrameReader, read_ground_truth, read_seqinfo

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TrainConfig:
    """Fine-tuning settings (all have defaults that run in minutes on a CPU)."""

    epochs: int = 3
    ids_per_batch: int = 8
    crops_per_id: int = 4
    per_identity: int = 16
    margin: float = 0.3
    lr: float = 1e-4
    train_last: int = 12
    val_fraction: float = 0.25
    min_visibility: float = 0.5
    seed: int = 0


def collect_crops(seq_dirs: Sequence[str | Path], per_identity: int,
                  min_visibility: float) -> tuple[np.ndarray, np.ndarray]:
    """``(N, 256, 128, 3)`` uint8 crops and ``(N,)`` identity labels (0..K-1 over all sequences)."""
    crops, labels = [], []
    next_label = 0
    for seq in seq_dirs:
        info = read_seqinfo(seq, rate_needed=False)  # crops of the ground truth: no stage counts time
        gt = read_ground_truth(info.gt_path, info.length).pedestrians(min_visibility)
        chosen = []
        for tid in np.unique(gt.ids):
            rows = np.flatnonzero(gt.ids == tid)
            if len(rows) < 2:
                continue
            take = rows[np.linspace(0, len(rows) - 1, min(per_identity, len(rows))).round().astype(int)]
            chosen.extend((int(r), next_label) for r in np.unique(take))
            next_label += 1
        reader = FrameReader(info, cache_size=1)
        by_frame: dict[int, list[tuple[int, int]]] = {}
        for r, label in chosen:
            by_frame.setdefault(int(gt.frames[r]), []).append((r, label))
        for frame, items in sorted(by_frame.items()):
            rows = [r for r, _ in items]
            crops.append(crop_boxes(reader(frame), gt.boxes[rows]))
            labels.extend(label for _, label in items)
    if not crops:
        raise SotmotError("no ground-truth identity with two or more usable boxes in these sequences")
    return np.concatenate(crops), np.asarray(labels)


def batch_hard_triplet(features, labels, margin: float):
    """Mean batch-hard triplet loss of unit ``features`` (torch, ``(N, D)``) with ``labels`` ``(N,)``."""
    import torch

    f = torch.nn.functional.normalize(features, dim=1)
    dist = torch.cdist(f, f)
    same = labels[:, None] == labels[None, :]
    hardest_pos = torch.where(same, dist, torch.zeros_like(dist)).max(dim=1).values
    hardest_neg = torch.where(same, torch.full_like(dist, 1e6), dist).min(dim=1).values
    return torch.relu(hardest_pos - hardest_neg + margin).mean()


def pair_auc(features: np.ndarray, labels: np.ndarray) -> float:
    """ROC AUC of sotmot's affinity over all same-identity vs different-identity pairs."""
    from sotmot.appearance import affinity, roc_auc

    iu = np.triu_indices(len(labels), 1)
    same = (labels[:, None] == labels[None, :])[iu]
    scores = affinity(features, features)[iu]
    return roc_auc(scores[same], scores[~same])


def _save(path: Path, payload: dict) -> None:
    import torch

    from sotmot.io import atomic_path

    with atomic_path(path) as tmp:
        torch.save(payload, tmp)


def train(seq_dirs: Sequence[str | Path], appearance: AppearanceConfig, out: str | Path,
          config: TrainConfig = TrainConfig(), progress: Callable | None = None) -> dict:
    """Fine-tune ``appearance``'s model (torch backend) and write the best checkpoint to ``out``.

    Returns a summary: identities and crops per split, validation AUC before
    and after, loss per epoch, seconds.
    """
    import torch

    from sotmot.appearance.torch import TorchReidEmbedder

    start = time.perf_counter()
    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    crops, labels = collect_crops(seq_dirs, config.per_identity, config.min_visibility)
    ids = np.unique(labels)
    rng.shuffle(ids)
    n_val = max(1, int(round(config.val_fraction * len(ids))))
    val_ids, train_ids = ids[:n_val], ids[n_val:]
    if len(train_ids) < 2:
        raise SotmotError(f"only {len(ids)} identities: too few to train and validate")
    val = np.isin(labels, val_ids)
    embedder = TorchReidEmbedder(appearance)
    module = embedder.module
    params = list(module.parameters())
    for p in params:
        p.requires_grad_(False)
    trainable = params[-config.train_last:] if config.train_last > 0 else params
    for p in trainable:
        p.requires_grad_(True)
    optimiser = torch.optim.Adam(trainable, lr=config.lr)
    by_id = {i: np.flatnonzero(labels == i) for i in train_ids}
    val_before = pair_auc(embedder.embed_crops(crops[val]), labels[val])
    best, best_epoch = val_before, 0
    best_state = {k: v.detach().clone() for k, v in module.state_dict().items()}
    history = []
    out = Path(out)
    steps = max(1, len(train_ids) // config.ids_per_batch)
    epochs = range(1, config.epochs + 1)
    for epoch in (progress(epochs) if progress else epochs):
        module.train()
        losses = []
        order = rng.permutation(train_ids)
        for s in range(steps):
            chosen = order[s * config.ids_per_batch:(s + 1) * config.ids_per_batch]
            if len(chosen) < 2:
                continue
            idx = np.concatenate([rng.choice(by_id[i], config.crops_per_id, replace=len(by_id[i]) < config.crops_per_id)
                                  for i in chosen])
            batch = crops[idx]
            flip = rng.random(len(batch)) < 0.5  # mirrored crops are the same person (paper eq. 1)
            batch[flip] = batch[flip][:, :, ::-1]
            loss = batch_hard_triplet(embedder.forward_crops(batch),
                                      torch.as_tensor(labels[idx], device=embedder.device), config.margin)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            losses.append(float(loss.detach()))
        module.eval()
        auc = pair_auc(embedder.embed_crops(crops[val]), labels[val])
        history.append({"epoch": epoch, "train_loss": float(np.mean(losses)) if losses else None, "val_auc": auc})
        log.info("epoch %d: loss %.4f, validation AUC %.4f", epoch, history[-1]["train_loss"] or 0, auc)
        if auc > best:
            best, best_epoch = auc, epoch
            best_state = {k: v.detach().clone() for k, v in module.state_dict().items()}
        # the best weights so far (epoch 0 = the initial model), so an interrupted run leaves a usable file
        _save(out, {"state_dict": best_state, "onnx_model": str(embedder.path), "train_config": asdict(config),
                    "epoch": best_epoch, "val_auc": best, "sequences": [str(s) for s in seq_dirs]})
    summary = {"sequences": [str(s) for s in seq_dirs], "identities_train": int(len(train_ids)),
               "identities_val": int(len(val_ids)), "crops": int(len(crops)), "crops_val": int(val.sum()),
               "val_auc_before": val_before, "val_auc_best": best, "best_epoch": best_epoch, "history": history,
               "seconds": time.perf_counter() - start, "out": str(out), "config": asdict(config)}
    log.info("%s", json.dumps(summary))
    return summary
