"""Every tracker flag of the command line is parsed by a test (issue #40): each one given alone changes the
configuration the run would use, or is one of the run's own options (where, how many processes, resume)."""

from __future__ import annotations

import argparse

import pytest

from sotmot.cli import _build_config, build_parser

#: Flags that choose how the run goes, not how it tracks: they never reach the configuration.
RUN_OPTIONS = {"--out", "--eval", "--workers", "--cluster", "--resume", "--det", "--config", "--quiet", "--verbose",
               "--help", "--json", "--ids", "--tracklets", "--frames", "--solvers"}
#: A value for each flag that takes one and has no choices; prerequisites a flag needs to be valid.
VALUES = {"--reid-model": "m.onnx", "--weights": "w.pt", "--detector-model": "d.xml", "--score-threshold": "0.3",
          "--extend-ends": "0.5", "--fps": "12", "--window": "30"}
NEEDS = {"--weights": ["--appearance", "torch"]}


def _tracker_flags(command: str) -> list[argparse.Action]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[command]
    return [a for a in sub._actions if a.option_strings and not (set(a.option_strings) & RUN_OPTIONS)
            and not (set(a.option_strings) & {"-h", "-v", "-q"})]


def _config(command: str, extra: list[str]):
    argv = [command, "SEQ"] + (["--out", "o"] if command in ("track", "graph") else []) + \
        (["--ids", "1,2"] if command == "explain" else []) + extra
    return _build_config(build_parser().parse_args(argv))


@pytest.mark.parametrize("command", ["track", "compare", "graph", "explain"])
def test_every_tracker_flag_changes_the_configuration(command):
    flags = _tracker_flags(command)
    assert len(flags) >= 15, [a.option_strings for a in flags]
    for action in flags:
        flag = next(s for s in action.option_strings if s.startswith("--"))
        base = NEEDS.get(flag, [])
        reference = _config(command, base).to_dict()
        if action.nargs == 0:
            tried = [[flag]]
        elif action.choices:
            tried = [[flag, str(choice)] for choice in action.choices]
        else:
            assert flag in VALUES, f"{command} {flag}: give it a value in VALUES"
            tried = [[flag, VALUES[flag]]]
        changed = [t for t in tried if _config(command, base + t).to_dict() != reference]
        assert changed, f"{command} {flag}: no value of it changes the configuration"
