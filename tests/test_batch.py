"""Many sequences: parallel runs equal serial ones, failures stay local, --resume skips finished work."""

import shutil

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
