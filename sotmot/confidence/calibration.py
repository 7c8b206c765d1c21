"""The calibration: everything fitted once on training sequences (``scripts/fit_confidence.py``), read from
``sotmot/data/confidence.json`` or a file the configuration names: the detector families' score maps, the
confirmation models and their thresholds."""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from sotmot.confidence.box_model import BoxModel
from sotmot.errors import ConfigError

#: Families whose confirmation model and threshold are their own (fitted on that detector's runs only); the
#: public detectors' families share the ``"calibrated"`` model.
OWN_MODELS = ("pd0202",)


def model_kind(method: str) -> str:
    """Which box model serves detections whose confidence came from ``method`` (a resolved method).

    Quantile confidences are ranks, not probabilities, so they get a model of
    their own (``"quantile"``); the families of :data:`OWN_MODELS` have theirs
    too; the other family maps and raw probabilities share ``"calibrated"``.
    """
    if method in OWN_MODELS:
        return method
    return "quantile" if method == "quantile" else "calibrated"  # "self" maps are probabilities too


@dataclass(frozen=True)
class Calibration:
    """Everything fitted once on training sequences: per-family score maps and the box models.

    Attributes
    ----------
    families
        Family name -> ``(scores, confidences)`` knots of a monotone map.
    box_models
        :func:`model_kind` -> the confirmation model for confidences of that kind.
    thresholds
        :func:`model_kind` -> the fitted confirmation threshold (``[confirm]
        threshold`` defaults to it).
    provenance
        What it was fitted on, by which script and how (free text and numbers).
    """

    families: dict[str, tuple[tuple[float, ...], tuple[float, ...]]]
    box_models: dict[str, BoxModel]
    thresholds: dict[str, float]
    provenance: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"families": {k: {"scores": list(v[0]), "confidence": list(v[1])} for k, v in self.families.items()},
                "box_models": {k: m.to_dict() for k, m in self.box_models.items()},
                "thresholds": dict(self.thresholds), "provenance": self.provenance}

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "calibration") -> "Calibration":
        """Read :meth:`to_dict`'s form."""
        try:
            families = {k: (tuple(map(float, v["scores"])), tuple(map(float, v["confidence"])))
                        for k, v in data["families"].items()}
            models = {k: BoxModel.from_dict(m, source) for k, m in data["box_models"].items()}
            thresholds = {k: float(v) for k, v in data["thresholds"].items()}
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ConfigError(f"{source}: not a sotmot confidence calibration ({exc!r})") from exc
        needed = {"calibrated", "quantile"} | {f for f in OWN_MODELS if f in families}  # a map needs its model
        missing = sorted(needed - set(models) | needed - set(thresholds))
        if missing:
            raise ConfigError(f"{source}: no box model or threshold for {', '.join(missing)}")
        return cls(families, models, thresholds, dict(data.get("provenance", {})))


def load_calibration(path: str | Path | None = None) -> Calibration:
    """The calibration in ``path`` (JSON from ``scripts/fit_confidence.py``), or the packaged one.

    Read once per file version (the pipeline asks for it at several stages).
    """
    if path is None:
        return _packaged()
    path = Path(path)
    try:
        st = path.stat()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the confidence calibration: {exc.strerror}") from exc
    return _read_calibration(str(path.resolve()), st.st_size, st.st_mtime_ns)


@lru_cache(maxsize=8)
def _read_calibration(path: str, size: int, mtime_ns: int) -> Calibration:
    try:
        return Calibration.from_dict(json.loads(Path(path).read_text(encoding="utf-8")), path)
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read the confidence calibration: {exc}") from exc


@lru_cache(maxsize=1)
def _packaged() -> Calibration:
    text = resources.files("sotmot").joinpath("data", "confidence.json").read_text(encoding="utf-8")
    return Calibration.from_dict(json.loads(text), "sotmot/data/confidence.json")
