#!/usr/bin/env python3
"""The validation set: every candidate default judged by its worst sequence, not its mean (issue #39).

The set, built from what ``../shared/data`` holds:

* **frames**: the full-length sequences with frames (public detections, re-ID),
  and each 25-30 fps one at every 2nd and 3rd frame (``seqinfo.ini`` adjusted:
  the same people at 8-15 fps; made once under ``--cache``);
* **clips**: the 30-frame clips with frames (the MOT16 clips' DPM boxes) and,
  on the frames of the same videos, the MOT17 label sets' boxes (DPM, Faster
  R-CNN, SDP; :func:`~sotmot.benchmarks.detector_clips`, made once under
  ``--cache``): tracked as the full-length ones, the only moving cameras with
  pixels (camera motion estimated and compensated) and the only stronger
  detectors on them; one or two seconds each, so tracklets, compensation and
  confirmation, not long-term association;
* **labels**: the label-only sequences (``MOT16-labels``: DPM; ``MOT17-labels``:
  DPM, Faster R-CNN, SDP), 14 sequences with detections and ground truth but no
  frames, crowded and sparse, still and moving cameras, tracked in the
  motion-only mode (``[appearance] backend = "none"``, camera motion not
  estimated): what a default does to FP and FN where no frames exist;
* **label-rates**: each 25-30 fps label-only sequence at every 2nd frame (10
  sequences at 12.5-15 fps, made once under ``--cache``), tracked alike.

Each configuration (``--config NAME=FILE``, TOML or JSON; the first is the
reference, by default today's defaults) tracks every sequence; configurations
that agree on the sections a preparation reads (detections, features,
tracklets: :func:`~sotmot.benchmarks.preparation_key`) share one preparation. Printed: HOTA / MOTA
/ IDF1 / FP / FN per sequence and configuration, the change against the
reference, the **worst sequence** of each change (the selection rule: a new
default loses at most 0.5 HOTA and 0.5 MOTA on any sequence), and combined rows
per group.

With ``--noise`` the reference is tracked again under changes that should change
nothing (:data:`NOISE`): re-ID in the other runtime (OpenVINO, bf16 on CPUs that
have it, against onnxruntime in float32; the sequences with frames) and every
detection box moved by a seeded offset of under half a pixel (two seeds; every
sequence). Each sequence's **noise floor** is the largest change they make to
its HOTA, MOTA and IDF1; a candidate's loss on a sequence is then reported
beside it, and counted against the rule only where it is larger than both 0.5
and the floor (one run of one configuration cannot tell a smaller loss from
chance).

With ``--seeds K`` every configuration also tracks K copies of each sequence whose
boxes moved as ``--noise`` moves them (seeds 1 to K): its row of a sequence is the
mean over the K + 1 runs, and a loss counts against the rule only where it is
larger than 0.5 in every run, the copies paired with the reference's (a report of
its own: not merged, no noise floor needed).

With ``--peers`` (names of the ``trackers`` package's SORT, ByteTrack,
OC-SORT), each also tracks the label-only sequences from the same cleaned
detections, as it comes and given sotmot's memory (``+GSI 4s``: a lost track
kept ``[association] l_max_seconds`` and boxmot's GSI filling gaps as long):
motion-only peers beside sotmot's motion-only mode, scored the same way.

With ``--detector-model`` the sequences with frames (``frames``, ``rates`` and
``clips``, the default groups then; of the clips, those of the data folder) are
tracked from the person detector's boxes instead of their ``det/det.txt``
(MOTChallenge's private detections: what ``sotmot track`` does with a video),
each detected once and kept under ``--det-cache``, as
``scripts/bench_accuracy.py`` and ``scripts/fp_analysis.py`` take them; a
report of its own (``--merge`` refuses to mix the two protocols), without
``--seeds`` or ``--peers``; ``--noise`` moves the detector's boxes. MOT16-09
and the MOT17-09 sets are one video: the same boxes, scored against each ground
truth.

    python scripts/bench_validation.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --config defaults= --config paper-gap=gap60.toml --json docs/results/validation.json
    python scripts/bench_validation.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --detector-model ../shared/models/person-detection-0202/person-detection-0202.FP16-INT8.xml \\
        --config defaults= --config paper-gap=gap60.toml --json docs/results/validation_private.json
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA, add_more_argument, more_found, named_config, read_report, validation_groups
from sotmot.appearance import resolve_backend
from sotmot.benchmarks import (GROUPS, JITTER_PIXELS, LABEL_GROUPS, for_group, group_features, jittered_detections,
                               jittered_sequence, preparation_key, private_config, validation_set)
from sotmot.config import TrackerConfig
from sotmot.scoring import evaluate_files
from sotmot.io import results_path, write_results, write_text_atomic
from sotmot.peers import TRACKERS_PACKAGE, TRACKERS_ROWS, SeqInput, peer_scores, run_peer
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.types import Tracks
from sotmot.versions import machine

COLUMNS = ("HOTA", "MOTA", "IDF1", "IDSW", "FP", "FN")
#: The changes ``--noise`` makes to the reference: ``runtime`` (re-ID in the other runtime; sequences with
#: frames) and ``jitter<seed>`` (every detection box moved by under :data:`JITTER_PIXELS` in x and y).
NOISE = ("runtime", "jitter1", "jitter2")
#: The other re-ID runtime of each: the same network, other arithmetic.
OTHER_RUNTIME = {"openvino": "onnx", "onnx": "openvino"}
#: The selection rule: a new default loses at most this much HOTA and MOTA on any sequence.
RULE = 0.5


def jittered_copy(seq: Path, seed: int, cache: Path) -> tuple[Path, Path]:
    """The copy of ``seq`` with its boxes moved by under :data:`JITTER_PIXELS` (seed ``seed``; made once under
    ``cache``) and the feature cache of its own that copy needs (it keeps the sequence's name, which the
    features' cache key holds): ``--noise`` and ``--seeds`` share both."""
    return jittered_sequence(seq, seed, cache, JITTER_PIXELS), cache / f"features-jitter{seed}"


def keep_result(runs: dict[str, list[tuple[Path, Path, int, str]]], label: str, tracks: Tracks, info, root: Path
                ) -> None:
    """Write ``tracks`` of the sequence ``info`` under ``root / label`` and add the file to ``runs[label]``, the
    ``(results, ground truth, length, name)`` rows :func:`~sotmot.scoring.evaluate_files` scores."""
    path = results_path(root / label, info.name)
    write_results(path, tracks)
    runs.setdefault(label, []).append((path, info.gt_path, info.length, info.name))


def noise_runs(seq: Path, group: str, reference: TrackerConfig, model: str, cache: Path,
               detector: str | None = None, det_cache: Path | None = None
               ) -> dict[str, tuple[Path, TrackerConfig, Path]]:
    """The ``--noise`` runs of one validation sequence (:data:`NOISE`): name -> (the folder tracked, its
    configuration, its feature cache). ``runtime`` only where re-ID runs; the jittered folders are made once
    under ``cache`` and keep the sequence's name, their features in a cache of their own. With ``detector``
    (private detections) the detector's boxes of ``seq`` are what moves, a file made once under ``cache``."""
    config = for_group(reference, group, model)
    runs = {}
    other = OTHER_RUNTIME.get(resolve_backend(config.appearance).backend)
    if detector:
        private = private_config(config, seq, detector, det_cache)
        if other:
            runs["runtime"] = (seq, private.replace("appearance", backend=other), cache / "features")
        for run in (r for r in NOISE if r.startswith("jitter")):
            seed = int(run.removeprefix("jitter"))
            moved = jittered_detections(Path(private.detection.file), seed, cache / "private", JITTER_PIXELS)
            runs[run] = (seq, private.replace("detection", file=str(moved)), cache / f"features-jitter{seed}")
        return runs
    if group not in LABEL_GROUPS and other:
        runs["runtime"] = (seq, config.replace("appearance", backend=other), cache / "features")
    for run in (r for r in NOISE if r.startswith("jitter")):
        copy, features = jittered_copy(seq, int(run.removeprefix("jitter")), cache)
        runs[run] = (copy, config, features)
    return runs


def peer_runs(prepared, peers: list[str]) -> dict[str, Tracks]:
    """Each motion-only peer's tracks of a prepared sequence, from its cleaned detections: as it comes, and given
    sotmot's memory (``+GSI 4s``)."""
    info, dets = prepared.info, prepared.detections
    seq = SeqInput(info.path, info, dets,
                   np.zeros((len(dets), 0), np.float32), peer_scores(dets.scores), 0.0)
    return {row: run_peer(row, seq, 0.0)[0] for row, (tracker, _) in TRACKERS_ROWS.items() if tracker in peers}


def noise_floor(noise: dict[str, dict[str, dict]], reference: dict[str, dict]) -> dict[str, dict[str, float]]:
    """Per sequence and metric (HOTA, MOTA, IDF1): the largest absolute change any ``--noise`` run of the
    reference (``noise``: run -> sequence -> scores) made to ``reference``'s scores (sequence -> scores)."""
    floor: dict[str, dict[str, float]] = {}
    for run in noise.values():
        for seq, row in run.items():
            for metric in ("HOTA", "MOTA", "IDF1"):
                change = abs(row[metric] - reference[seq][metric])
                floor.setdefault(seq, {})[metric] = max(floor.get(seq, {}).get(metric, 0.0), change)
    return floor


def worst_of(per_seq: dict[str, dict[str, dict]], reference: str, names: list[str],
             floor: dict[str, dict[str, float]] | None = None,
             runs: dict[str, list[dict[str, dict]]] | None = None) -> dict[str, dict]:
    """Per configuration but the reference, per metric: the mean change against the reference over the
    sequences ``names``, the worst one and which sequences lose more than :data:`RULE` (the selection rule);
    with a noise ``floor`` (:func:`noise_floor`), also which of them lose more than their floor too; with
    ``runs`` (configuration -> its rows of each ``--seeds`` run, paired in order), which lose more than
    :data:`RULE` in every run."""
    worst: dict[str, dict] = {}
    for name in [n for n in per_seq if n != reference]:
        worst[name] = {}
        for metric in ("HOTA", "MOTA", "IDF1"):
            delta = {s: per_seq[name][s][metric] - per_seq[reference][s][metric] for s in names}
            low = min(delta, key=delta.get)
            below = sorted(s for s, d in delta.items() if d < -RULE)
            worst[name][metric] = {"worst_sequence": low, "worst": delta[low],
                                   "mean": sum(delta.values()) / len(delta), "sequences_below_-0.5": below}
            if floor:
                worst[name][metric]["below_noise_floor"] = [s for s in below
                                                            if delta[s] < -floor.get(s, {}).get(metric, 0.0)]
            if runs:
                worst[name][metric]["below_in_every_run"] = [
                    s for s in names if all(mine[s][metric] - ref[s][metric] < -RULE
                                            for mine, ref in zip(runs[name], runs[reference]))]
    return worst


def mean_rows(rows: list[dict[str, float]]) -> dict[str, float]:
    """The mean of score rows (one per run), metric by metric."""
    return {k: sum(r[k] for r in rows) / len(rows) for k in rows[0]}


def merge_reports(old: dict, new: dict) -> dict:
    """``old`` updated by ``new`` (two reports of this script): each configuration's rows of the sequences and
    groups ``new`` measured replace ``old``'s, the rest are kept; ``new``'s peers replace ``old``'s when it has
    any; the worst sequences are recomputed over every sequence. Both must share the reference, and a
    configuration ``old`` lacks must come with every sequence ``old`` has.

    Raises
    ------
    ValueError
        For another reference, or a new configuration that would leave sequences without rows.
    """
    if protocol(new) != protocol(old):
        raise ValueError(f"--merge: this run's detections are {protocol(new)}, the old report's {protocol(old)}: "
                         "one report per protocol")
    if new["reference"] != old["reference"]:
        raise ValueError(f"--merge: the reference is {new['reference']!r} here and {old['reference']!r} in the "
                         "old report")
    groups = {**old["groups"], **new["groups"]}
    machine = old["machine"] if old["machine"] == new["machine"] else \
        f"{'; '.join(machines(old['machine']))} (rows not rerun); {new['machine']} (this run's rows)"
    merged = {**old, "machine": machine, "groups": groups, "seconds": {**old["seconds"], **new["seconds"]}}
    for key in ("configs", "configs_described"):
        merged[key] = {**old[key], **new[key]}
    merged["sequences"] = {name: {**old["sequences"].get(name, {}), **new["sequences"].get(name, {})}
                           for name in merged["configs"]}
    merged["combined"] = {name: {**old["combined"].get(name, {}), **new["combined"].get(name, {})}
                          for name in merged["configs"]}
    short = [name for name, rows in merged["sequences"].items() if set(rows) != set(groups)]
    if short:
        raise ValueError(f"--merge: {', '.join(short)} would lack rows of some sequences; run them on every group")
    merged["peers"] = new.get("peers") or old.get("peers") or {}
    noise = {run: {**old.get("noise", {}).get(run, {}), **new.get("noise", {}).get(run, {})}
             for run in {**old.get("noise", {}), **new.get("noise", {})}}
    floor = noise_floor(noise, merged["sequences"][merged["reference"]])
    merged.update(noise=noise, noise_floor=floor)
    merged["worst"] = worst_of(merged["sequences"], merged["reference"], list(groups), floor)
    return merged


def machines(text: str) -> list[str]:
    """The machines a report's ``machine`` names, once each: a merged report's says which rows were rerun where,
    and a second merge must not nest those words."""
    names = [part.removesuffix(" (rows not rerun)").removesuffix(" (this run's rows)") for part in text.split("; ")]
    return list(dict.fromkeys(names))


def protocol(report: dict) -> str:
    """Whose boxes a report's sequences with frames were tracked from: ``"public"`` (their ``det/det.txt``; reports
    written before private runs existed say nothing) or ``"private: <detector file>"``."""
    return report.get("detections", "public")


def cells(values: dict[str, float]) -> str:
    return "".join(f"{values[c]:8.1f}" if c in ("HOTA", "MOTA", "IDF1") else f"{values[c]:8.0f}" for c in COLUMNS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model (for the sequences with frames)")
    add_more_argument(parser)
    parser.add_argument("--config", action="append", type=named_config, metavar="NAME=FILE",
                        help="a configuration to judge (repeat; the first is the reference; FILE empty: the "
                             "defaults; default: defaults=)")
    parser.add_argument("--groups", type=validation_groups,
                        help=f"which parts of the set, of those above (default: {','.join(GROUPS)}; with "
                             f"--detector-model frames,rates,clips)")
    parser.add_argument("--cache", type=Path, default=Path(".cache/validation"),
                        help="frame-rate variants and re-ID features kept between runs (default: %(default)s)")
    parser.add_argument("--peers", default="",
                        help=f"motion-only peers on the label-only sequences, comma-separated, of "
                             f"{', '.join(TRACKERS_PACKAGE)} (default: none)")
    parser.add_argument("--noise", action="store_true",
                        help="also track the reference under changes that should change nothing (re-ID in the other "
                             "runtime; boxes moved by under half a pixel, two seeds): each sequence's noise floor, "
                             "beside which a candidate's losses are judged")
    parser.add_argument("--seeds", type=int, default=0, metavar="K",
                        help="also track K copies of every sequence whose boxes moved by under half a pixel (seeds "
                             "1 to K): rows are means over the K + 1 runs, and a loss counts only where it shows in "
                             "every run (default: %(default)s, one run)")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="track the sequences with frames from this person detector's boxes (private "
                             "detections) instead of their det/det.txt; only --groups frames,rates,clips (the clips "
                             "of the data folder: another detector's boxes on their frames would be the same run "
                             "again)")
    parser.add_argument("--det-cache", type=Path, default=Path(".cache/detections"),
                        help="where the detector's boxes are kept between runs (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write the report here")
    parser.add_argument("--merge", type=Path, metavar="OLD.json",
                        help="a previous report to update: the rows this run measures (its configurations on its "
                             "groups, its peers) replace the old ones, the rest are kept, and the worst sequences "
                             "are recomputed over all of them; written to --json, another file")
    args = parser.parse_args(argv)
    detector = None
    if args.detector_model:
        if not Path(args.detector_model).is_file():
            parser.error(f"--detector-model: no such file: {args.detector_model}")
        if args.groups and set(LABEL_GROUPS) & set(args.groups):
            parser.error("--detector-model detects on frames: the label-only sequences have none; give --groups "
                         "frames, rates or clips")
        for flag, given in (("--seeds", args.seeds), ("--peers", args.peers)):
            if given:
                parser.error(f"{flag} is for the public detections (their boxes moved, the label-only sequences): "
                             "not with --detector-model")
        detector = str(Path(args.detector_model).resolve())
    args.groups = args.groups or (("frames", "rates", "clips") if detector else GROUPS)
    if args.seeds < 0:
        parser.error("--seeds takes a count, 0 or more")
    if args.seeds and (args.merge or args.noise):
        parser.error("--seeds makes a report of its own: not with --merge (its rows are means over runs) or --noise "
                     "(the runs of every configuration already pair each with chance)")
    previous = None
    if args.merge:
        previous = read_report(parser, args.merge, f"--merge {args.merge}", ("configs", "reference", "groups"))
    if args.merge and not args.json:
        parser.error("--merge writes the merged report to --json: give both")
    if args.merge and args.json.resolve() == args.merge.resolve():
        parser.error("--json must name another file than --merge (a run never writes over what it read); "
                     "replace the old report with the new one afterwards")
    peers = [p for p in args.peers.split(",") if p]
    if any(p not in TRACKERS_PACKAGE for p in peers):
        parser.error(f"--peers: choose from {', '.join(TRACKERS_PACKAGE)}")
    if peers:
        try:  # before any sequence is tracked: the peers and boxmot's GSI come with the benchmark extras
            for module in ("trackers", "boxmot"):
                importlib.import_module(module)
        except ImportError as exc:
            parser.error(f"--peers needs the benchmark extras ({exc}); run: bash scripts/bootstrap.sh --bench")

    described = dict(args.config or [named_config("defaults=")])
    configs = {name: cfg for name, (cfg, _) in described.items()}
    reference = next(iter(configs))
    if previous is not None:  # what merge_reports would refuse, said before any work
        fresh = [n for n in configs if n not in previous["configs"]]
        if previous["reference"] != reference:
            parser.error(f"--merge: the first --config is {reference!r}, the old report's reference "
                         f"{previous['reference']!r}")
        if fresh and not set(previous["groups"].values()) <= set(args.groups):
            parser.error(f"--merge: {', '.join(fresh)} not in the old report: run them on every group it has")
    # configurations that agree on every section a preparation reads share one preparation of each sequence
    preparation = {name: preparation_key(cfg) for name, cfg in configs.items()}
    members = validation_set(args.data, args.cache, set(args.groups), private=detector is not None,
                             more=more_found(args))
    if not members:
        print(f"no validation sequences under {args.data}", file=sys.stderr)
        return 1
    embedders: dict[str, list] = {}  # one box per [appearance]: a box's embedder computes the features not cached
    pairs: dict[str, list[tuple[Path, Path, int, str]]] = {name: [] for name in configs}
    noise_pairs: dict[str, list[tuple[Path, Path, int, str]]] = {}
    group_of: dict[str, str] = {}
    seconds: dict[str, float] = {}
    peer_pairs: dict[str, list[tuple[Path, Path, int, str]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for group, seq in members:
            start = time.perf_counter()
            copies = [(seq, args.cache / "features", "")] + [
                (*jittered_copy(seq, k, args.cache), f"@{k}") for k in range(1, args.seeds + 1)]
            for copy, cache, suffix in copies:
                made: dict[str, object] = {}
                for name, cfg in configs.items():
                    cfg = for_group(cfg, group, args.model)
                    if detector:
                        cfg = private_config(cfg, copy, detector, args.det_cache)
                    if preparation[name] not in made:
                        made[preparation[name]] = prepare_sequence(
                            copy, cfg, features=group_features(copy, cfg, group, cache, embedders))
                    result = finish_sequence(made[preparation[name]], cfg)
                    keep_result(pairs, name + suffix, result.tracks, result.info, Path(tmp))
                if not suffix:
                    prepared = made[preparation[reference]]
            neutral = noise_runs(seq, group, configs[reference], args.model, args.cache, detector,
                                 args.det_cache) if args.noise else {}
            for run, (run_seq, cfg, cache) in neutral.items():
                features = group_features(run_seq, cfg, group, cache, embedders)
                result = finish_sequence(prepare_sequence(run_seq, cfg, features=features), cfg)
                keep_result(noise_pairs, run, result.tracks, result.info, Path(tmp) / "noise")
            group_of[prepared.info.name] = group
            if group == "labels":
                for name, tracks in peer_runs(prepared, peers).items():
                    keep_result(peer_pairs, name, tracks, prepared.info, Path(tmp))
            seconds[prepared.info.name] = time.perf_counter() - start
            print(f"{prepared.info.name}: {seconds[prepared.info.name]:.1f} s", file=sys.stderr)
        by_group = {label: {g: evaluate_files([p for p in runs if group_of[p[3]] == g])
                            for g in sorted(set(group_of.values()))} for label, runs in pairs.items()}
        by_peer = {name: evaluate_files(p) for name, p in peer_pairs.items()}
        by_noise = {run: [evaluate_files([p for p in runs if group_of[p[3]] == g])
                          for g in sorted({group_of[p[3]] for p in runs})] for run, runs in noise_pairs.items()}
    # per sequence: each group's own rows (a sequence's scores do not depend on what it is scored beside)
    each = {label: {s: row for rep in reps.values() for s, row in rep.sequences.items()}
            for label, reps in by_group.items()}
    labels = {name: [name] + [f"{name}@{k}" for k in range(1, args.seeds + 1)] for name in configs}
    per_seq = {name: {s: mean_rows([each[label][s] for label in runs]) for s in each[name]}
               for name, runs in labels.items()}
    combined = {name: {g: mean_rows([by_group[label][g].combined for label in runs]) for g in by_group[name]}
                for name, runs in labels.items()}
    seed_runs = {name: [each[label] for label in runs] for name, runs in labels.items()} if args.seeds else None
    noise = {run: {s: row for rep in reps for s, row in rep.sequences.items()} for run, reps in by_noise.items()}
    floor = noise_floor(noise, per_seq[reference])

    names = list(group_of)
    head = f"{'sequence':<28}{'config':<16}" + "".join(f"{c:>8}" for c in COLUMNS)
    lines = [head, "-" * len(head)]
    for seq in names:
        for name in configs:
            lines.append(f"{seq:<28}{name:<16}" + cells(per_seq[name][seq]))
    lines.append("")
    for g in sorted(set(group_of.values())):
        for name in configs:
            lines.append(f"{'combined ' + g:<28}{name:<16}" + cells(combined[name][g]))
    worst = worst_of(per_seq, reference, names, floor, seed_runs)
    if floor:
        lines += ["", f"noise floor of {reference!r} (the largest change of {', '.join(noise)}), HOTA / MOTA / IDF1:"]
        lines += [f"  {seq:<26}" + " / ".join(f"{floor[seq][m]:.2f}" for m in ("HOTA", "MOTA", "IDF1"))
                  for seq in names if seq in floor]
    lines += ["", f"change against {reference!r}, per sequence: mean and worst (the selection rule: a new default "
                  f"loses at most {RULE} HOTA and {RULE} MOTA on any sequence)"]
    for name, metrics in worst.items():
        for metric, w in metrics.items():
            beyond = (f", {len(w['below_noise_floor'])} beyond their noise floor" if "below_noise_floor" in w
                      else f", {len(w['below_in_every_run'])} in every run" if "below_in_every_run" in w else "")
            lines.append(f"  {name:<16}{metric}: mean {w['mean']:+6.2f}, worst {w['worst']:+6.2f} "
                         f"({w['worst_sequence']}), {len(w['sequences_below_-0.5'])} of {len(names)} sequences "
                         f"below -{RULE}{beyond}")
    if by_peer:
        lines += ["", "motion-only peers on the label-only sequences (combined), beside the reference:"]
        lines.append(f"{'combined labels':<28}{reference:<16}" + cells(combined[reference]["labels"]))
        lines += [f"{'combined labels':<28}{name:<16}" + cells(rep.combined) for name, rep in by_peer.items()]
    print("\n".join(lines))
    if args.seeds:
        print(f"rows: means over each sequence and its {args.seeds} copies with boxes moved by under "
              f"{JITTER_PIXELS} px")
    detections = f"private: {Path(detector).name}" if detector else "public"
    print(f"frames: {'the boxes of ' + Path(detector).name if detector else 'public detections'}, re-ID "
          f"{Path(args.model).name}; labels: motion only (no frames)")
    print(f"machine: {machine()}")
    if args.json:
        report = {
            "machine": machine(), "model": args.model, "detections": detections, "reference": reference,
            "configs": {name: cfg.to_dict() for name, cfg in configs.items()},
            "configs_described": {name: about for name, (_, about) in described.items()},
            "groups": group_of, "seconds": seconds,
            "sequences": per_seq,
            "combined": combined, "seeds": args.seeds, "runs": seed_runs or {},
            "worst": worst, "noise": noise, "noise_floor": floor,
            "peers": {name: {"sequences": rep.sequences, "combined": rep.combined} for name, rep in by_peer.items()},
        }
        if args.merge:
            report = merge_reports(previous, report)
        write_text_atomic(args.json, json.dumps(report, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
