"""The tracker's command-line flags: one table, :data:`FLAGS`, from flag to configuration field.

Each :class:`Flag` names the ``[section] field`` it sets. Its choices come from
the field's ``Literal`` type (or the plug-in table that names the valid values),
its value's type from the field's type, and its help from the field's own
description in the section's docstring (the text docs/configuration.md
shows), so a flag cannot drift from the configuration it sets. Values are
checked once, by the configuration; a failed check names the flag.
"""

from __future__ import annotations

import argparse
import re
import types
import typing
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from sotmot.config import SECTIONS, TrackerConfig, field_docs, load_config
from sotmot.errors import ConfigError

#: Sub-commands that track: each takes the flags of :data:`FLAGS` whose ``commands`` name it.
COMMANDS = frozenset({"track", "compare", "graph", "explain"})
#: Help text longer than this is cut at the end of a sentence (the configuration reference has it whole).
HELP_CHARS = 420


def _solvers() -> list[str]:
    from sotmot.plugins import SOLVERS

    return sorted(SOLVERS)


def _backends() -> list[str]:
    from sotmot.plugins import BACKENDS

    return ["auto", *sorted(BACKENDS)]


def _unconfirmed(config: TrackerConfig, value: str) -> TrackerConfig:
    if value == "keep":
        return config.replace("confirm", enabled=False)
    return config.replace("confirm", enabled=True, low_confidence=value)


@dataclass(frozen=True)
class Flag:
    """One tracker flag and the configuration field it sets.

    Attributes
    ----------
    names
        The flag and its aliases (``--solver``, ``--merger``).
    section, field
        What it sets: ``[section] field``.
    switch
        For a flag without a value: what it sets the field to.
    metavar
        The value's name in the help.
    note
        Said before the field's description, where the flag is more than the field (``--no-flip``).
    choices
        The valid values where the field's type does not list them: a function, so that the plug-in tables
        are read only when the parser is built.
    sets
        ``(config, value) -> config`` for a flag that sets more than its one field.
    commands
        The sub-commands that take it.
    """

    names: tuple[str, ...]
    section: str
    field: str
    switch: Any = None
    metavar: str | None = None
    note: str = ""
    choices: Callable[[], list[str]] | None = None
    sets: Callable[[TrackerConfig, Any], TrackerConfig] | None = None
    commands: frozenset[str] = field(default=COMMANDS)

    @property
    def dest(self) -> str:
        return self.names[0].removeprefix("--").replace("-", "_")

    def apply(self, config: TrackerConfig, value: Any) -> TrackerConfig:
        """``config`` with this flag's value set; a value the configuration refuses is an error naming the flag."""
        try:
            if self.sets is not None:
                return self.sets(config, value)
            return config.replace(self.section, **{self.field: value})
        except ConfigError as exc:
            given = f"{value:g}" if isinstance(value, float) else value
            shown = self.names[0] if self.switch is not None else f"{self.names[0]} {given}"
            raise ConfigError(f"{shown}: {exc}") from None


#: Every tracker flag, in the order the help lists them and the configuration receives them.
FLAGS: tuple[Flag, ...] = (
    Flag(("--solver", "--merger"), "association", "solver", choices=_solvers, metavar="SOLVER",
         commands=frozenset({"track", "graph", "explain"})),
    Flag(("--reid-model",), "appearance", "model", metavar="PATH",
         note="Overrides the configuration and SOTMOT_REID_MODEL."),
    Flag(("--appearance",), "appearance", "backend", choices=_backends,
         note="none: no re-ID, the motion-only mode (several times faster with a det.txt, about twice with "
              "the built-in detector; 6 to 25 HOTA lower where frames exist: docs/results.md, \"Without re-ID\")."),
    Flag(("--fps",), "input", "fps", metavar="N", commands=frozenset({"track", "graph", "explain", "compare"})),
    Flag(("--step",), "input", "step", metavar="K", commands=frozenset({"track", "graph", "explain"})),
    Flag(("--no-flip",), "appearance", "flip", switch=False, note="Embed each crop once, without its mirror image."),
    Flag(("--device",), "appearance", "device"),
    Flag(("--weights",), "appearance", "weights", metavar="FILE.pt", note="Implies --appearance torch.",
         sets=lambda c, v: c.replace("appearance", backend="torch", weights=v)),
    Flag(("--detections",), "detection", "source"),
    Flag(("--detector-model",), "detection", "model", metavar="PATH.xml",
         note="Overrides the configuration and SOTMOT_DETECTOR_MODEL."),
    Flag(("--score-threshold",), "preprocess", "score_threshold", metavar="S"),
    Flag(("--nms",), "preprocess", "nms"),
    Flag(("--confidence",), "preprocess", "confidence"),
    Flag(("--mask",), "preprocess", "mask", metavar="IMAGE"),
    Flag(("--unconfirmed",), "confirm", "low_confidence", choices=lambda: ["drop", "file", "keep"], sets=_unconfirmed,
         note="Boxes more likely false than true after association: drop them, write them to DIR/<name>.low.txt "
              "(file), or keep them (keep: [confirm] enabled = false)."),
    Flag(("--confirm-threshold",), "confirm", "threshold", metavar="P",
         note="sotmot explain --ids N shows the probabilities of a track's boxes."),
    Flag(("--weak-boxes",), "detection", "weak_boxes"),
    Flag(("--sot",), "sot", "variant"),
    Flag(("--extend-ends",), "ends", "seconds", metavar="SECONDS"),
    Flag(("--camera-motion",), "motion", "compensation"),
    Flag(("--window",), "windows", "seconds", metavar="SECONDS", commands=frozenset({"track"})),
)


def _hint(flag: Flag) -> Any:
    """The field's type, without ``None``."""
    hint = typing.get_type_hints(SECTIONS[flag.section])[flag.field]
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        hint = next(a for a in typing.get_args(hint) if a is not type(None))
    return hint


def _plain(text: str) -> str:
    """reStructuredText roles and literals as plain words: ``x`` and :func:`a.b` -> x and a.b."""
    return re.sub(r":\w+:`~?([^`]+)`", r"\1", text).replace("``", "")


def _short(text: str, limit: int = HELP_CHARS) -> str:
    """``text`` up to the last sentence end within ``limit`` characters (at least its first sentence)."""
    if len(text) <= limit:
        return text
    ends = [m.end() for m in re.finditer(r"[.;](?=\s+[A-Z(\"'])", text)]
    cut = max((e for e in ends if e <= limit), default=ends[0] if ends else len(text))
    return text[:cut] + " (more in docs/configuration.md)"


def help_text(flag: Flag) -> str:
    """The flag's help: its note, the field's description, where it lives and its default."""
    doc = _short(_plain(field_docs(SECTIONS[flag.section])[flag.field]))
    default = getattr(SECTIONS[flag.section](), flag.field)
    shown = "none" if default is None else str(default).lower() if isinstance(default, bool) else default
    return " ".join(p for p in (flag.note, doc, f"([{flag.section}] {flag.field}, default {shown})") if p) \
        .replace("%", "%%")


def add_tracker_flags(parser: argparse.ArgumentParser, command: str) -> None:
    """Add ``--config`` and every flag of :data:`FLAGS` that ``command`` takes to ``parser``."""
    parser.add_argument("--config", type=Path, metavar="FILE",
                        help="TOML or JSON file with " + ", ".join(f"[{name}]" for name in SECTIONS)
                             + " tables (docs/configuration.md); unknown keys are errors. Or a run record "
                               "(<name>.run.json beside earlier results): the settings of that run. The flags below "
                               "override it")
    for flag in FLAGS:
        if command not in flag.commands:
            continue
        if flag.switch is not None:
            parser.add_argument(*flag.names, dest=flag.dest, action="store_const", const=flag.switch,
                                help=help_text(flag))
            continue
        hint = _hint(flag)
        choices = flag.choices() if flag.choices else (list(typing.get_args(hint))
                                                        if typing.get_origin(hint) is Literal else None)
        kind = float if hint is float else int if hint is int else str
        parser.add_argument(*flag.names, dest=flag.dest, choices=choices, type=None if choices else kind,
                            metavar=flag.metavar, help=help_text(flag))


def build_config(args: argparse.Namespace) -> TrackerConfig:
    """The configuration a tracking command runs with: ``--config`` (or the defaults), then each flag given."""
    config = load_config(args.config) if getattr(args, "config", None) else TrackerConfig()
    for flag in FLAGS:
        value = getattr(args, flag.dest, None)
        if value is not None:
            config = flag.apply(config, value)
    return config
