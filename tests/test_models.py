"""The bundled models (issue #43): the defaults with nothing given, checked against their SHA-256, replaced by
a flag, the config or an environment variable, and one clear error when a bundled file is changed or cut."""

from __future__ import annotations

import hashlib
import json
import shutil

import pytest

import sotmot.models as models
from sotmot.cli import main
from sotmot.errors import ModelError

from conftest import MODEL_0288


@pytest.fixture
def no_model_variables(monkeypatch):
    for model in models.MODELS.values():
        monkeypatch.delenv(model.env_var, raising=False)


@pytest.fixture
def bundled_copy(tmp_path, monkeypatch):
    """The bundled files copied into a folder the test may spoil, and the package pointed at it."""
    folder = tmp_path / "models"
    shutil.copytree(models.HERE, folder, ignore=shutil.ignore_patterns("*.py", "__pycache__"))
    monkeypatch.setattr(models, "HERE", folder)
    models._checked.cache_clear()
    yield folder
    models._checked.cache_clear()


def test_the_table_holds_the_hash_of_every_shipped_file():
    shipped = sorted(p.name for p in models.HERE.iterdir() if p.suffix in (".onnx", ".xml", ".bin"))
    listed = sorted(name for model in models.MODELS.values() for name, _ in model.files)
    assert shipped == listed
    for model in models.MODELS.values():
        for name, digest in model.files:
            assert hashlib.sha256((models.HERE / name).read_bytes()).hexdigest() == digest, name
    assert (models.HERE / models.LICENCE_FILE).read_text().lstrip().startswith("Apache License")


def test_the_bundled_models_are_the_shared_ones_byte_for_byte():
    """Results with the bundled models equal today's with the shared ones because the bytes are the same."""
    if not MODEL_0288.is_file():
        pytest.skip(f"{MODEL_0288} not found")
    assert models.MODELS["reid"].path.read_bytes() == MODEL_0288.read_bytes()
    shared = MODEL_0288.parent / "person-detection-0202"
    for name, _ in models.MODELS["detector"].files:
        assert (models.HERE / name).read_bytes() == (shared / name).read_bytes(), name


def test_nothing_given_runs_the_bundled_models(no_model_variables):
    from sotmot.appearance.base import resolve_model_path
    from sotmot.detection import resolve_detector_path

    assert resolve_model_path(None) == models.MODELS["reid"].path
    assert resolve_detector_path(None) == models.MODELS["detector"].path


def test_a_flag_or_variable_replaces_the_bundled_model(tmp_path, monkeypatch, no_model_variables):
    from sotmot.appearance.base import resolve_model_path

    mine = tmp_path / "mine.onnx"
    mine.write_bytes(b"x")
    assert resolve_model_path(str(mine)) == mine
    monkeypatch.setenv("SOTMOT_REID_MODEL", str(mine))
    assert resolve_model_path(None) == mine
    with pytest.raises(ModelError, match=r"person re-ID model not found: .*gone.onnx.*--reid-model"):
        resolve_model_path(str(tmp_path / "gone.onnx"))


@pytest.mark.parametrize("spoil", ["changed", "truncated", "missing"])
def test_a_spoiled_bundled_file_is_one_clear_error_naming_it(bundled_copy, no_model_variables, spoil, capsys):
    from sotmot.detection import resolve_detector_path

    weights = bundled_copy / "person-detection-0202.FP16-INT8.bin"
    data = weights.read_bytes()
    if spoil == "changed":
        weights.write_bytes(data[:100] + bytes([data[100] ^ 1]) + data[101:])
    elif spoil == "truncated":
        weights.write_bytes(data[: len(data) // 2])
    else:
        weights.unlink()
    with pytest.raises(ModelError, match=r"bundled person detector file is (changed or truncated|missing): .*\.bin"):
        resolve_detector_path(None)
    assert main(["models"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "person-detection-0202.FP16-INT8.bin" in err
    assert "reinstall sotmot" in err


def test_models_command_lists_origin_licence_size_and_hash(no_model_variables, capsys):
    assert main(["models"]) == 0
    out = capsys.readouterr().out
    for model in models.MODELS.values():
        for name, digest in model.files:
            assert digest in out and name in out
    assert "Apache-2.0" in out and "Open Model Zoo" in out
    assert main(["models", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [row["kind"] for row in rows] == ["reid", "detector"]
    assert rows[0]["in_use"] == str(models.MODELS["reid"].path) and rows[1]["bytes"] > 2_000_000
