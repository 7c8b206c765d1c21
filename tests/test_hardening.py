"""Regression tests of the hardening issue (#14): each failed on main before its fix."""

from __future__ import annotations

import argparse

import pytest

from conftest import GeometryEmbedder, write_sequence
from sotmot.config import TrackerConfig, load_config
from sotmot.errors import ConfigError, EvaluationError, InputError
from sotmot.io import read_detections, read_seqinfo, results_path


@pytest.mark.parametrize("name", ["../../x", "/tmp/x", "a/b", "..", ".", "", "a\\b"])
def test_sequence_name_that_would_escape_out_is_refused_with_its_line(tmp_path, name):
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False)
    text = (seq / "seqinfo.ini").read_text().replace("name=SYN", f"name={name}")
    (seq / "seqinfo.ini").write_text(text)
    with pytest.raises(InputError, match="plain file name") as err:
        read_seqinfo(seq)
    assert err.value.line == 2 or name == ""


def test_results_path_refuses_a_name_with_a_separator(tmp_path):
    with pytest.raises(InputError, match="outside this folder"):
        results_path(tmp_path, "../evil")
    assert results_path(tmp_path, "MOT16-09") == tmp_path / "MOT16-09.txt"


def test_track_never_writes_outside_out(tmp_path):
    from sotmot.batch import track_one

    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=True)
    (seq / "seqinfo.ini").write_text((seq / "seqinfo.ini").read_text().replace("name=SYN", "name=../escaped"))
    outcome = track_one(str(seq), str(tmp_path / "out"), TrackerConfig(), "greedy", False,
                        embedder=GeometryEmbedder())
    assert outcome.status == "failed" and "plain file name" in outcome.message
    assert not (tmp_path / "escaped.txt").exists() and not (tmp_path / "escaped.flags.csv").exists()


def test_evaluation_refuses_names_with_separators(tmp_path):
    from sotmot.evaluate import evaluate_files

    with pytest.raises(EvaluationError, match="plain file names"):
        evaluate_files([(tmp_path / "r.txt", tmp_path / "gt.txt", 5, "../x")])


def test_percent_in_seqinfo_is_a_character(tmp_path):
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False)
    (seq / "seqinfo.ini").write_text((seq / "seqinfo.ini").read_text() + "comment=100% real\n")
    assert read_seqinfo(seq).name == "SYN"


def test_utf8_bom_is_tolerated_in_seqinfo_det_and_config(tmp_path):
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9", "2,-1,10,10,5,8,0.8"], images=False)
    for path in (seq / "seqinfo.ini", seq / "det" / "det.txt"):
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    info = read_seqinfo(seq)
    assert len(read_detections(info.det_path, info.length)) == 2
    config = tmp_path / "c.toml"
    config.write_bytes(b"\xef\xbb\xbf[association]\nl_max = 45\n")
    assert load_config(config).association.l_max == 45


def test_non_utf8_config_is_one_clear_error(tmp_path):
    config = tmp_path / "c.toml"
    config.write_bytes(b"[association]\n# caf\xe9\nl_max = 45\n")
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_config(config)


def test_workers_must_be_positive(capsys):
    from sotmot.cli import main

    with pytest.raises(SystemExit):
        main(["track", "x", "--out", "y", "--workers", "0"])
    assert "must be at least 1" in capsys.readouterr().err


def test_progress_bars_only_on_a_terminal(monkeypatch):
    import sys

    from sotmot.cli import _progress

    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    assert not _progress(argparse.Namespace(quiet=False))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert _progress(argparse.Namespace(quiet=False)) and not _progress(argparse.Namespace(quiet=True))
