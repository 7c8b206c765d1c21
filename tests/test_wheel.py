"""``pip install`` as a user installs (issue #43): the wheel holds the models, the calibration and the licence,
installs no bare top-level ``solvers``, stays small, and from a fresh virtual environment, outside this
repository and with no model given, ``sotmot`` tracks a clip. Offline: the wheel is built with the setuptools
already installed, the new environment reaches its dependencies through this one's."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

from conftest import DATA, ROOT, require

pytestmark = pytest.mark.slow


def _run(*args, **kwargs) -> subprocess.CompletedProcess:
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True, **kwargs)
    assert done.returncode == 0, f"{args}: rc {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    pytest.importorskip("setuptools")
    src = tmp_path_factory.mktemp("src")
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for package in ("sotmot", "solvers"):
        shutil.copytree(ROOT / package, src / package, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    out = tmp_path_factory.mktemp("dist")
    _run(sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index", "--quiet",
         "--disable-pip-version-check", "-w", out, src)
    (found,) = out.glob("sotmot-*.whl")
    return found


def test_the_wheel_holds_models_calibration_licence_and_every_package(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    from sotmot.models import LICENCE_FILE, MODELS

    for model in MODELS.values():
        for name, _ in model.files:
            assert f"sotmot/models/{name}" in names
    assert f"sotmot/models/{LICENCE_FILE}" in names and "sotmot/data/confidence.json" in names
    packages = {str(p.parent.relative_to(ROOT)).replace(os.sep, "/") for p in (ROOT / "sotmot").rglob("__init__.py")}
    for package in packages:
        assert f"{package}/__init__.py" in names, f"{package} is missing from the wheel"
    assert "sotmot/solvers/greedy.py" in names and "sotmot/solvers/__init__.py" in names
    top = {name.split("/")[0] for name in names}
    assert top == {"sotmot", f"{wheel.name.split('-')[0]}-{wheel.name.split('-')[1]}.dist-info"}, top
    assert wheel.stat().st_size < 10e6, f"{wheel.stat().st_size / 1e6:.1f} MB"


def test_installed_from_the_wheel_it_tracks_a_clip_with_nothing_given(wheel, tmp_path):
    clip = require(DATA / "MOT16-02-clip30")
    venv = tmp_path / "venv"
    _run(sys.executable, "-m", "venv", "--without-pip", venv)
    python = venv / "bin" / "python"
    site = Path(_run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])").stdout.strip())
    # the dependencies, already installed here, reached through a path file (pip cannot fetch them offline)
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run(sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index", "--quiet",
         "--disable-pip-version-check", wheel)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SOTMOT_", "PYTHON"))}
    where = _run(python, "-c", "import sotmot.models, sotmot.solvers; print(sotmot.models.HERE)", cwd=tmp_path,
                 env=env).stdout.strip()
    assert Path(where).is_relative_to(venv), where
    assert _run(venv / "bin" / "sotmot", "--version", cwd=tmp_path, env=env).stdout.startswith("sotmot 0.1.0")
    _run(venv / "bin" / "sotmot", "models", cwd=tmp_path, env=env)
    _run(venv / "bin" / "sotmot", "track", clip, "--out", "r", "-q", cwd=tmp_path, env=env)
    results = (tmp_path / "r" / "MOT16-02-clip30.txt").read_text()
    assert len(results.splitlines()) > 100
    record = (tmp_path / "r" / "MOT16-02-clip30.run.json").read_text()
    assert str(venv) in record and "person-reidentification-retail-0288.onnx" in record
