"""Tracking many sequences: one after another, or in parallel worker processes on this machine.

Each sequence is one job that reads its own frames (nothing but paths and
the configuration crosses process boundaries), writes ``<name>.flags.csv``
then ``<name>.txt`` atomically, and reports success or its error. A failing
sequence never loses the others' results; with ``resume`` a sequence whose
results file exists is skipped (results are written atomically and last, so
an existing file is a complete one).
"""

from __future__ import annotations

import os
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

from sotmot.config import TrackerConfig
from sotmot.errors import SotmotError

_EMBEDDER = None  # one appearance model per worker process


@dataclass(frozen=True)
class Outcome:
    """What happened to one sequence.

    Attributes
    ----------
    seq_dir
        The sequence folder.
    status
        ``"done"``, ``"skipped"`` (results existed, ``resume``) or ``"failed"``.
    results
        The results file (None if it failed before knowing the name).
    message
        One line: tracks and speed, or the error.
    """

    seq_dir: str
    status: str
    results: str | None
    message: str


def _init_worker(config: TrackerConfig) -> None:
    global _EMBEDDER
    from sotmot.appearance import make_embedder

    _EMBEDDER = make_embedder(config.appearance)


def track_one(seq_dir: str, out_dir: str, config: TrackerConfig, merger: str, resume: bool,
              progress: bool = False, embedder=None) -> Outcome:
    """Track one sequence into ``out_dir``; never raises (errors become a ``failed`` outcome)."""
    from sotmot.io import read_seqinfo, results_path, write_results
    from sotmot.pipeline import track_sequence
    from sotmot.render import write_flags

    try:
        info = read_seqinfo(seq_dir)
        out = results_path(out_dir, info.name)
        if resume and out.is_file():
            return Outcome(seq_dir, "skipped", str(out), f"{info.name}: results exist, skipped (--resume)")
        start = time.perf_counter()
        result = track_sequence(seq_dir, config, merger=merger, embedder=embedder or _EMBEDDER, progress=progress)
        write_flags(out, result.tracks)
        write_results(out, result.tracks)
        fps = info.length / (time.perf_counter() - start)
        return Outcome(seq_dir, "done", str(out), f"{info.name}: {result.tracks.n_tracks} tracks, "
                                                  f"{len(result.tracks)} boxes, {fps:.1f} frames/s -> {out}")
    except SotmotError as exc:
        return Outcome(seq_dir, "failed", None, f"{seq_dir}: {exc}")
    except Exception as exc:  # a bug must not lose the other sequences' results either
        detail = traceback.format_exc(limit=3).strip().splitlines()[-1]
        return Outcome(seq_dir, "failed", None, f"{seq_dir}: unexpected {type(exc).__name__}: {detail}")


def track_many(seq_dirs: list[str | Path], out_dir: str | Path, config: TrackerConfig, merger: str = "greedy",
               workers: int = 1, resume: bool = False, progress: bool = False, report=None) -> list[Outcome]:
    """Track every sequence; ``workers > 1`` runs them in that many processes.

    With several workers each gets ``cpu_count // workers`` onnxruntime
    threads (unless the config sets them), so the machine is not
    oversubscribed. ``report`` is called with each :class:`Outcome` as it
    arrives. Outcomes come back in the order of ``seq_dirs``.
    """
    seq_dirs = [str(s) for s in seq_dirs]
    out_dir = str(out_dir)
    report = report or (lambda outcome: None)
    if workers <= 1 or len(seq_dirs) <= 1:
        from sotmot.appearance import make_embedder

        embedder = None
        outcomes = []
        for seq in seq_dirs:
            if embedder is None and not (resume and _has_results(seq, out_dir)):
                embedder = make_embedder(config.appearance)  # a bad model path stops everything, once
            outcome = track_one(seq, out_dir, config, merger, resume, progress, embedder)
            report(outcome)
            outcomes.append(outcome)
        return outcomes
    if config.appearance.threads == 0:
        config = config.replace("appearance", threads=max(1, (os.cpu_count() or 1) // workers))
    _init_worker(config)  # fail here, once, on a bad model path rather than in every worker
    by_seq: dict[str, Outcome] = {}
    with ProcessPoolExecutor(max_workers=workers, initializer=_init_worker, initargs=(config,)) as pool:
        futures = {pool.submit(track_one, seq, out_dir, config, merger, resume): seq for seq in seq_dirs}
        done = as_completed(futures)
        if progress:
            from tqdm import tqdm

            done = tqdm(done, total=len(futures), desc="sequences", unit="seq", dynamic_ncols=True)
        for future in done:
            outcome = future.result()
            by_seq[futures[future]] = outcome
            report(outcome)
    return [by_seq[s] for s in seq_dirs]


def _has_results(seq_dir: str, out_dir: str) -> bool:
    from sotmot.io import read_seqinfo, results_path

    try:
        return results_path(out_dir, read_seqinfo(seq_dir).name).is_file()
    except SotmotError:
        return False
