"""Scoring with TrackEval (HOTA, CLEAR MOT, Identity); no metric is computed here.

Sequences whose ``gt.txt`` has the MOT16 layout (9 columns with class and
visibility) are scored with TrackEval's MOT16 rules: boxes matched to
distractor classes are removed before scoring and only considered pedestrians
count. 2DMOT2015-layout files are scored with TrackEval's MOT15 rules: no
classes; a ground-truth row whose 7th column is 0 ("not to be considered") is
left out, and an output box on that person counts as a false positive (nothing
is removed from the output; PETS09-S2L1 marks its far walkers so). Scores
over several sequences are combined by TrackEval's own ``combine_sequences``.

TrackEval 1.3.0 is installed without its declared dependencies (it asks for
``opencv-python``, a second copy of ``cv2`` beside ``opencv-python-headless``,
and for matplotlib and pycocotools, which MOTChallenge scoring does not use).
"""

from __future__ import annotations

import contextlib
import io
import logging
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sotmot.errors import EvaluationError, InputError
from sotmot.io import gt_style, is_plain_name, read_ground_truth, read_results, read_seqinfo, results_path
from sotmot.io.mot import mot_rows

log = logging.getLogger(__name__)
#: Names that an annotation tool's first label may give the people (``gt/labels.txt``, CVAT's MOT export).
PEOPLE_LABELS = ("person", "pedestrian", "people", "human", "persons", "pedestrians")

#: Reported metrics: name -> (TrackEval metric family, field, is a fraction to show as %).
METRICS: dict[str, tuple[str, str, bool]] = {
    "HOTA": ("HOTA", "HOTA", True),
    "DetA": ("HOTA", "DetA", True),
    "AssA": ("HOTA", "AssA", True),
    "LocA": ("HOTA", "LocA", True),
    "MOTA": ("CLEAR", "MOTA", True),
    "MOTP": ("CLEAR", "MOTP", True),
    "IDF1": ("Identity", "IDF1", True),
    "IDP": ("Identity", "IDP", True),
    "IDR": ("Identity", "IDR", True),
    "IDSW": ("CLEAR", "IDSW", False),
    "FP": ("CLEAR", "CLR_FP", False),
    "FN": ("CLEAR", "CLR_FN", False),
    "Frag": ("CLEAR", "Frag", False),
    "MT": ("CLEAR", "MT", False),
    "ML": ("CLEAR", "ML", False),
    "GT_IDs": ("Count", "GT_IDs", False),
    "IDs": ("Count", "IDs", False),
}

INSTALL_HINT = ("TrackEval is not installed; install it with 'pip install --no-deps trackeval==1.3.0' "
                "(--no-deps: its metadata pulls opencv-python, a second cv2; scripts/bootstrap.sh does this)")


def _trackeval() -> Any:
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # it prints a warning about BURST's optional deps
            import trackeval
    except ImportError as exc:
        raise EvaluationError(INSTALL_HINT) from exc
    return trackeval


@dataclass
class EvalReport:
    """Scores per sequence and combined.

    Attributes
    ----------
    sequences
        Sequence name -> metric name -> value (fractions as percentages).
    combined
        Metric name -> value over all sequences (TrackEval's combination).
    benchmark
        Sequence name -> TrackEval rules used ("MOT16" or "MOT15").
    """

    sequences: dict[str, dict[str, float]] = field(default_factory=dict)
    combined: dict[str, float] = field(default_factory=dict)
    benchmark: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"sequences": self.sequences, "combined": self.combined, "benchmark": self.benchmark}


def _summarise(raw: dict[str, dict[str, Any]]) -> dict[str, float]:
    out = {}
    for name, (family, key, fraction) in METRICS.items():
        value = raw[family][key]
        value = float(np.mean(value)) if np.ndim(value) else float(value)
        out[name] = 100.0 * value if fraction else value
    return out


def _metric_objects(te: Any) -> list[Any]:
    """HOTA, CLEAR and Identity at the standard IoU threshold 0.5 (Evaluator adds Count itself)."""
    return [te.metrics.HOTA({"PRINT_CONFIG": False}),
            te.metrics.CLEAR({"THRESHOLD": 0.5, "PRINT_CONFIG": False}),
            te.metrics.Identity({"THRESHOLD": 0.5, "PRINT_CONFIG": False})]


def _write_rows(rows: np.ndarray, path: Path) -> None:
    """Checked rows (:func:`sotmot.io.mot.mot_rows`) as the plain comma-separated file TrackEval reads: no blank
    line, no byte-order mark, one layout; frame and id as integers, every other value exactly as read."""
    text = "".join(",".join([str(int(row[0])), str(int(row[1])), *map(repr, row[2:])]) + "\n"
                   for row in rows.tolist())
    path.write_text(text, encoding="utf-8")


def _trackeval_layout(root: Path, members: Sequence[tuple[Path, Path, int, str]], benchmark: str) -> dict:
    """Copy results and ground truth into the folder layout TrackEval reads; return its dataset config.

    ``members`` are ``(results_txt, gt_txt, seq_length, seq_name)``; the
    tracker is called ``sotmot``.
    """
    for results, gt, length, name in members:
        (root / "gt" / name / "gt").mkdir(parents=True)
        _write_rows(mot_rows(gt, "gt", length), root / "gt" / name / "gt" / "gt.txt")
        (root / "trackers" / "sotmot" / "data").mkdir(parents=True, exist_ok=True)
        _write_rows(mot_rows(results, "results", length), root / "trackers" / "sotmot" / "data" / f"{name}.txt")
    return {
        "GT_FOLDER": str(root / "gt"), "TRACKERS_FOLDER": str(root / "trackers"),
        "OUTPUT_FOLDER": str(root / "out"), "TRACKERS_TO_EVAL": ["sotmot"],
        "CLASSES_TO_EVAL": ["pedestrian"], "BENCHMARK": benchmark, "SPLIT_TO_EVAL": "train",
        "DO_PREPROC": True, "TRACKER_SUB_FOLDER": "data", "SKIP_SPLIT_FOL": True,
        "SEQ_INFO": {name: length for _, _, length, name in members},
        "GT_LOC_FORMAT": "{gt_folder}/{seq}/gt/gt.txt", "PRINT_CONFIG": False,
    }


def evaluate_files(pairs: Sequence[tuple[str | Path, str | Path, int, str]]) -> EvalReport:
    """Score results files against ground truth files.

    Parameters
    ----------
    pairs
        ``(results_txt, gt_txt, seq_length, seq_name)`` per sequence. Sequence
        names must be unique.

    Raises
    ------
    InputError
        A results or ground-truth file is malformed (file and line named).
    EvaluationError
        TrackEval is missing or failed.
    """
    te = _trackeval()
    names = [p[3] for p in pairs]
    if len(set(names)) != len(names):
        raise EvaluationError(f"sequence names must be unique, got {names}")
    bad = [n for n in names if not is_plain_name(n)]
    if bad:
        raise EvaluationError(f"sequence names must be plain file names (no path separators), got {bad}")
    report = EvalReport()
    per_seq_raw: dict[str, dict[str, Any]] = {}
    groups: dict[str, list[tuple[Path, Path, int, str]]] = {}
    for results, gt, length, name in pairs:
        results, gt = Path(results), Path(gt)
        read_results(results, length)  # validates, with file and line in any error
        read_ground_truth(gt, length)
        _check_labels(gt)
        groups.setdefault(gt_style(gt), []).append((results, gt, length, name))
    for benchmark, members in groups.items():
        with tempfile.TemporaryDirectory(prefix="sotmot-eval-") as tmp:
            dataset_config = _trackeval_layout(Path(tmp), members, benchmark)
            eval_config = {
                "USE_PARALLEL": False, "PRINT_RESULTS": False, "PRINT_ONLY_COMBINED": True,
                "PRINT_CONFIG": False, "TIME_PROGRESS": False, "DISPLAY_LESS_PROGRESS": True,
                "OUTPUT_SUMMARY": False, "OUTPUT_EMPTY_CLASSES": False, "OUTPUT_DETAILED": False,
                "PLOT_CURVES": False, "BREAK_ON_ERROR": True, "RETURN_ON_ERROR": False,
                "LOG_ON_ERROR": None,
            }
            with contextlib.redirect_stdout(io.StringIO()) as captured:
                try:
                    evaluator = te.Evaluator(eval_config)
                    dataset = te.datasets.MotChallenge2DBox(dataset_config)
                    results, messages = evaluator.evaluate([dataset], _metric_objects(te))
                except Exception as exc:  # TrackEval raises bare exceptions
                    raise EvaluationError(f"TrackEval failed: {exc}\n{captured.getvalue()[-2000:]}") from exc
            status = messages["MotChallenge2DBox"]["sotmot"]
            if status != "Success":
                raise EvaluationError(f"TrackEval failed: {status}")
            by_seq = results["MotChallenge2DBox"]["sotmot"]
            for _, _, _, name in members:
                per_seq_raw[name] = by_seq[name]["pedestrian"]
                report.sequences[name] = _summarise(by_seq[name]["pedestrian"])
                report.benchmark[name] = benchmark
    if per_seq_raw:
        combined = {}
        for metric in _metric_objects(te) + [te.metrics.Count({"PRINT_CONFIG": False})]:
            combined[metric.get_name()] = metric.combine_sequences(
                {name: raw[metric.get_name()] for name, raw in per_seq_raw.items()})
        report.combined = _summarise(combined)
    return report


def _check_labels(gt: Path) -> None:
    """Warn when a ``labels.txt`` beside ``gt`` (annotation tools such as CVAT number the classes of their MOT
    export by it) names something other than people first: MOTChallenge's scoring counts class 1 as pedestrians."""
    labels = gt.with_name("labels.txt")
    try:
        names = [line.strip() for line in labels.read_text(encoding="utf-8-sig").splitlines() if line.strip()]
    except (OSError, UnicodeDecodeError):
        return
    if names and names[0].lower() not in PEOPLE_LABELS:
        people = [k for k, name in enumerate(names, 1) if name.lower() in PEOPLE_LABELS]
        where = f"the people are class {people[0]}" if people else "no label names people"
        log.warning("%s: class 1 is %r by %s, and %s; MOTChallenge's scoring counts only class 1 as pedestrians "
                    "(2, 7, 8, 12 as distractors): renumber the classes of gt.txt", gt, names[0], labels.name, where)


@dataclass
class FrameErrors:
    """Per-frame CLEAR matching of one sequence, for drawing (1-based frame -> rows).

    Attributes
    ----------
    matched
        Frame -> list of ``(gt_box, tracker_box, tracker_id, is_id_switch)``.
    false_positives
        Frame -> list of ``(tracker_box, tracker_id)``.
    misses
        Frame -> list of ground-truth boxes nobody matched.
    missed_ids
        Frame -> the ground-truth identity of each box in ``misses`` (same
        order; TrackEval's numbering, as in ``identities``).
    identities
        ``(frame, tracker_id)`` -> the ground-truth identity its box is matched
        to (TrackEval's numbering of the sequence's identities, from 0).
    """

    matched: dict[int, list] = field(default_factory=dict)
    false_positives: dict[int, list] = field(default_factory=dict)
    misses: dict[int, list] = field(default_factory=dict)
    missed_ids: dict[int, list[int]] = field(default_factory=dict)
    identities: dict[tuple[int, int], int] = field(default_factory=dict)

    def totals(self) -> dict[str, int]:
        """Counts: TP, FP, FN, IDSW."""
        return {"TP": sum(map(len, self.matched.values())),
                "FP": sum(map(len, self.false_positives.values())),
                "FN": sum(map(len, self.misses.values())),
                "IDSW": sum(m[3] for rows in self.matched.values() for m in rows)}

    def miss_positions(self) -> dict[int, list[tuple[str, int]]]:
        """Where each miss lies in the tracked life of its ground-truth identity (frame -> one entry per box of
        ``misses``, same order), with ``d`` the distance in frames to the nearest frame where it is matched:

        * ``("gap", d)``: between two frames where the identity is matched to one tracker id: inside a
          trajectory (interpolation, or SOT inside the gap, could reach it);
        * ``("link", d)``: between two matched frames of different tracker ids: between two trajectories
          that association did not join;
        * ``("end", d)``: before its first or after its last matched frame (only an extension reaches it);
        * ``("never", -1)``: an identity never matched (it needs a trajectory of its own).
        """
        seen: dict[int, dict[int, int]] = {}
        for (frame, tid), g in self.identities.items():
            seen.setdefault(g, {})[frame] = tid
        matched = {g: np.array(sorted(frames)) for g, frames in seen.items()}
        out: dict[int, list[tuple[str, int]]] = {}
        for frame, ids in self.missed_ids.items():
            rows = []
            for g in ids:
                if g not in seen:
                    rows.append(("never", -1))
                    continue
                frames = matched[g]
                distance = int(np.abs(frames - frame).min())
                if not frames[0] < frame < frames[-1]:
                    rows.append(("end", distance))
                    continue
                before, after = frames[frames < frame][-1], frames[frames > frame][0]
                rows.append(("gap" if seen[g][before] == seen[g][after] else "link", distance))
            out[frame] = rows
        return out


def frame_errors(results: str | Path, gt: str | Path, length: int, name: str) -> FrameErrors:
    """Which boxes are matched, false, missed or switched, frame by frame.

    The boxes come from TrackEval's own preprocessing (its distractor removal
    for MOT16-style ground truth, its IoU similarities); the per-frame matching
    follows the CLEAR MOT rule as TrackEval states it: Hungarian assignment on
    IoU >= 0.5, with a large bonus for keeping the previous frame's match; an
    ID switch when a ground-truth object is matched to a different tracker id
    than the last time it was matched. A test checks that the counts equal
    TrackEval's CLEAR FP, FN and IDSW.
    """
    from scipy.optimize import linear_sum_assignment

    te = _trackeval()
    style = gt_style(gt)
    out = FrameErrors()
    with tempfile.TemporaryDirectory(prefix="sotmot-match-") as tmp:
        config = _trackeval_layout(Path(tmp), [(Path(results), Path(gt), length, name)], style)
        with contextlib.redirect_stdout(io.StringIO()) as captured:
            try:
                dataset = te.datasets.MotChallenge2DBox(config)
                raw = dataset.get_raw_seq_data("sotmot", name)
                data = dataset.get_preprocessed_seq_data(raw, "pedestrian")
            except Exception as exc:  # TrackEval raises bare exceptions
                raise EvaluationError(f"TrackEval failed on {results} and {gt}: {exc}\n"
                                      f"{captured.getvalue()[-2000:]}") from exc
    last_match: dict[int, int] = {}  # gt id -> tracker id it was last matched to
    previous: dict[int, int] = {}  # gt id -> tracker id matched in the previous frame
    for t in range(data["num_timesteps"]):
        frame = t + 1
        gt_ids, gt_boxes = data["gt_ids"][t], data["gt_dets"][t]
        trk_boxes = data["tracker_dets"][t]
        # TrackEval relabels tracker ids; recover the file's ids (its rows are kept in order)
        raw_boxes, raw_ids = raw["tracker_dets"][t], raw["tracker_ids"][t]
        trk_ids, k = [], 0
        for box in trk_boxes:
            while not np.array_equal(raw_boxes[k], box):
                k += 1
            trk_ids.append(int(raw_ids[k]))
            k += 1
        sim = np.asarray(data["similarity_scores"][t], dtype=np.float64)
        matched_rows: list[tuple[int, int]] = []
        if len(gt_ids) and len(trk_ids):
            score = np.where(sim >= 0.5 - np.finfo(float).eps, sim, 0.0)
            for i, g in enumerate(gt_ids):
                for j, tid in enumerate(trk_ids):
                    if previous.get(int(g)) == tid and score[i, j] > 0:
                        score[i, j] += 1000.0
            rows, cols = linear_sum_assignment(-score)
            matched_rows = [(r, c) for r, c in zip(rows, cols) if sim[r, c] >= 0.5 - np.finfo(float).eps]
        now: dict[int, int] = {}
        for r, c in matched_rows:
            g, tid = int(gt_ids[r]), trk_ids[c]
            switch = g in last_match and last_match[g] != tid
            out.matched.setdefault(frame, []).append((gt_boxes[r], trk_boxes[c], tid, switch))
            out.identities[frame, tid] = g
            last_match[g] = tid
            now[g] = tid
        previous = now
        taken_gt = {r for r, _ in matched_rows}
        taken_trk = {c for _, c in matched_rows}
        missed = [r for r in range(len(gt_ids)) if r not in taken_gt]
        misses = [gt_boxes[r] for r in missed]
        false = [(trk_boxes[c], trk_ids[c]) for c in range(len(trk_ids)) if c not in taken_trk]
        if misses:
            out.misses[frame] = misses
            out.missed_ids[frame] = [int(gt_ids[r]) for r in missed]
        if false:
            out.false_positives[frame] = false
    return out


def evaluate(results_dir: str | Path, seq_dirs: Sequence[str | Path]) -> EvalReport:
    """Score ``results_dir/<name>.txt`` for each MOTChallenge sequence folder in ``seq_dirs``.

    ``<name>`` is the ``name`` in the sequence's ``seqinfo.ini`` (a folder of images without one: the folder's).
    """
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise InputError(results_dir, "results folder not found")
    pairs = []
    for seq in seq_dirs:
        info = read_seqinfo(seq, rate_needed=False)
        results = results_path(results_dir, info.name)
        if not results.is_file():
            raise InputError(results, f"no results for sequence {info.name}; run 'sotmot track {seq} "
                             f"--out {results_dir}' first")
        pairs.append((results, info.gt_path, info.length, info.name))
    return evaluate_files(pairs)


def format_table(report: EvalReport, columns: Sequence[str] = ("HOTA", "DetA", "AssA", "MOTA", "MOTP",
                                                                "IDF1", "IDSW", "FP", "FN")) -> str:
    """A plain-text table: one row per sequence and a COMBINED row."""
    rows = [(name, report.sequences[name]) for name in report.sequences]
    if len(rows) > 1 or not rows:
        rows.append(("COMBINED", report.combined))
    width = max([len(r[0]) for r in rows] + [8])
    head = f"{'sequence':<{width}}  " + "  ".join(f"{c:>7}" for c in columns)
    lines = [head, "-" * len(head)]
    for name, values in rows:
        cells = []
        for c in columns:
            v = values.get(c, float("nan"))
            cells.append(f"{v:7.1f}" if METRICS.get(c, ("", "", True))[2] else f"{v:7.0f}")
        lines.append(f"{name:<{width}}  " + "  ".join(cells))
    return "\n".join(lines)
