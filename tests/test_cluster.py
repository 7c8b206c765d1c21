"""`track --cluster` against a real Dask scheduler and two workers started as processes on the loopback address
(issue #27): byte-identical to a serial run however the model is given, and a killed worker loses nothing.

The scheduler and workers are started without SOTMOT_REID_MODEL in their environment, as on machines of their
own; every process is bounded in time and stopped by the fixture.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from conftest import DATA, require
from sotmot.cli import main

pytestmark = pytest.mark.slow
START_SECONDS = 60


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def cluster(tmp_path):
    """``(address, {worker name: process})`` of a scheduler and two single-thread workers on 127.0.0.1."""
    distributed = pytest.importorskip("distributed")
    env = {k: v for k, v in os.environ.items() if k not in ("SOTMOT_REID_MODEL", "SOTMOT_DETECTOR_MODEL")}
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = tmp_path / "dask-logs"
    logs.mkdir()
    procs: dict[str, subprocess.Popen] = {}

    def start(name: str, *args: str) -> None:
        with open(logs / f"{name}.log", "w") as log:
            procs[name] = subprocess.Popen([sys.executable, "-m", *args], env=env, stdout=log, stderr=log,
                                           start_new_session=True)

    try:
        start("scheduler", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
              "--no-dashboard")
        for k in range(2):
            start(f"w{k}", "distributed.cli.dask_worker", address, "--nthreads", "1", "--nworkers", "1",
                  "--host", "127.0.0.1", "--no-dashboard", "--name", f"w{k}", "--death-timeout", "60")
        with distributed.Client(address, timeout=f"{START_SECONDS}s") as client:
            client.wait_for_workers(2, timeout=START_SECONDS)
        yield address, {k: v for k, v in procs.items() if k != "scheduler"}
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
        for proc in procs.values():
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(10)


def _outputs(folder, names):
    return {f"{n}{suffix}": (folder / f"{n}{suffix}").read_bytes() for n in names for suffix in (".txt", ".flags.csv")}


CLIPS = ("MOT16-05-clip30", "MOT16-02-clip30")


def test_cluster_results_equal_serial_with_the_model_given_each_way(tmp_path, cluster, model_0288, monkeypatch,
                                                                   capsys):
    address, _ = cluster
    url = "dask://" + address.removeprefix("tcp://")
    seqs = [str(require(DATA / c)) for c in CLIPS]
    monkeypatch.delenv("SOTMOT_REID_MODEL", raising=False)
    assert main(["track", *seqs, "--out", str(tmp_path / "serial"), "--reid-model", str(model_0288), "-q"]) == 0
    serial = _outputs(tmp_path / "serial", CLIPS)
    config = tmp_path / "model.toml"
    config.write_text(f'[appearance]\nmodel = "{model_0288}"\n')
    ways = {"flag": ["--reid-model", str(model_0288)], "config": ["--config", str(config)], "environment": []}
    for way, extra in ways.items():
        if way == "environment":  # on the client only: the workers were started without it
            monkeypatch.setenv("SOTMOT_REID_MODEL", str(model_0288))
        out = tmp_path / way
        assert main(["track", *seqs, "--out", str(out), "--cluster", url, "-q", *extra]) == 0, \
            capsys.readouterr().err
        assert _outputs(out, CLIPS) == serial, f"model given by {way}: cluster results differ from serial"


def test_a_failure_on_a_worker_names_the_worker(tmp_path, cluster, model_0288, capsys):
    import shutil

    address, _ = cluster
    broken = tmp_path / "BROKEN"
    shutil.copytree(require(DATA / "MOT16-05-clip30"), broken, ignore=shutil.ignore_patterns("img1"))
    (broken / "seqinfo.ini").write_text((broken / "seqinfo.ini").read_text().replace("MOT16-05-clip30", "BROKEN"))
    code = main(["track", str(broken), "--out", str(tmp_path / "out"), "--cluster",
                 "dask://" + address.removeprefix("tcp://"), "--reid-model", str(model_0288), "-q"])
    assert code == 2 and "(on Dask worker tcp://127.0.0.1:" in capsys.readouterr().err


def test_a_worker_killed_mid_sequence_loses_nothing(tmp_path, cluster, model_0288):
    distributed = pytest.importorskip("distributed")
    address, workers = cluster
    seqs = [str(require(DATA / c)) for c in CLIPS]
    common = ["--reid-model", str(model_0288), "-q"]
    assert main(["track", *seqs, "--out", str(tmp_path / "serial"), *common]) == 0
    out = tmp_path / "cluster"
    codes = []
    run = threading.Thread(target=lambda: codes.append(main(
        ["track", *seqs, "--out", str(out), "--cluster", "dask://" + address.removeprefix("tcp://"), *common])))
    killed = None
    with distributed.Client(address, timeout="30s") as client:
        run.start()
        deadline = time.monotonic() + START_SECONDS
        while killed is None and time.monotonic() < deadline:
            busy = [addr for addr, keys in client.processing().items() if keys]
            if busy:  # a sequence is being tracked there: end that worker's process group now
                name = client.scheduler_info()["workers"][busy[0]]["name"]
                os.killpg(workers[name].pid, signal.SIGKILL)
                killed = name
            time.sleep(0.05)
        run.join(240)
    assert killed is not None, "no worker ever held a sequence"
    assert not run.is_alive() and codes == [0]
    assert _outputs(out, CLIPS) == _outputs(tmp_path / "serial", CLIPS)
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == []  # no half-written file


def test_the_windows_of_one_sequence_spread_over_the_cluster_equal_the_serial_run(cluster, tmp_path):
    from conftest import write_sequence

    address, _ = cluster
    lines = [f"{f},-1,{10 + 3 * f},20,30,60,0.9" for f in range(1, 121) if not 50 <= f <= 56]
    seq = write_sequence(tmp_path, lines, length=120, frame_rate=5, width=800, height=240, images=False)
    common = ["--appearance", "none", "--unconfirmed", "keep", "--window", "8", "-q"]
    assert main(["track", str(seq), "--out", str(tmp_path / "serial"), *common]) == 0
    url = "dask://" + address.removeprefix("tcp://")
    assert main(["track", str(seq), "--out", str(tmp_path / "dask"), "--cluster", url, *common]) == 0
    assert (tmp_path / "dask" / "SYN.txt").read_bytes() == (tmp_path / "serial" / "SYN.txt").read_bytes()
    record = (tmp_path / "dask" / "SYN.run.json").read_text()
    assert '"complete": true' in record
