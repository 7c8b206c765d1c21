"""The long-term association constraint A(t1, t2): the rule table (paper Sec. 3.4).

This module is the one place where the rules are stated. The checker
(:mod:`sotmot.association.checks`), which every solver calls, the
explanations (``sotmot explain``) and the drawings (``sotmot graph``) iterate
over :data:`RULES`, so all of them obey, and explain, the very same rules:

1. **IoU**: on every temporally overlapping segment (a maximal run of
   consecutive frames where both trajectories have a box) the mean IoU of
   their boxes must be ``> tau_iou`` (0.5). The merged trajectory keeps the
   higher-score box in each shared frame.
2. **Velocity**: in every gap that the merge creates or changes, the speed
   of the box centre under linear motion, ``||c2 - c1|| / (f2 - f1)`` pixels
   per frame, must be ``<= w``, ``2/3 w`` or ``1/3 w`` for a frame difference
   of 1, 2..5 or more than 5, with ``w`` the mean width of the two boxes at
   the gap's ends. Gaps that lie wholly inside one input before the other
   begins (or after it ends) are unchanged by the merge and not re-checked.
3. **Gap**: every gap (frame difference between consecutive boxes) of the
   merged trajectory is ``<= l_max`` (60).
4. **Affinity**: the appearance affinity of the two mean features is
   ``>= min_affinity`` (a gate below which a pair is never merged).
5. **Bridge** (off unless ``long_gap_affinity`` is set): the affinity must
   also reach a gate that rises with the gap the merge creates or changes,
   from ``min_affinity`` at half of ``l_max`` to ``long_gap_affinity`` at
   ``l_max`` (:func:`bridge_gate`).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from sotmot.boxes import centers
from sotmot.config import AssociationConfig

Constraint = Literal["iou", "velocity", "gap", "affinity", "bridge"]

#: A pair's measurements by name (the names of the association graph's edge attributes): scalars or arrays.
Measurements = Mapping[str, Any]


def velocity_bound(gap: np.ndarray | int, width: np.ndarray | float,
                   config: AssociationConfig) -> np.ndarray:
    """Velocity bound in pixels per frame for a gap of ``gap`` frames between boxes of mean ``width``."""
    gap = np.asarray(gap)
    factor = np.where(gap <= 1, config.velocity_adjacent,
                      np.where(gap <= config.short_gap, config.velocity_short, config.velocity_long))
    return factor * np.asarray(width, dtype=np.float64)


def gap_velocity(f1: np.ndarray, b1: np.ndarray, f2: np.ndarray, b2: np.ndarray,
                 config: AssociationConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gap, speed and velocity bound between boxes ``b1`` at frames ``f1`` and ``b2`` at ``f2``.

    Vectorised over rows: ``f1, f2`` are ``(K,)`` frames with ``f2 > f1``,
    ``b1, b2`` are ``(K, 4)`` boxes. Returns the frame differences, the centre
    speeds in pixels per frame (linear motion) and their bounds.
    """
    gaps = np.asarray(f2) - np.asarray(f1)
    speed = np.linalg.norm(centers(b2) - centers(b1), axis=1) / gaps
    bound = velocity_bound(gaps, 0.5 * (np.asarray(b1)[:, 2] + np.asarray(b2)[:, 2]), config)
    return gaps, speed, bound


def rule_failures(overlap, min_iou, max_gap, speed, bound, affinity,
                  config: AssociationConfig, velocity_gap=0) -> dict[Constraint, np.ndarray]:
    """Each rule of :data:`RULES` applied elementwise: per constraint, True where it fails."""
    measured = {"overlap_frames": overlap, "min_segment_iou": min_iou, "max_gap": max_gap, "velocity": speed,
                "velocity_bound": bound, "affinity": affinity, "velocity_gap": velocity_gap}
    return {rule.name: np.asarray(rule.fails(measured, config)) for rule in RULES}


def bridge_gate(gap, config: AssociationConfig) -> np.ndarray:
    """The affinity a link whose created (or changed) gap is ``gap`` frames needs: ``min_affinity`` up to half of
    ``l_max``, rising linearly to ``long_gap_affinity`` at ``l_max`` (``min_affinity`` throughout without it)."""
    gap = np.asarray(gap, dtype=np.float64)
    if config.long_gap_affinity is None:
        return np.full(gap.shape, config.min_affinity)
    rise = np.clip((gap - 0.5 * config.l_max) / (0.5 * config.l_max), 0.0, 1.0)
    return config.min_affinity + rise * (config.long_gap_affinity - config.min_affinity)


def passes_affinity_gate(affinity, config: AssociationConfig) -> np.ndarray:
    """Where an appearance affinity is at least ``min_affinity``: the one statement of the gate.

    NaN never passes (a comparison with NaN is false), so every caller treats an
    undefined affinity the same way: as a pair that is never merged.
    """
    return np.asarray(affinity, dtype=np.float64) >= config.min_affinity


@dataclass(frozen=True)
class Rule:
    """One rule of A(t1, t2): what it measures, when it fails, how it is explained and drawn.

    The checker (:func:`rule_failures`), the explanations (``sotmot explain``)
    and the drawings (``sotmot graph``) iterate over :data:`RULES`, so a new
    rule is one entry there.

    Attributes
    ----------
    name
        The constraint's name (edge attribute ``ok_<name>``, reported in ``failed``).
    measures
        The measurement names (edge attributes) it reads.
    fails
        ``(measurements, config) -> bool array``: True where the rule fails.
    describe
        ``(edge data, config) -> str``: the measurement in plain words, for one pair.
    colour
        BGR colour of a link rejected by this rule in drawings.
    """

    name: Constraint
    measures: tuple[str, ...]
    fails: Callable[[Measurements, AssociationConfig], np.ndarray]
    describe: Callable[[Measurements, AssociationConfig], str]
    colour: tuple[int, int, int]


def _describe_iou(d: Measurements, a: AssociationConfig) -> str:
    if not d["overlap_frames"]:
        return "IoU: no shared frames (rule does not apply)"
    return (f"IoU: {d['overlap_frames']} shared frames, lowest segment mean IoU {d['min_segment_iou']:.3f} "
            f"(must be > {a.tau_iou})")


def _describe_velocity(d: Measurements, a: AssociationConfig) -> str:
    if not math.isfinite(d["velocity_bound"]):
        return "velocity: the merge creates or changes no gap"
    return (f"velocity: {d['velocity']:.2f} px/frame over the worst checked gap of {d['velocity_gap']} frames "
            f"(bound {d['velocity_bound']:.2f})")


#: The rules, in the order a failed one is reported when several fail.
RULES: tuple[Rule, ...] = (
    Rule("iou", ("overlap_frames", "min_segment_iou"),
         lambda m, a: (np.asarray(m["overlap_frames"]) > 0) & ~(np.asarray(m["min_segment_iou"]) > a.tau_iou),
         _describe_iou, (0, 140, 255)),
    Rule("gap", ("max_gap",), lambda m, a: np.asarray(m["max_gap"]) > a.l_max,
         lambda d, a: f"gap: largest gap of the merged trajectory {d['max_gap']} frames (max {a.l_max})",
         (180, 60, 160)),
    Rule("velocity", ("velocity", "velocity_bound"),
         lambda m, a: np.asarray(m["velocity"]) > np.asarray(m["velocity_bound"]),
         _describe_velocity, (40, 40, 220)),
    Rule("affinity", ("affinity",), lambda m, a: ~passes_affinity_gate(m["affinity"], a),
         lambda d, a: f"affinity: {d['affinity']:.3f} (min {a.min_affinity})", (200, 120, 30)),
    Rule("bridge", ("affinity", "velocity_gap"),
         lambda m, a: passes_affinity_gate(m["affinity"], a)  # below min_affinity: the affinity rule's failure
         & ~(np.asarray(m["affinity"], dtype=np.float64) >= bridge_gate(m["velocity_gap"], a)),
         lambda d, a: (f"bridge: affinity {d['affinity']:.3f} over a gap of {d['velocity_gap']} frames "
                       f"(needs {float(bridge_gate(d['velocity_gap'], a)):.3f})"), (120, 200, 30)),
)

#: The constraints' names, in :data:`RULES` order.
CONSTRAINTS: tuple[Constraint, ...] = tuple(rule.name for rule in RULES)
