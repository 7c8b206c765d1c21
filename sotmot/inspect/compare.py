"""Compare long-term association solvers on the very same tracklets.

Each sequence is taken once through reading, preprocessing, appearance and
tracklets; then every solver runs on those tracklets, its output is
post-processed, written and scored with TrackEval. A fingerprint of the
tracklets is checked after every solver, so no solver can change anything
before long-term association.
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
from sotmot.config import TrackerConfig
from sotmot.errors import SotmotError
from sotmot.scoring import evaluate_files
from sotmot.association.objective import flow_objective, lifted_objective
from sotmot.io import results_path, write_results
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.types import Tracklet

#: ``lifted_obj``: the lifted objective of the solver's grouping
#: (:func:`sotmot.association.objective.lifted_objective`, higher is
#: better), the one objective every solver is scored on. ``window_gap``: for the lifted solver, the summed gap
#: between CP-SAT's proved bound and its solution over the windows not proven optimal (0: every window optimal;
#: NaN for solvers without a bound; ``null`` in JSON). ``flow_net_cost``: the flow network's own cost (lower is
#: better for that network only; :func:`sotmot.association.objective.flow_objective`). ``tracks``: the identities
#: in the results the solver's run writes (after confirmation), as ``sotmot track`` counts them.
COLUMNS = ("HOTA", "MOTA", "IDF1", "IDSW", "tracks", "lifted_obj", "window_gap", "flow_net_cost", "solver_s")
_FLOAT_COLUMNS = {"lifted_obj": 1, "window_gap": 1, "flow_net_cost": 3, "solver_s": 3}


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
    """Rows of the comparison: ``rows[sequence][solver] -> metric -> value``, plus ``"COMBINED"``."""

    rows: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    tracklets: dict[str, int] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"rows": self.rows, "tracklets": self.tracklets}


def compare(seq_dirs: Sequence[str | Path], solvers: Sequence[str], config: TrackerConfig = TrackerConfig(),
            embedder: Embedder | None = None, progress: bool = False) -> Comparison:
    """Run every solver in ``solvers`` on the same tracklets of each sequence and score them."""
    for name in solvers:
        get_solver(name)
    embedder = embedder_for(config.appearance, embedder)
    result = Comparison()
    pairs: dict[str, list[tuple[Path, Path, int, str]]] = {m: [] for m in solvers}
    with tempfile.TemporaryDirectory(prefix="sotmot-compare-") as tmp:
        for seq in seq_dirs:
            prepared = prepare_sequence(seq, config, embedder, progress)
            name = prepared.info.name
            before = fingerprint(prepared.tracklets)
            result.tracklets[name] = len(prepared.tracklets)
            result.rows[name] = {}
            gaps = config.association.at(prepared.info.frame_rate)  # the constraints as the solvers saw them
            for solver in solvers:
                start = time.perf_counter()
                run = finish_sequence(prepared, config.replace("association", solver=solver), embedder)
                seconds = run.timings["association"]
                if fingerprint(prepared.tracklets) != before:
                    raise SotmotError(f"solver {solver!r} changed the tracklets of {name}")
                path = results_path(Path(tmp) / solver, name)
                write_results(path, run.tracks)
                pairs[solver].append((path, prepared.info.gt_path, prepared.info.length, name))
                result.rows[name][solver] = {
                    "tracks": float(run.tracks.n_tracks),  # the ids of the results file, as `track` writes it
                    "lifted_obj": lifted_objective(prepared.tracklets, run.association.groups, gaps),
                    "window_gap": run.association.stats.get("bound_gap", float("nan")),
                    "flow_net_cost": flow_objective(prepared.tracklets, run.association.groups, gaps),
                    "solver_s": seconds, "total_s": time.perf_counter() - start,
                }
        result.rows["COMBINED"] = {m: {} for m in solvers}
        for solver in solvers:
            report = evaluate_files(pairs[solver])
            for name, scores in report.sequences.items():
                result.rows[name][solver].update(scores)
            combined = result.rows["COMBINED"][solver]
            combined.update(report.combined)
            for key in ("tracks", "lifted_obj", "window_gap", "flow_net_cost", "solver_s"):
                combined[key] = float(sum(result.rows[n][solver][key] for n in result.tracklets))
    return result


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
        lines.append("")
    return "\n".join(lines)
