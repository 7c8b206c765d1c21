"""Configuration: one frozen dataclass per stage, the paper's values as defaults.

Every threshold of the tracker is a field here, documented with its meaning
and where it comes from (He et al., *SOT for MOT*, section numbers below).
Where our re-ID model needs another value than the paper's, the default says
so and points at ``docs/calibration.md``, which derives it from data.

A configuration file (TOML or JSON) holds one table per stage
(``detection``, ``preprocess``, ``appearance``, ``sot``, ``tracklets``, ``association``,
``postprocess``, ``confirm``, ``ends``, ...)::

    [preprocess]
    nms = "iou"
    [association]
    l_max = 45

Unknown tables and keys are errors (a typo must not be silently ignored).
"""


from __future__ import annotations

import dataclasses
import functools
import inspect
import json
import logging
import math
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from sotmot.config.association import AssociationConfig, TrackletConfig
from sotmot.config.common import MAX_FRAME_RATE
from sotmot.config.output import ConfirmConfig, MotionConfig, PostprocessConfig, WindowConfig
from sotmot.config.sot import EndsConfig, SotConfig
from sotmot.config.sources import AppearanceConfig, ConfidenceMethod, DetectionConfig, InputConfig, PreprocessConfig
from sotmot.errors import ConfigError

log = logging.getLogger(__name__)

__all__ = ["AppearanceConfig", "AssociationConfig", "ConfidenceMethod", "ConfirmConfig", "DetectionConfig",
           "EndsConfig", "InputConfig", "MAX_FRAME_RATE", "MotionConfig", "PostprocessConfig", "SECTIONS", "SotConfig",
           "TrackerConfig", "TrackletConfig", "WindowConfig", "config_from_dict", "field_docs", "load_config"]


@dataclass(frozen=True)
class TrackerConfig:
    """The whole tracker: one section per stage."""

    input: InputConfig = field(default_factory=InputConfig)
    detection: DetectionConfig = field(default_factory=DetectionConfig)
    preprocess: PreprocessConfig = field(default_factory=PreprocessConfig)
    appearance: AppearanceConfig = field(default_factory=AppearanceConfig)
    sot: SotConfig = field(default_factory=SotConfig)
    tracklets: TrackletConfig = field(default_factory=TrackletConfig)
    association: AssociationConfig = field(default_factory=AssociationConfig)
    postprocess: PostprocessConfig = field(default_factory=PostprocessConfig)
    confirm: ConfirmConfig = field(default_factory=ConfirmConfig)
    ends: EndsConfig = field(default_factory=EndsConfig)
    motion: MotionConfig = field(default_factory=MotionConfig)
    windows: WindowConfig = field(default_factory=WindowConfig)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain nested dict, the same layout a config file uses."""
        return dataclasses.asdict(self)

    def replace(self, section: str, **changes: Any) -> "TrackerConfig":
        """A copy with some fields of one section changed (validated)."""
        if section not in SECTIONS:
            raise ConfigError(f"unknown section {section!r}; valid: {', '.join(SECTIONS)}")
        current = dataclasses.asdict(getattr(self, section))
        return dataclasses.replace(self, **{section: _build(section, {**current, **_in_frames(section, changes),
                                                                      **changes})})


SECTIONS: dict[str, type] = {
    "input": InputConfig,
    "detection": DetectionConfig,
    "preprocess": PreprocessConfig,
    "appearance": AppearanceConfig,
    "sot": SotConfig,
    "tracklets": TrackletConfig,
    "association": AssociationConfig,
    "postprocess": PostprocessConfig,
    "confirm": ConfirmConfig,
    "ends": EndsConfig,
    "motion": MotionConfig,
    "windows": WindowConfig,
}


@functools.lru_cache(maxsize=None)
def field_docs(cls: type) -> dict[str, str]:
    """Field name -> its description, from the numpy-style ``Attributes`` section of a section's docstring: what
    docs/configuration.md and the command line's help both say of it (parsed once per section; do not change the
    dict returned)."""
    lines = inspect.getdoc(cls).splitlines()
    docs: dict[str, str] = {}
    names: list[str] = []
    for line in lines[lines.index("Attributes") + 2:]:
        if line and not line.startswith(" "):
            names = [n.strip() for n in line.split(",")]
            docs.update((n, "") for n in names)
        elif line.strip():
            for n in names:
                docs[n] = (docs[n] + " " + line.strip()).strip()
    return docs


def _coerce(section: str, name: str, hint: Any, value: Any) -> Any:
    """Check ``value`` against the field's type hint; ints are accepted for floats, and ``"none"`` for an optional
    number (TOML has no null: ``interpolate_max_seconds = "none"``)."""
    args = typing.get_args(hint)
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        if type(None) in args and (value is None or (value == "none" and inner[0] in (int, float))):
            return None
        for choice in inner[1:]:  # a word beside a number (``int | Literal["auto"]``): the word as it is
            if typing.get_origin(choice) is Literal and value in typing.get_args(choice):
                return value
        try:
            return _coerce(section, name, inner[0], value)
        except ConfigError as exc:
            words = [repr(w) for c in inner[1:] if typing.get_origin(c) is Literal for w in typing.get_args(c)]
            if not words:
                raise
            raise ConfigError(str(exc).replace("; got", f" or {' or '.join(words)}; got", 1)) from None
    if origin is Literal:
        if value not in args:
            raise ConfigError(f"[{section}] {name} must be one of {', '.join(map(repr, args))}; got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"[{section}] {name} must be a list; got {value!r}")
        return tuple(_coerce(section, name, args[0], v) for v in value)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"[{section}] {name} must be a finite number; got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"[{section}] {name} must be an integer; got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"[{section}] {name} must be true or false; got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"[{section}] {name} must be a string; got {value!r}")
        return value
    return value


def _in_frames(section: str, given: dict[str, Any]) -> dict[str, Any]:
    """What ``given`` (the fields a file or a caller sets) implies beyond itself: a gap limit given as ``l_max``
    alone is counted in frames, so ``l_max_seconds`` (set by default) is cleared."""
    if section == "association" and "l_max" in given and "l_max_seconds" not in given:
        return {"l_max_seconds": None}
    return {}


#: Gap refinement, removed once the validation set confirmed it gained nothing.
GAPS_REMOVED = ("removed: SOT or the weak boxes inside gaps gained nothing on the validation set (mean -0.05 HOTA; "
                "docs/benchmarks.md), interpolation fills the gaps")

#: Keys that left a section (issue #40), and what to write instead: a file written for an older sotmot gets told.
MOVED = {
    ("sot", "extend_seconds"): "now [ends] seconds",
    ("sot", "extend_min_confidence"): "now [ends] min_confidence",
    ("sot", "extend_min_affinity"): "now [ends] min_affinity",
    ("sot", "stop_iou"): "now [ends] stop_iou",
    ("sot", "refine_gaps"): GAPS_REMOVED,
    ("ends", "refine_gaps"): GAPS_REMOVED,
    ("sot", "verify"): "now [detection] weak_boxes (\"detector\" is \"on\", \"none\" is \"off\")",
    ("sot", "extend_by"): "removed: trajectory ends grow by the detector's weak boxes when [detection] weak_boxes "
                          "is on, else by SOT",
    ("sot", "rules"): "removed: Algorithm 1 runs as the paper publishes it (the \"confident\" rules gained nothing "
                      "held out)",
    ("sot", "must_link"): "removed: seeding tracklets with the SOT links gained nothing",
    ("sot", "seed_min_confidence"): "removed: every detection seeds Algorithm 1, as in the paper",
    **{("sot", name): "removed: the detector's weak boxes are judged by fixed values (sotmot.sot.support)"
       for name in ("verify_min_score", "verify_iou", "extend_supported_affinity", "extend_supported_stop_iou")},
}


#: Fields a run sets from the sequence, never a file or a caller (a run record holds them empty).
SET_BY_THE_RUN = {
    ("association", "frame_rate"): "set by each run from the sequence's frame rate (seqinfo.ini's frameRate, or "
                                   "[input] fps / --fps for a video or a folder of images)",
}


def _build(section: str, values: dict[str, Any]) -> Any:
    cls = SECTIONS[section]
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    moved = [f"[{section}] {k}: {MOVED[section, k]}" for k in sorted(values) if (section, k) in MOVED]
    moved += [f"[{section}] {k}: {SET_BY_THE_RUN[section, k]}, not given" for k in sorted(values)
              if (section, k) in SET_BY_THE_RUN and values[k] is not None]
    if moved:
        raise ConfigError("; ".join(moved))
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise ConfigError(f"[{section}] unknown key(s) {', '.join(unknown)}; valid keys: {', '.join(names)}")
    values = {**values, **_in_frames(section, values)}
    return cls(**{k: _coerce(section, k, hints[k], v) for k, v in values.items()})


def config_from_dict(data: dict[str, Any]) -> TrackerConfig:
    """Build a :class:`TrackerConfig` from nested dicts, rejecting unknown sections and keys."""
    if not isinstance(data, dict):
        raise ConfigError("a configuration must be a table of sections")
    loose = sorted(key for key, value in data.items() if not isinstance(value, dict))
    if loose:  # `l_max = 30` above every [table] of a TOML file
        raise ConfigError(f"key(s) {', '.join(loose)} outside any [section]: every key belongs to the table of its "
                          f"stage, e.g. [association] l_max_seconds = 3; sections: {', '.join(SECTIONS)}")
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise ConfigError(f"unknown section(s) {', '.join(unknown)}; valid sections: {', '.join(SECTIONS)}")
    parts = {}
    for section, values in data.items():
        if not isinstance(values, dict):
            raise ConfigError(f"[{section}] must be a table of keys")
        parts[section] = _build(section, values)
    return TrackerConfig(**parts)


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object as a dict; a key given twice is an error (TOML refuses it too), never last-wins."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ConfigError(f"key {key!r} is given twice")
        out[key] = value
    return out


def _is_run_record(data: Any) -> bool:
    """Whether parsed JSON ``data`` is a run record (``<name>.run.json``, :mod:`sotmot.provenance`)."""
    return (isinstance(data, dict) and isinstance(data.get("config"), dict) and isinstance(data.get("sotmot"), str)
            and "results_sha256" in data)


def run_record_settings(record: dict[str, Any], source: str | Path = "run record") -> dict[str, Any]:
    """The settings a run record holds (its ``config`` table), to run again with: a model the record names by the
    SHA-256 of a bundled one is this installation's copy of it (the record's path may be another machine's)."""
    from sotmot import __version__
    from sotmot.models import MODELS
    from sotmot.versions import environment_changes

    settings = {section: dict(values) if isinstance(values, dict) else values
                for section, values in record["config"].items()}
    for kind, entry, section in (("reid", "reid_model", "appearance"), ("detector", "detector_model", "detection")):
        named = record.get(entry)
        if (isinstance(named, dict) and named.get("sha256") == MODELS[kind].files[0][1]
                and isinstance(settings.get(section), dict)):
            settings[section]["model"] = str(MODELS[kind].path)
    replay = settings.get("detection", {}).get("file") if isinstance(settings.get("detection"), dict) else None
    if replay:
        log.warning("%s: its run read the detections of %s from %s, and so does this one (--det FILE reads "
                    "others)", source, record.get("sequence", "its sequence"), replay)
    if record["sotmot"] != __version__:
        log.warning("%s: written by sotmot %s, this is %s: settings this version added take their defaults, and "
                    "the results may differ", source, record["sotmot"], __version__)
    changed = environment_changes(record.get("environment"))
    if changed:
        log.warning("%s: its run had other library versions or another CPU (%s): a box may move and a close "
                    "decision flip", source, "; ".join(changed))
    return settings


def load_config(path: str | Path) -> TrackerConfig:
    """Read a TOML (``.toml``) or JSON (``.json``) configuration file, or the run record (``<name>.run.json``)
    ``sotmot track`` writes beside its results: the settings of that run (:func:`run_record_settings`)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: configuration file not found")
    try:
        if path.suffix == ".json":
            data = json.loads(path.read_text(encoding="utf-8-sig"), object_pairs_hook=_unique_keys)
        elif path.suffix == ".toml":
            data = tomllib.loads(path.read_text(encoding="utf-8-sig"))
        else:
            raise ConfigError("configuration must be a .toml or .json file")
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{path}: cannot be parsed: {exc}") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start}); save it as UTF-8") from exc
    if _is_run_record(data):
        log.info("%s: a run record; running with the settings of its run (%s)", path, data.get("sequence", "?"))
        data = run_record_settings(data, path)
    try:
        return config_from_dict(data)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
