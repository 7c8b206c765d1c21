"""Many sequences: parallel runs equal serial ones, failures stay local, --resume skips finished work."""

import shutil

import pytest

from conftest import DATA, require
from sotmot.cli import main


def test_parallel_equals_serial_and_a_failure_loses_nothing(tmp_path, model_0288, capsys):
    a = require(DATA / "MOT16-05-clip30")
    b = require(DATA / "MOT16-02-clip30")
    broken = tmp_path / "BROKEN"
    shutil.copytree(a, broken, ignore=shutil.ignore_patterns("img1"))
    (broken / "seqinfo.ini").write_text((a / "seqinfo.ini").read_text().replace("MOT16-05-clip30", "BROKEN"))
    common = ["--reid-model", str(model_0288), "-q"]
    assert main(["track", str(a), str(b), "--out", str(tmp_path / "serial"), *common]) == 0
    code = main(["track", str(a), str(broken), str(b), "--out", str(tmp_path / "par"), "--workers", "2", *common])
    err = capsys.readouterr().err
    assert code == 2 and "BROKEN" in err and "1 of 3 sequences failed" in err  # its frames are missing
    for name in ("MOT16-05-clip30", "MOT16-02-clip30"):
        assert (tmp_path / "par" / f"{name}.txt").read_text() == (tmp_path / "serial" / f"{name}.txt").read_text()
    assert not (tmp_path / "par" / "BROKEN.txt").exists()


def test_resume_skips_sequences_with_results(tmp_path, model_0288, capsys):
    a = require(DATA / "MOT16-05-clip30")
    out = tmp_path / "res"
    common = ["--out", str(out), "--reid-model", str(model_0288), "-q"]
    assert main(["track", str(a), *common]) == 0
    first = (out / "MOT16-05-clip30.txt").stat().st_mtime_ns
    capsys.readouterr()
    assert main(["track", str(a), "--resume", *common]) == 0
    assert "skipped (--resume)" in capsys.readouterr().out
    assert (out / "MOT16-05-clip30.txt").stat().st_mtime_ns == first


def test_dask_cluster_runs_the_same_jobs_and_keeps_failures_local(tmp_path, model_0288, capsys):
    # a LocalCluster on loopback stands in for a real cluster; frames are read by the worker processes
    distributed = pytest.importorskip("distributed")
    a = require(DATA / "MOT16-05-clip30")
    broken = tmp_path / "BROKEN"
    shutil.copytree(a, broken, ignore=shutil.ignore_patterns("img1"))
    (broken / "seqinfo.ini").write_text((a / "seqinfo.ini").read_text().replace("MOT16-05-clip30", "BROKEN"))
    common = ["--reid-model", str(model_0288), "-q"]
    assert main(["track", str(a), "--out", str(tmp_path / "serial"), *common]) == 0
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        url = "dask://" + cluster.scheduler_address.removeprefix("tcp://")
        out = tmp_path / "dask"
        code = main(["track", str(a), str(broken), "--out", str(out), "--cluster", url, *common])
        err = capsys.readouterr().err
        assert code == 2 and "BROKEN" in err and "1 of 2 sequences failed" in err
        assert (out / "MOT16-05-clip30.txt").read_text() == (tmp_path / "serial" / "MOT16-05-clip30.txt").read_text()
        assert not (out / "BROKEN.txt").exists()
        assert main(["track", str(a), "--out", str(out), "--cluster", url, "--resume", *common]) == 0
        assert "skipped (--resume)" in capsys.readouterr().out


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:8786", "dask://127.0.0.1", "dask://:8786", "dask://h:port"])
def test_malformed_cluster_addresses_are_refused(address):
    from sotmot.runs import dask_address
    from sotmot.errors import ConfigError

    with pytest.raises(ConfigError, match="dask://HOST:PORT"):
        dask_address(address)


def test_unreachable_scheduler_is_a_clear_error(tmp_path, model_0288, capsys):
    pytest.importorskip("distributed")
    import socket

    with socket.socket() as s:  # a loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    a = require(DATA / "MOT16-05-clip30")
    code = main(["track", str(a), "--out", str(tmp_path), "--cluster", f"dask://127.0.0.1:{port}",
                 "--reid-model", str(model_0288), "-q"])
    assert code == 2 and "cannot reach the Dask scheduler" in capsys.readouterr().err


def test_a_worker_that_dies_fails_its_own_sequence_only(tmp_path, monkeypatch, model_0288):
    """A crash in native code kills the worker process (here: os._exit); the other sequences still finish."""
    import os
    import sys

    from pathlib import Path

    if sys.platform != "linux":
        pytest.skip("relies on fork: the patched job reaches the workers")
    from conftest import GeometryEmbedder, write_sequence
    from sotmot import runs as batch
    from sotmot.config import TrackerConfig

    real = batch.track_one
    seqs = []
    for name in ("A", "CRASH", "B"):
        lines = [f"{f},-1,{10 + 2 * f},20,20,40,0.95" for f in range(1, 9)]
        seqs.append(write_sequence(tmp_path / name, lines, length=10, frame_rate=4, width=120, height=80, name=name))

    def crashing(seq_dir, *args, **kwargs):
        if seq_dir.endswith("CRASH"):
            os._exit(11)
        return real(seq_dir, *args, **kwargs)

    monkeypatch.setattr(batch, "track_one", crashing)
    monkeypatch.setattr(batch, "worker_embedder", lambda appearance: GeometryEmbedder())
    config = TrackerConfig().replace("confirm", enabled=False).replace("appearance", model=str(model_0288))
    outcomes = batch.track_many(seqs, tmp_path / "out", config, workers=2)
    by_name = {Path(o.seq_dir).name: o for o in outcomes}
    assert by_name["A"].status == "done" and by_name["B"].status == "done"
    assert by_name["CRASH"].status == "failed" and "worker process died" in by_name["CRASH"].message
