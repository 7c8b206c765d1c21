"""Every tracker flag of the command line is parsed by a test (issue #40): each one given alone changes the
configuration the run would use, or is one of the run's own options (where, how many processes, resume)."""

from __future__ import annotations

import argparse
import re

import pytest

from sotmot.cli import build_parser
from sotmot.cli.flags import build_config

#: Flags that choose how the run goes, not how it tracks: they never reach the configuration.
RUN_OPTIONS = {"--out", "--live", "--eval", "--workers", "--cluster", "--resume", "--det", "--config", "--quiet",
               "--verbose", "--help", "--json", "--ids", "--tracklets", "--tracks", "--frames", "--solvers", "--jitter"}
#: A value for each flag that takes one and has no choices; prerequisites a flag needs to be valid.
VALUES = {"--reid-model": "m.onnx", "--weights": "w.pt", "--detector-model": "d.xml", "--score-threshold": "0.3",
          "--confirm-threshold": "0.3", "--extend-ends": "0.5", "--fps": "12", "--window": "30", "--mask": "m.png",
          "--step": "2"}
NEEDS = {"--weights": ["--appearance", "torch"]}


def _tracker_flags(command: str) -> list[argparse.Action]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[command]
    return [a for a in sub._actions if a.option_strings and not (set(a.option_strings) & RUN_OPTIONS)
            and not (set(a.option_strings) & {"-h", "-v", "-q"})]


def _config(command: str, extra: list[str]):
    argv = [command, "SEQ"] + (["--out", "o"] if command in ("track", "graph") else []) + \
        (["--ids", "1,2"] if command == "explain" else []) + extra
    return build_config(build_parser().parse_args(argv))


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


def test_the_flag_table_names_real_fields_and_says_where_each_lives():
    import dataclasses
    import typing

    from sotmot.cli.flags import FLAGS, help_text
    from sotmot.config import SECTIONS

    for flag in FLAGS:
        names = {f.name for f in dataclasses.fields(SECTIONS[flag.section])}
        assert flag.field in names, f"{flag.names[0]}: [{flag.section}] has no field {flag.field}"
        assert f"([{flag.section}] {flag.field}, default" in help_text(flag)
    # choices come from the field's type: a Literal's values are the flag's choices
    nms = next(a for a in _tracker_flags("track") if "--nms" in a.option_strings)
    hint = typing.get_type_hints(SECTIONS["preprocess"])["nms"]
    assert list(nms.choices) == list(typing.get_args(hint))


def test_a_value_the_configuration_refuses_is_an_error_that_names_the_flag():
    from sotmot.errors import ConfigError

    for argv, shown in ((["--fps", "0"], "--fps 0: [input] fps"), (["--window", "-1"], "--window -1: [windows]"),
                        (["--extend-ends", "-2"], "--extend-ends -2: [ends]")):
        with pytest.raises(ConfigError, match="^" + re.escape(shown)):
            _config("track", argv)


def test_a_value_that_is_no_number_is_refused_by_the_parser(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["track", "SEQ", "--out", "o", "--fps", "fast"])
    assert "invalid float value: 'fast'" in capsys.readouterr().err
