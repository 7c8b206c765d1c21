"""Scoring with TrackEval (HOTA, CLEAR MOT, Identity); no metric is computed here.

Sequences whose ``gt.txt`` has the MOT16 layout (9 columns with class and
visibility) are scored with TrackEval's MOT16 rules: boxes matched to
distractor classes are removed before scoring and only considered pedestrians
count. 2DMOT2015-layout files are scored with the plain MOT15 rules. Scores
over several sequences are combined by TrackEval's own ``combine_sequences``.

TrackEval 1.3.0 is installed without its declared dependencies (it asks for
``opencv-python``, a second copy of ``cv2`` beside ``opencv-python-headless``,
and for matplotlib and pycocotools, which MOTChallenge scoring does not use).
"""

from __future__ import annotations

import contextlib
import io
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sotmot.errors import EvaluationError, InputError
from sotmot.io import gt_style, read_ground_truth, read_results, read_seqinfo

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
    report = EvalReport()
    per_seq_raw: dict[str, dict[str, Any]] = {}
    groups: dict[str, list[tuple[Path, Path, int, str]]] = {}
    for results, gt, length, name in pairs:
        results, gt = Path(results), Path(gt)
        read_results(results, length)  # validates, with file and line in any error
        read_ground_truth(gt, length)
        groups.setdefault(gt_style(gt), []).append((results, gt, length, name))
    for benchmark, members in groups.items():
        with tempfile.TemporaryDirectory(prefix="sotmot-eval-") as tmp:
            root = Path(tmp)
            for results, gt, _, name in members:
                (root / "gt" / name / "gt").mkdir(parents=True)
                shutil.copyfile(gt, root / "gt" / name / "gt" / "gt.txt")
                (root / "trackers" / "sotmot" / "data").mkdir(parents=True, exist_ok=True)
                shutil.copyfile(results, root / "trackers" / "sotmot" / "data" / f"{name}.txt")
            dataset_config = {
                "GT_FOLDER": str(root / "gt"), "TRACKERS_FOLDER": str(root / "trackers"),
                "OUTPUT_FOLDER": str(root / "out"), "TRACKERS_TO_EVAL": ["sotmot"],
                "CLASSES_TO_EVAL": ["pedestrian"], "BENCHMARK": benchmark, "SPLIT_TO_EVAL": "train",
                "DO_PREPROC": True, "TRACKER_SUB_FOLDER": "data", "SKIP_SPLIT_FOL": True,
                "SEQ_INFO": {name: length for _, _, length, name in members},
                "GT_LOC_FORMAT": "{gt_folder}/{seq}/gt/gt.txt", "PRINT_CONFIG": False,
            }
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


def evaluate(results_dir: str | Path, seq_dirs: Sequence[str | Path]) -> EvalReport:
    """Score ``results_dir/<name>.txt`` for each MOTChallenge sequence folder in ``seq_dirs``.

    ``<name>`` is the ``name`` in the sequence's ``seqinfo.ini``.
    """
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise InputError(results_dir, "results folder not found")
    pairs = []
    for seq in seq_dirs:
        info = read_seqinfo(seq)
        results = results_dir / f"{info.name}.txt"
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
