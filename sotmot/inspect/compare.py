"""Compare long-term association solvers on the very same tracklets.

Each sequence is taken once through reading, preprocessing, appearance and
tracklets; then every solver runs on those tracklets, its output is
post-processed, written and scored with TrackEval. A fingerprint of the
tracklets is checked after every solver, so no solver can change anything
before long-term association.

With ``jitter = K`` every sequence is also taken, the same way, through ``K``
copies of its detections (its file, or the boxes the built-in detector gave the
first run, written as the ``<name>.det.txt`` that replays it) with every box
moved by a seeded offset of under :data:`~sotmot.benchmarks.JITTER_PIXELS` in x
and y (seeds 1 to K): a change that should change nothing, yet one that flips
thresholds all along the pipeline (a box kept or not by NMS, a tracklet of two
boxes or none, the bridges it allows), so that one run's score moves by up to
about 2 HOTA on a busy sequence. Each solver's scores over the ``1 + K`` runs show that spread,
and each solver is judged against the first one run by run (paired): a
difference that changes sign between runs cannot be told from chance; one sign
in every run is the more telling the more runs there are.
"""

from __future__ import annotations

import hashlib
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sotmot.association import get_solver
from sotmot.appearance import Embedder, embedder_for
from sotmot.benchmarks import JITTER_PIXELS, jittered_detections
from sotmot.config import TrackerConfig
from sotmot.detection import detection_source, detector_file_text
from sotmot.errors import SotmotError
from sotmot.scoring import evaluate_files
from sotmot.association.objective import flow_objective, lifted_objective
from sotmot.io import read_seqinfo, results_path, write_results, write_text_atomic
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.types import Detections, Tracklet

#: ``lifted_obj``: the lifted objective of the solver's grouping
#: (:func:`sotmot.association.objective.lifted_objective`, higher is
#: better), the one objective every solver is scored on. ``window_gap``: for the lifted solver, the summed gap
#: between CP-SAT's proved bound and its solution over the windows not proven optimal (0: every window optimal;
#: NaN for solvers without a bound; ``null`` in JSON). ``flow_net_cost``: the flow network's own cost (lower is
#: better for that network only; :func:`sotmot.association.objective.flow_objective`). ``tracks``: the identities
#: in the results the solver's run writes (after confirmation), as ``sotmot track`` counts them.
COLUMNS = ("HOTA", "MOTA", "IDF1", "IDSW", "tracks", "lifted_obj", "window_gap", "flow_net_cost", "solver_s")
_FLOAT_COLUMNS = {"lifted_obj": 1, "window_gap": 1, "flow_net_cost": 3, "solver_s": 3}
#: The scores followed over the jittered runs (``jitter``).
SPREAD_COLUMNS = ("HOTA", "MOTA", "IDF1")


def fingerprint(tracklets: Sequence[Tracklet]) -> str:
    """A hash of every tracklet's id, frames, boxes, scores, detections and feature."""
    h = hashlib.sha256()
    for t in tracklets:
        h.update(np.int64(t.id).tobytes())
        for arr in (t.frames, t.boxes, t.scores, t.det_index, t.feature):
            h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


@dataclass
class Comparison:
    """Rows of the comparison: ``rows[sequence][solver] -> metric -> value``, plus ``"COMBINED"``.

    With jittered runs (``jitter`` copies of each sequence), ``runs[sequence][solver][metric]`` holds the
    :data:`SPREAD_COLUMNS` of the ``1 + jitter`` runs, the sequence itself first (``rows``' values)."""

    rows: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    tracklets: dict[str, int] = field(default_factory=dict)
    jitter: int = 0
    runs: dict[str, dict[str, dict[str, list[float]]]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        out: dict[str, Any] = {"rows": self.rows, "tracklets": self.tracklets}
        if self.jitter:
            out["jitter"] = {"copies": self.jitter, "pixels": JITTER_PIXELS, "runs": self.runs}
        return out


def jitter_runs(seq: str | Path, config: TrackerConfig, copies: int, root: Path, detected: Detections | None = None
                ) -> list[TrackerConfig]:
    """The configurations of the ``copies`` jittered runs of ``seq`` (the same folder): each reads, as its
    ``[detection] file``, a copy of the run's detections with every box moved by under
    :data:`~sotmot.benchmarks.JITTER_PIXELS` (seeds 1 to ``copies``, written under ``root``, which must be this
    sequence's own). The detections are the file the
    run reads (the folder's ``det/det.txt`` or its ``[detection] file``), or, where the built-in detector gives
    them, the boxes it gave the run on the sequence itself (``detected``, ``Prepared.detected``), written first as
    the ``<name>.det.txt`` a model run writes, which replays that run exactly."""
    if copies == 0:
        return []
    info = read_seqinfo(seq, config.input.fps)
    source, det_file = detection_source(config.detection, info)
    if source != "file":
        if detected is None:
            raise ValueError(f"{seq}: the detector's boxes of the run on the sequence itself are needed")
        det_file = root / f"{info.name}.det.txt"
        write_text_atomic(det_file, detector_file_text(detected, config.detection))
    return [config.replace("detection", source="file", file=str(jittered_detections(Path(det_file), seed, root)))
            for seed in range(1, copies + 1)]


def compare(seq_dirs: Sequence[str | Path], solvers: Sequence[str], config: TrackerConfig = TrackerConfig(),
            embedder: Embedder | None = None, progress: bool = False, jitter: int = 0) -> Comparison:
    """Run every solver in ``solvers`` on the same tracklets of each sequence and score them; with ``jitter``,
    also on that many copies of each sequence whose boxes moved by under half a pixel (module docstring)."""
    for name in solvers:
        get_solver(name)
    if jitter < 0:
        raise ValueError(f"jitter must be 0 or more copies, got {jitter}")
    embedder = embedder_for(config.appearance, embedder)
    result = Comparison(jitter=jitter)
    # pairs[run][solver]: the (results, ground truth, length, name) rows TrackEval scores, run 0 the sequences
    pairs: list[dict[str, list[tuple[Path, Path, int, str]]]] = [{m: [] for m in solvers} for _ in range(jitter + 1)]
    with tempfile.TemporaryDirectory(prefix="sotmot-compare-") as tmp:
        for k, seq in enumerate(seq_dirs):
            detected = _compare_sequence(Path(seq), config, solvers, embedder, progress, Path(tmp) / "run0", pairs[0],
                                         result)
            copies = jitter_runs(seq, config, jitter, Path(tmp) / "jitter" / str(k), detected)
            for run, run_config in enumerate(copies, 1):
                _compare_sequence(Path(seq), run_config, solvers, embedder, progress, Path(tmp) / f"run{run}",
                                  pairs[run], None)
        result.rows["COMBINED"] = {m: {} for m in solvers}
        for run, by_solver in enumerate(pairs):
            for solver in solvers:
                report = evaluate_files(by_solver[solver])
                for name, scores in [*report.sequences.items(), ("COMBINED", report.combined)]:
                    if run == 0:
                        result.rows[name][solver].update(scores)
                    if jitter:
                        spread = result.runs.setdefault(name, {}).setdefault(solver, {})
                        for column in SPREAD_COLUMNS:
                            spread.setdefault(column, []).append(float(scores[column]))
        for solver in solvers:
            combined = result.rows["COMBINED"][solver]
            for key in ("tracks", "lifted_obj", "window_gap", "flow_net_cost", "solver_s"):
                combined[key] = float(sum(result.rows[n][solver][key] for n in result.tracklets))
    return result


def _compare_sequence(seq: Path, config: TrackerConfig, solvers: Sequence[str], embedder: Embedder,
                      progress: bool, out: Path, pairs: dict[str, list[tuple[Path, Path, int, str]]],
                      result: Comparison | None) -> Detections | None:
    """Every solver on the same tracklets of ``seq``: results written under ``out`` and listed in ``pairs``; with
    ``result`` (the sequence itself, not a jittered copy) its rows filled too. Returns the boxes the built-in
    detector gave (None where they came from a file)."""
    prepared = prepare_sequence(seq, config, embedder, progress)
    name = prepared.info.name
    before = fingerprint(prepared.tracklets)
    if result is not None:
        result.tracklets[name] = len(prepared.tracklets)
        result.rows[name] = {}
    gaps = config.association.at(prepared.info.frame_rate)  # the constraints as the solvers saw them
    for solver in solvers:
        start = time.perf_counter()
        run = finish_sequence(prepared, config.replace("association", solver=solver), embedder)
        seconds = run.timings["association"]
        if fingerprint(prepared.tracklets) != before:
            raise SotmotError(f"solver {solver!r} changed the tracklets of {name}")
        path = results_path(out / solver, name)
        write_results(path, run.tracks)
        pairs[solver].append((path, prepared.info.gt_path, prepared.info.length, name))
        if result is not None:
            result.rows[name][solver] = {
                "tracks": float(run.tracks.n_tracks),  # the ids of the results file, as `track` writes it
                "lifted_obj": lifted_objective(prepared.tracklets, run.association.groups, gaps),
                "window_gap": run.association.stats.get("bound_gap", float("nan")),
                "flow_net_cost": flow_objective(prepared.tracklets, run.association.groups, gaps),
                "solver_s": seconds, "total_s": time.perf_counter() - start,
            }
    return prepared.detected


def _width(column: str) -> int:
    return max(13, len(column) + 2)


def format_comparison(comparison: Comparison) -> str:
    """One block per sequence and a COMBINED block: a row per solver."""
    lines = []
    solver_width = max([9, *(len(s) for by_solver in comparison.rows.values() for s in by_solver)])
    for name, by_solver in comparison.rows.items():
        extra = f" ({comparison.tracklets[name]} tracklets)" if name in comparison.tracklets else ""
        lines.append(f"{name}{extra}")
        head = f"  {'solver':<{solver_width}}" + "".join(f"{c:>{_width(c)}}" for c in COLUMNS)
        lines.append(head)
        for solver, values in by_solver.items():
            cells = []
            for c in COLUMNS:
                v = values.get(c, float("nan"))
                digits = 1 if c in ("HOTA", "MOTA", "IDF1") else _FLOAT_COLUMNS.get(c, 0)
                cells.append(f"{v:{_width(c)}.{digits}f}")
            lines.append(f"  {solver:<{solver_width}}" + "".join(cells))
        if name in comparison.runs:
            lines.extend(_spread_lines(comparison.runs[name], comparison.jitter, solver_width))
        lines.append("")
    return "\n".join(lines)


def paired_verdict(differences: Sequence[float]) -> str:
    """What run-by-run differences of one score between two solvers say: the same sign in every run, or not."""
    if all(d > 0 for d in differences):
        return "above in every run"
    if all(d < 0 for d in differences):
        return "below in every run"
    if all(d == 0 for d in differences):
        return "equal in every run"
    return "not told apart from chance"


def paired_rows(tables: Sequence[dict], reference: str, metric: str) -> dict[str, dict[str, dict]]:
    """Each tracker's ``metric`` over runs, and ``reference``'s lead over it run by run: ``tracker -> row ->
    {"runs": [value per table], "lead": [reference minus it per table], "verdict": paired_verdict(lead)}``
    (no lead for the reference itself), from score tables ``table[tracker][row][metric]`` of the same trackers
    and rows (sequences, groups), the run on the boxes themselves first."""
    rows: dict[str, dict[str, dict]] = {}
    for tracker, by_row in tables[0].items():
        rows[tracker] = {}
        for name in by_row:
            row: dict = {"runs": [t[tracker][name][metric] for t in tables]}
            if tracker != reference:
                lead = [t[reference][name][metric] - t[tracker][name][metric] for t in tables]
                row.update(lead=lead, verdict=paired_verdict(lead))
            rows[tracker][name] = row
    return rows


def _spread_lines(runs: dict[str, dict[str, list[float]]], jitter: int, solver_width: int) -> list[str]:
    """Each solver's lowest and highest score over the runs, then each solver against the first, run by run."""
    lines = [f"  over {1 + jitter} runs (in {jitter} of them every box moved by under {JITTER_PIXELS:g} px): "
             f"lowest - highest"]
    for solver, scores in runs.items():
        lines.append(f"  {solver:<{solver_width}}" + "".join(
            f"  {c} {min(scores[c]):5.1f} - {max(scores[c]):5.1f}" for c in SPREAD_COLUMNS))
    first, *others = runs
    for solver in others:
        for c in SPREAD_COLUMNS:
            d = [a - b for a, b in zip(runs[solver][c], runs[first][c])]
            lines.append(f"  {solver} - {first}, {c}: {d[0]:+.2f} (runs {min(d):+.2f} to {max(d):+.2f}: "
                         f"{paired_verdict(d)})")
    return lines
