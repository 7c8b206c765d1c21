#!/usr/bin/env python3
"""Leave one video out over validation reports: which candidate default each fold would choose, and what it does
to the video held out.

A default chosen on the very sequences it is reported on says little about the next video (issue #39: a gap
tuned on three videos cost eleven others 3.7 MOTA). This script reads reports of
``scripts/bench_validation.py`` (``--json``; public and private ones together, any groups) and replays the
choice with one video held out at a time:

* a **run** is one sequence under one protocol (MOT16-09 from its ``det.txt`` and from the built-in detector's
  boxes are two runs); a **video** is what a run shows: MOT16-09 and the MOT17-09 sets are one video, and a
  sequence's 8-15 fps copies are its video too (:func:`sotmot.benchmarks.video_of`);
* each fold trains on every run of the other videos: a candidate is **eligible** when no training run loses more
  than :data:`bench_validation.RULE` HOTA or MOTA against the reference; the fold chooses the eligible candidate
  whose mean change of (HOTA + MOTA) / 2 over its training runs is the largest, and keeps the reference when
  none gains (fewer knobs: a tie keeps what is);
* with ``--floor`` (reports made with ``--noise``) chance is allowed for: a training loss counts only beyond
  the run's noise floor too, and a gain only beyond the **noise gain**, the largest mean change of (HOTA +
  MOTA) / 2 that a noise run (re-ID in the other runtime, boxes moved by under half a pixel: changes that
  should change nothing) makes over the same training runs;
* printed per fold: the choice, its mean gain in training, and on the held-out runs the mean and the worst
  change of HOTA and MOTA; then every candidate over all runs (mean, worst run, runs below the rule).

    python scripts/choose_default.py docs/results/validation.json docs/results/validation_private.json
    python scripts/choose_default.py /tmp/seen.json --reference off --candidates 0.2,0.25,0.3 --json /tmp/lovo.json
    # candidates measured later beside the same defaults, judged with the committed reports' noise floors
    python scripts/choose_default.py docs/results/validation.json /tmp/new.json --candidates new1,new2 --floor

The reports' own configurations are the candidates (``--candidates`` picks some, in the order to prefer on a
tie); each must have tracked every run. Reports of the same runs are merged (a candidate measured later beside
the same defaults joins the report whose noise runs measured their floor), and must agree where they overlap.
Nothing is tracked: it takes seconds.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from bench_validation import RULE
from sotmot.benchmarks import video_of
from sotmot.io import write_text_atomic

METRICS = ("HOTA", "MOTA")


@dataclass(frozen=True)
class Run:
    """One sequence of one report: its name, protocol (``public`` or ``private``), group and video, each
    configuration's scores (name -> metric -> value), its noise floor (metric -> value) and the reference's
    scores in each noise run (noise run -> metric -> value; both empty without ``--noise``)."""

    name: str
    protocol: str
    group: str
    video: str
    scores: dict[str, dict[str, float]]
    floor: dict[str, float]
    noise: dict[str, dict[str, float]]

    @property
    def label(self) -> str:
        return f"{self.name} ({self.protocol})"

    def change(self, candidate: str, reference: str, metric: str) -> float:
        return self.scores[candidate][metric] - self.scores[reference][metric]


def read_runs(paths: list[Path], reference: str, candidates: list[str] | None,
              groups: list[str] | None = None) -> tuple[list[Run], list[str]]:
    """The runs of the reports at ``paths`` (only those of ``groups``, when given) and the candidates judged
    (``candidates``, or every configuration the reports hold but ``reference``, in the order found).

    Reports that hold the same run (a sequence under the same protocol) are merged: each adds its configurations
    and noise runs, and they must agree on every configuration both hold (a candidate measured later, beside the
    same defaults, joins the report that measured the noise). Raises ``ValueError`` naming the file when a report
    is not a validation report, lacks the reference, disagrees with an earlier one, or a candidate is missing
    from a run."""
    merged: dict[tuple[str, str], dict] = {}
    found: list[str] = []
    for path in paths:
        try:
            report = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise ValueError(f"{path}: cannot read it as JSON: {exc}") from exc
        if not isinstance(report, dict) or not isinstance(report.get("sequences"), dict):
            raise ValueError(f"{path}: not a report of scripts/bench_validation.py (no 'sequences')")
        per_config = report["sequences"]
        if reference not in per_config:
            raise ValueError(f"{path}: no configuration {reference!r}; it has {', '.join(per_config)}")
        found += [c for c in per_config if c != reference and c not in found]
        protocol = "private" if str(report.get("detections", "")).startswith("private") else "public"
        floors, noise = report.get("noise_floor") or {}, report.get("noise") or {}
        for name in per_config[reference]:
            run = merged.setdefault((protocol, name), {"group": report.get("groups", {}).get(name, ""),
                                                       "scores": {}, "floor": {}, "noise": {}, "from": {}})
            for config, rows in per_config.items():
                if name not in rows:
                    continue
                scores = {m: float(rows[name][m]) for m in METRICS}
                if config in run["scores"] and run["scores"][config] != scores:
                    raise ValueError(f"{path}: {name} ({protocol}) under {config!r} scores otherwise than in "
                                     f"{run['from'][config]}: not the same run")
                run["scores"][config], run["from"][config] = scores, path
            run["floor"].update({m: float(v) for m, v in floors.get(name, {}).items() if m in METRICS})
            run["noise"].update({f"{protocol} {n}": {m: float(per[name][m]) for m in METRICS}
                                 for n, per in noise.items() if name in per})
    candidates = found if candidates is None else candidates
    merged = {key: run for key, run in merged.items() if groups is None or run["group"] in groups}
    for (protocol, name), run in merged.items():
        missing = [c for c in candidates if c not in run["scores"]]
        if missing:
            raise ValueError(f"{name} ({protocol}): no run of {', '.join(map(repr, missing))} in "
                             f"{', '.join(str(p) for p in paths)}")
    runs = [Run(name, protocol, run["group"], video_of(name),
                {c: run["scores"][c] for c in [reference, *candidates]}, run["floor"], run["noise"])
            for (protocol, name), run in merged.items()]
    return runs, candidates


def loses(run: Run, candidate: str, reference: str, floor: bool) -> bool:
    """Whether ``candidate`` loses more than the rule allows on ``run`` (beyond its noise floor with ``floor``)."""
    return any(run.change(candidate, reference, m) < -max(RULE, run.floor.get(m, 0.0) if floor else 0.0)
               for m in METRICS)


def mean_change(runs: list[Run], scores: Callable[[Run], dict[str, float]], reference: str) -> float:
    """The mean over ``runs`` of the change of (HOTA + MOTA) / 2 from ``reference``'s scores to ``scores(run)``."""
    return sum(sum(scores(r)[m] - r.scores[reference][m] for m in METRICS) / len(METRICS) for r in runs) / len(runs)


def gain(runs: list[Run], candidate: str, reference: str) -> float:
    """The mean over ``runs`` of ``candidate``'s change of (HOTA + MOTA) / 2 against ``reference``."""
    return mean_change(runs, lambda r: r.scores[candidate], reference)


def noise_gain(runs: list[Run], reference: str) -> float:
    """The largest absolute mean change of (HOTA + MOTA) / 2 that one noise run of the reference makes over the
    ``runs`` it covers (0 without noise runs): a mean gain this small is chance."""
    largest = 0.0
    for name in dict.fromkeys(n for r in runs for n in r.noise):
        covered = [r for r in runs if name in r.noise]
        largest = max(largest, abs(mean_change(covered, lambda r: r.noise[name], reference)))
    return largest


def summary(runs: list[Run], candidate: str, reference: str) -> dict:
    """Mean and worst change of each metric over ``runs`` (the worst run named)."""
    out: dict = {}
    for m in METRICS:
        changes = [(r.change(candidate, reference, m), r.label) for r in runs]
        worst = min(changes)
        out[m] = {"mean": sum(c for c, _ in changes) / len(changes), "worst": worst[0], "worst_run": worst[1]}
    return out


def choose(runs: list[Run], candidates: list[str], reference: str, floor: bool, margin: float = 0.0
           ) -> tuple[str, float]:
    """The candidate a fold trained on ``runs`` chooses and its mean gain there (the reference and 0 when no
    eligible candidate gains more than ``margin``, the noise gain with ``floor``; the first of equals wins)."""
    best, best_gain = reference, margin
    for candidate in candidates:
        if any(loses(r, candidate, reference, floor) for r in runs):
            continue
        g = gain(runs, candidate, reference)
        if g > best_gain + 1e-9:
            best, best_gain = candidate, g
    return best, best_gain if best != reference else 0.0


def folds(runs: list[Run], candidates: list[str], reference: str, floor: bool) -> dict[str, dict]:
    """Per video (in the order first seen): the choice trained on the other videos' runs and what it does to the
    held-out runs (:func:`summary`; zeros where the fold keeps the reference)."""
    out = {}
    for video in dict.fromkeys(r.video for r in runs):
        train = [r for r in runs if r.video != video]
        held = [r for r in runs if r.video == video]
        noise = noise_gain(train, reference) if floor else None
        chosen, trained = choose(train, candidates, reference, floor, noise or 0.0) if train else (reference, 0.0)
        out[video] = {"runs": [r.label for r in held], "chose": chosen, "training_gain": trained,
                      "noise_gain": noise,
                      "held_out": summary(held, chosen, reference)}
    return out


def lines(result: dict) -> list[str]:
    """The printed report of :func:`main`'s result."""
    ref = result["reference"]
    noisy = result["floor"]
    out = [f"{'held out':<18}{'runs':>5}  {'chose':<16}{'train gain':>11}" + (f"{'noise gain':>11}" if noisy else "")
           + f"  {'held-out mean HOTA / MOTA':>26}  worst HOTA (run) / MOTA (run)", "-" * 120]
    for video, fold in result["folds"].items():
        h = fold["held_out"]
        out.append(f"{video:<18}{len(fold['runs']):>5}  {fold['chose']:<16}{fold['training_gain']:>+11.3f}"
                   + (f"{fold['noise_gain']:>11.3f}" if noisy else "") + "  "
                   f"{h['HOTA']['mean']:>+12.2f} / {h['MOTA']['mean']:>+6.2f}      "
                   + " / ".join(f"{h[m]['worst']:+.2f} ({h[m]['worst_run']})" for m in METRICS))
    kept = sum(1 for f in result["folds"].values() if f["chose"] == ref)
    others = [f"{c!r} chosen by {n}" for c, n in result["chosen"].items() if c != ref and n]
    out += ["", f"{kept} of {len(result['folds'])} folds keep {ref!r}" + "".join(f"; {o}" for o in others), ""]
    out.append(f"every candidate against {ref!r} over all {result['runs']} runs (in-sample):")
    for name, row in result["all"].items():
        out.append(f"  {name:<16}" + "   ".join(f"{m} mean {row[m]['mean']:+.2f} worst {row[m]['worst']:+.2f} "
                                                   f"({row[m]['worst_run']})" for m in METRICS)
                   + f";  {row['below_rule']} runs below the rule")
    out.append(f"rule: a loss over {RULE} HOTA or MOTA on a training run"
               + (" beyond its noise floor" if noisy else "") + " makes a candidate ineligible; "
               + ("a mean gain within the noise gain is a tie; " if noisy else "")
               + "reports: " + ", ".join(result["reports"]))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="The rule, the folds and what is printed: the docstring of "
                                            "scripts/choose_default.py.")
    parser.add_argument("reports", nargs="+", type=Path, metavar="REPORT.json",
                        help="reports of scripts/bench_validation.py --json (public and private together)")
    parser.add_argument("--reference", default="defaults",
                        help="the configuration every candidate is judged against (default: %(default)s)")
    parser.add_argument("--candidates", help="comma-separated configurations to choose from, the preferred first "
                        "(default: every other configuration the reports hold)")
    parser.add_argument("--groups", help="comma-separated validation groups whose runs count (frames, rates, labels, "
                        "label-rates; default: every run), e.g. for a setting the motion-only mode never reads")
    parser.add_argument("--floor", action="store_true",
                        help="allow for chance (reports made with --noise): a training loss counts only beyond the "
                        "run's noise floor, a gain only beyond the noise runs' mean change")
    parser.add_argument("--json", type=Path, help="write the folds and the in-sample summary here")
    args = parser.parse_args(argv)
    wanted = [c for c in args.candidates.split(",") if c] if args.candidates else None
    try:
        runs, candidates = read_runs(args.reports, args.reference, wanted,
                                     args.groups.split(",") if args.groups else None)
    except ValueError as exc:
        parser.error(str(exc))
    if not candidates:
        parser.error(f"no candidate besides {args.reference!r} in {', '.join(map(str, args.reports))}")
    if not runs:
        parser.error(f"no run of the groups {args.groups} in {', '.join(map(str, args.reports))}")
    result_folds = folds(runs, candidates, args.reference, args.floor)
    result = {
        "reports": [str(p) for p in args.reports], "reference": args.reference, "candidates": candidates,
        "rule": RULE, "floor": args.floor, "groups": args.groups, "runs": len(runs), "folds": result_folds,
        "chosen": {c: sum(1 for f in result_folds.values() if f["chose"] == c) for c in [args.reference, *candidates]},
        "all": {c: {**summary(runs, c, args.reference),
                    "below_rule": sum(loses(r, c, args.reference, args.floor) for r in runs)} for c in candidates},
    }
    print("\n".join(lines(result)))
    if args.json:
        write_text_atomic(args.json, json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
