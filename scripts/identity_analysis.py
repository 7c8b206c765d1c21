#!/usr/bin/env python3
"""Where identities are lost: fragmentations and switches of sotmot, by the stage that made them, beside a peer's.

Tracks every full-length sequence with frames, or those ``--sequences`` names
(public detections, or with ``--detector-model`` the person detector's boxes,
as ``sotmot track --detections model`` tracks them; the configuration given or
the defaults) and matches its
output to the ground truth with TrackEval's own CLEAR matching
(:func:`sotmot.scoring.frame_errors`).
Counted, for sotmot and for a peer's results on the same boxes (``--peer``, a
results folder of ``scripts/bench_peers.py``, e.g. ``peers/results/StrongSORT_+GSI_4s``):

* **fragmentations**: a person matched to ``k`` output ids counts ``k - 1``;
* **switches**: an output id matched to ``k`` people counts ``k - 1``.

sotmot's are explained by the stage that made them, one count per change of
output id along a life (a person who goes ``a -> b -> a`` is one fragmentation
and two changes, so these counts can exceed the totals above):

* a fragmentation (a person's output id changes from ``a`` to ``b``): the
  trajectories ``a`` and ``b`` as association saw them, checked by the rule
  table (:func:`sotmot.association.checks.check_pair`): ``refused: <rules>``
  (the rules that fail), or ``allowed, not chosen`` (the merge was allowed,
  but one of the two had been merged with someone else first);
* a switch (an output id's person changes between two matched frames):
  ``inside a tracklet`` (both boxes from one tracklet: the tracklet stage
  linked two people), ``a merge`` (boxes of two tracklets that association
  joined), or ``interpolation`` (one of the two boxes is interpolated), told
  apart by the detected boxes on either side of the filled span: ``joins two
  people`` (they are matched to two people: the merge across the gap was
  wrong), ``filled off the person`` (to one: the straight line left them for
  someone else), ``an end unmatched`` (either is matched to no one).

**The ceiling of association** on the same tracklets: each sequence is also
finished (interpolation, confirmation, end extension as configured) with the
solver replaced by the ground truth: every tracklet joined with the others whose
boxes are mostly the same person (:func:`sotmot.fitting.lifted.tracklet_identities`;
a tracklet with no majority person stays alone), the rules of A(t1, t2) not
asked. Its HOTA / IDF1 / MOTA, beside sotmot's and the peer's, say about how
much association of these tracklets can still gain, and what is left to the
stages before it (detection, tracklets). Not a strict bound: interpolation,
confirmation and the end extension judge the joined trajectories again.

**The tracklets' choices** (``--choices``): is appearance the right judge
where the frame-by-frame matching of tracklets has a choice? Each detection
gets the person the CLEAR rule matches it to (every detection a track of its
own, :func:`detection_persons`); a choice is a detection of a known person with
two or more detections of the frame before inside both gates of ``[tracklets]``
(affinity and IoU), exactly one of them that person's. Each candidate's tail is
its own person's last ``tail`` detections, so no earlier mistake of the tracker
counts (a candidate of no known person is its one box). Counted: the choices,
and how many each judge (:data:`JUDGES`) gets right, taking the candidate it
ranks first: the matching's own (appearance), the IoU with the candidate's box,
and the two added. Not counted: a detection whose person has no candidate (was
not detected in the frame before, or fails a gate), the case where the right
answer is to take nothing.

    python scripts/identity_analysis.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --peer peers/results/StrongSORT_+GSI_4s --json identities.json
"""

from __future__ import annotations

import argparse
import bisect
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA, named_sequences
from sotmot.appearance import affinity, motion_only
from sotmot.association.checks import check_pair
from sotmot.benchmarks import FULL_LENGTH, cached_features, private_config, sequences
from sotmot.association import Association
from sotmot.boxes import iou_matrix
from sotmot.config import TrackerConfig, TrackletConfig, load_config
from sotmot.fitting.confidence import clear_matching
from sotmot.fitting.lifted import tracklet_identities
from sotmot.plugins import SOLVERS
from sotmot.scoring import FrameErrors, evaluate_files, frame_errors
from sotmot.io import read_seqinfo, results_path, write_results, write_text_atomic
from sotmot.pipeline import Prepared, TrackResult, finish_sequence, prepare_sequence
from sotmot.types import Detections, Tracks
from sotmot.versions import machine

SCORES = ("HOTA", "IDF1", "MOTA")
#: The ground-truth "solver" of the ceiling: tracklet id -> person, set for the sequence being finished.
_PERSON: dict[int, int] = {}


def ground_truth_solve(tracklets, config) -> Association:
    """Join every tracklet with the others of its person (:data:`_PERSON`); the rules are not asked."""
    groups: dict[int, list[int]] = {}
    for t in tracklets:
        person = _PERSON.get(t.id, -1)
        groups.setdefault(person if person >= 0 else -1 - t.id, []).append(t.id)
    return Association(groups=tuple(sorted(tuple(sorted(g)) for g in groups.values())))


def scores(path: Path, info) -> dict[str, float]:
    """HOTA, IDF1, MOTA of one results file."""
    report = evaluate_files([(path, info.gt_path, info.length, info.name)])
    return {k: round(float(report.sequences[info.name][k]), 2) for k in SCORES}


def lives(errors: FrameErrors) -> tuple[dict[int, list[tuple[int, int]]], dict[int, list[tuple[int, int]]]]:
    """Person -> its matched ``(frame, output id)`` in frame order, and output id -> its ``(frame, person)``."""
    people: dict[int, list[tuple[int, int]]] = {}
    tracks: dict[int, list[tuple[int, int]]] = {}
    for (frame, tid), g in sorted(errors.identities.items()):
        people.setdefault(g, []).append((frame, tid))
        tracks.setdefault(tid, []).append((frame, g))
    return people, tracks


def changes(life: list[tuple[int, int]]) -> list[tuple[int, int, int, int]]:
    """``(frame_a, value_a, frame_b, value_b)`` where consecutive entries of a life change value."""
    return [(fa, a, fb, b) for (fa, a), (fb, b) in zip(life, life[1:]) if a != b]


def counts(errors: FrameErrors) -> dict[str, int]:
    people, tracks = lives(errors)
    return {"fragmentations": sum(len({t for _, t in life}) - 1 for life in people.values()),
            "switches": sum(len({g for _, g in life}) - 1 for life in tracks.values())}


def explain(result: TrackResult, errors: FrameErrors, config: TrackerConfig) -> dict[str, Counter]:
    """sotmot's fragmentations and switches by the stage that made them (see the module docstring)."""
    association = config.association.at(result.info.frame_rate)
    by_output = {i: t for t, i in zip(result.trajectories, result.track_ids) if i is not None}
    tracklet_of = {int(d): t.id for t in result.tracklets for d in t.det_index}
    tracks = result.tracks
    filled = {(int(f), int(i)): bool(x) for f, i, x in zip(tracks.frames, tracks.ids, tracks.interpolated)}
    people, track_lives = lives(errors)
    frag: Counter = Counter()
    for life in people.values():
        for _, a, _, b in changes(life):
            check = check_pair(by_output[a], by_output[b], association)
            frag["refused: " + ", ".join(check.failed) if check.failed else "allowed, not chosen"] += 1
    switch: Counter = Counter()

    def source(tid: int, frame: int) -> int | None:
        t = by_output[tid]
        row = int(np.searchsorted(t.frames, frame))
        return tracklet_of.get(int(t.det_index[row])) if row < len(t) and t.frames[row] == frame else None

    detected: dict[int, list[int]] = {}  # output id -> the frames of its detected (not interpolated) boxes, in order
    for (f, i), x in sorted(filled.items()):
        if not x:
            detected.setdefault(i, []).append(f)

    for tid, life in track_lives.items():
        for fa, _, fb, _ in changes(life):
            if filled.get((fa, tid)) or filled.get((fb, tid)):
                switch[gap_kind(detected.get(tid, []), errors, tid, fa, fb)] += 1
            else:
                a, b = source(tid, fa), source(tid, fb)
                switch["inside a tracklet" if a is not None and a == b else "a merge"] += 1
    return {"fragmentations": frag, "switches": switch}


def gap_kind(detected: list[int], errors: FrameErrors, tid: int, fa: int, fb: int) -> str:
    """A switch of output id ``tid`` between matched frames ``fa`` and ``fb``, one of them interpolated: are the
    detected boxes around the filled span (``detected``: the frames of the id's detected boxes, in order; the last
    at or before ``fa``, the first at or after ``fb``) matched to two people, to one, or is either unmatched?"""
    k = bisect.bisect_right(detected, fa)
    before = detected[k - 1] if k else None
    k = bisect.bisect_left(detected, fb)
    after = detected[k] if k < len(detected) else None
    pa = errors.identities.get((before, tid)) if before is not None else None
    pb = errors.identities.get((after, tid)) if after is not None else None
    if pa is None or pb is None:
        return "interpolation: an end unmatched"
    return "interpolation: joins two people" if pa != pb else "interpolation: filled off the person"


#: What ranks the candidates of one choice (:func:`choices`), from their affinity and IoU with the detection.
JUDGES = {"appearance": lambda aff, iou: aff, "IoU": lambda aff, iou: iou,
          "affinity + IoU": lambda aff, iou: aff + iou}


def detection_persons(prepared: Prepared, workdir: Path) -> np.ndarray:
    """``(N,)`` the ground-truth person each detection of ``prepared`` is matched to by the CLEAR rule (each
    detection written as a track of its own, in its frame's pixels), -1 for none (a distractor, no one)."""
    dets = prepared.detections
    tracks = Tracks(dets.frames, np.arange(1, len(dets) + 1), dets.boxes, dets.scores)
    matched = clear_matching(tracks, prepared.info, workdir).identities
    return np.array([matched.get((int(f), k + 1), -1) for k, f in enumerate(dets.frames)], dtype=np.int64)


def choices(detections: Detections, features: np.ndarray, persons: np.ndarray, config: TrackletConfig
            ) -> dict[str, int]:
    """The tracklets' matching where it has a choice with a known answer (module docstring, ``--choices``):
    ``{"choices": n, judge: right, ...}`` for each of :data:`JUDGES`. ``detections`` as the tracklets see
    them (``x, y, w, h`` pixels of the reference frame, 1-based frames), ``features`` theirs (none: motion
    only, no choice is counted), ``persons`` from :func:`detection_persons`."""
    counts = dict.fromkeys(("choices", *JUDGES), 0)
    if motion_only(features):
        return counts
    by_frame = detections.by_frame()
    seen: dict[int, list[int]] = {}  # person -> their detections so far, in frame order
    for frame in sorted(by_frame):
        cur, prev = by_frame[frame], by_frame.get(frame - 1)
        if prev is not None and len(prev):
            tails = np.stack([features[seen[persons[i]][-config.tail:] if persons[i] >= 0 else [i]].mean(axis=0)
                              for i in prev])
            aff = affinity(tails, features[cur])
            iou = iou_matrix(detections.boxes[prev], detections.boxes[cur])
            allowed = (aff >= config.min_affinity) & (iou >= config.min_iou)
            prev_persons = persons[prev]
            for c, j in enumerate(cur):
                if persons[j] < 0:
                    continue
                rows = np.flatnonzero(allowed[:, c])
                right = prev_persons[rows] == persons[j]
                if len(rows) < 2 or right.sum() != 1:
                    continue
                counts["choices"] += 1
                for name, judge in JUDGES.items():
                    counts[name] += int(right[np.argmax(judge(aff[rows, c], iou[rows, c]))])
        for j in cur:
            if persons[j] >= 0:
                seen.setdefault(int(persons[j]), []).append(int(j))
    return counts


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--config", type=Path, help="tracker configuration file (default: the defaults)")
    parser.add_argument("--peer", type=Path, help="a peer's results folder (<sequence>.txt), on the same boxes")
    parser.add_argument("--cache", type=Path, default=Path(".cache/validation/features"),
                        help="re-ID features kept between runs (default: %(default)s)")
    parser.add_argument("--sequences", default="",
                        help="comma-separated names under --data, whatever their length (default: every full-length "
                             "sequence), e.g. the 30-frame clips the validation set makes under "
                             ".cache/validation/clips")
    parser.add_argument("--choices", action="store_true",
                        help="also count the tracklets' choices with a known answer and how often appearance, the "
                             "IoU and the two added pick right (see above)")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="track the person detector's boxes (private detections) instead of det/det.txt; --peer "
                             "then names a peer's results on those boxes (bench_peers.py --detector-model)")
    parser.add_argument("--det-cache", type=Path, default=Path(".cache/detections"),
                        help="where the detector's boxes are kept between runs (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write the report here")
    args = parser.parse_args(argv)
    if args.detector_model and not Path(args.detector_model).is_file():
        parser.error(f"--detector-model: no such file: {args.detector_model}")

    config = (load_config(args.config) if args.config else TrackerConfig()).replace("appearance", model=args.model)
    seqs = named_sequences(parser, args.data, args.sequences) if args.sequences else \
        [p for p in sequences(args.data) if read_seqinfo(p).length > FULL_LENGTH]
    if not seqs:
        parser.error(f"no such sequences with frames under {args.data}: {args.sequences or 'none full-length'}")
    if args.peer is not None:  # a peer that is not there must not become a column of blanks
        wanted = (args.peer / f"{read_seqinfo(seq).name}.txt" for seq in seqs)
        missing = [str(path) for path in wanted if not path.is_file()]
        if missing:
            parser.error(f"--peer: no results file {', '.join(missing)} (bench_peers.py writes "
                         f"<out>/results/<tracker>/<sequence>.txt)")
    SOLVERS["ground-truth"] = f"{__name__}:ground_truth_solve"  # after the checks: a refused run changes nothing
    report: dict[str, dict] = {}
    embedder: list = []
    with tempfile.TemporaryDirectory() as tmp:
        for seq in seqs:
            seq_config = (private_config(config, seq, str(Path(args.detector_model).resolve()), args.det_cache)
                          if args.detector_model else config)
            ceiling_config = seq_config.replace("association", solver="ground-truth")
            prepared = prepare_sequence(seq, seq_config,
                                        features=cached_features(seq, seq_config, args.cache, embedder))
            result = finish_sequence(prepared, seq_config)
            info = result.info
            path = results_path(Path(tmp), info.name)
            write_results(path, result.tracks)
            errors = frame_errors(path, info.gt_path, info.length, info.name)
            row = {"sotmot": counts(errors), "sotmot_by_stage": {k: dict(v) for k, v in
                                                                explain(result, errors, seq_config).items()},
                   "sotmot_scores": scores(path, info)}
            persons = tracklet_identities(prepared.tracklets, info, Path(tmp) / "persons" / info.name,
                                          prepared.motion)
            _PERSON.clear()
            _PERSON.update({t.id: int(p) for t, p in zip(prepared.tracklets, persons)})
            ceiling = results_path(Path(tmp) / "ceiling", info.name)
            write_results(ceiling, finish_sequence(prepared, ceiling_config).tracks)
            row["ceiling_scores"] = scores(ceiling, info)
            peer_file = args.peer / f"{info.name}.txt" if args.peer else None
            if peer_file is not None:
                row["peer"] = counts(frame_errors(peer_file, info.gt_path, info.length, info.name))
                row["peer_scores"] = scores(peer_file, info)
            if args.choices:
                row["choices"] = choices(prepared.in_ref, prepared.features,
                                         detection_persons(prepared, Path(tmp) / "detections" / info.name),
                                         seq_config.tracklets)
            report[info.name] = row
            print(f"{info.name}: done", file=sys.stderr)
    peer = args.peer.name.replace("_", " ") if args.peer else None
    lines = [f"{'sequence':<16}{'sotmot frag':>12}{'switch':>8}" + (f"{'peer frag':>11}{'switch':>8}" if peer else "")
             + "   sotmot's changes of id (fragmentations / switches) by stage"]
    for name, row in report.items():
        p = row.get("peer")
        stages = "; ".join(f"{k} {v}" for k, v in sorted(row["sotmot_by_stage"]["fragmentations"].items())) + " / " \
            + "; ".join(f"{k} {v}" for k, v in sorted(row["sotmot_by_stage"]["switches"].items()))
        lines.append(f"{name:<16}{row['sotmot']['fragmentations']:>12}{row['sotmot']['switches']:>8}"
                     + (f"{p['fragmentations']:>11}{p['switches']:>8}" if p else f"{'-':>11}{'-':>8}" if peer else "")
                     + "   " + stages)
    lines += ["", f"{'sequence':<16}" + "".join(f"{w + ' ' + k:>16}" for w in ("sotmot", "ceiling", "peer")
                                              for k in SCORES)]
    for name, row in report.items():
        lines.append(f"{name:<16}" + "".join(f"{row.get(w + '_scores', {}).get(k, float('nan')):>16.2f}"
                                             for w in ("sotmot", "ceiling", "peer") for k in SCORES))
    if args.choices:
        lines += ["", "the tracklets' choices with a known answer (each candidate's tail its own person's): "
                  "right by each judge", f"{'sequence':<16}{'choices':>9}" + "".join(f"{j:>16}" for j in JUDGES)]
        lines += [f"{name:<16}{row['choices']['choices']:>9}" + "".join(f"{row['choices'][j]:>16}" for j in JUDGES)
                  for name, row in report.items()]
    print("\n".join(lines))
    detections = (f"private detections: the boxes of {Path(args.detector_model).name}" if args.detector_model
                  else "public detections")
    print(f"peer: {peer or 'none'}; {detections}; machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "peer": peer, "detections": detections,
                                                 "config": config.to_dict(), "sequences": report}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
