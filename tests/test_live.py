"""``sotmot track --live``: a camera, a stream or a video read once as it plays, tracked in committed windows,
its final boxes appended as they come. A video read live gives the results file of ``sotmot track VIDEO
--window`` byte for byte; a run stopped keeps what was final and its record says how far; a run stopped before
anything was final leaves nothing; flags that cannot go with a live source are refused before anything opens."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from sotmot.cli import main
from sotmot.io.video import live_name

from conftest import DATA, require, write_video

#: Windows of 15 frames overlapping by 6 at 30 fps (as tests/test_stream.py): the 30-frame clip in three.
SMALL = '[association]\nl_max_seconds = 0.2\n[windows]\nseconds = 0.5\n'


def _clip_video(path):
    import cv2

    frames = sorted((require(DATA / "MOT16-02-clip30") / "img1").glob("*.jpg"))
    first = cv2.imread(str(frames[0]))
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (first.shape[1], first.shape[0]))
    for f in frames:
        writer.write(cv2.imread(str(f)))
    writer.release()
    return path


def test_a_video_read_live_gives_the_windowed_results_and_a_record_that_repeats_it(tmp_path, capsys):
    video = _clip_video(tmp_path / "street.avi")
    (tmp_path / "small.toml").write_text(SMALL)
    config = str(tmp_path / "small.toml")
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "live"), "--config", config, "-q"]) == 0
    assert "street: 30 frames (1 s at 30 frames/s) in windows of 0.5 s" in capsys.readouterr().out
    assert main(["track", str(video), "--out", str(tmp_path / "file"), "--config", config, "-q"]) == 0
    for name in ("street.txt", "street.flags.csv", "street.det.txt"):  # det.txt: the detector's boxes
        assert (tmp_path / "live" / name).read_bytes() == (tmp_path / "file" / name).read_bytes()
    assert len((tmp_path / "live" / "street.txt").read_text().splitlines()) > 100
    record = json.loads((tmp_path / "live" / "street.run.json").read_text())
    assert record["live"] == {"frames_final": 30, "complete": True,
                              "bytes": {n: (tmp_path / "live" / n).stat().st_size
                                        for n in ("street.txt", "street.flags.csv", "street.det.txt")}}
    assert record["inputs"]["live"] == {"source": str(video), "frame_rate": 30.0}
    assert record["inputs"]["detections"]["source"] == "model" and record["detector_model"]["sha256"]
    from sotmot.hashing import file_sha256

    assert record["results_sha256"] == file_sha256(tmp_path / "live" / "street.txt")
    # the record is a configuration: the same run again
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "again"), "-q",
                 "--config", str(tmp_path / "live" / "street.run.json")]) == 0
    assert (tmp_path / "again" / "street.txt").read_bytes() == (tmp_path / "live" / "street.txt").read_bytes()
    # but never into the folder of the record it reads, over it
    before = (tmp_path / "live" / "street.run.json").read_bytes()
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "live"), "-q",
                 "--config", str(tmp_path / "live" / "street.run.json")]) == 2
    assert "would write over" in capsys.readouterr().err
    assert (tmp_path / "live" / "street.run.json").read_bytes() == before


def test_a_video_read_live_at_every_2nd_frame_gives_what_the_file_gives_and_every_frame(tmp_path, capsys):
    video = _clip_video(tmp_path / "street.avi")
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "live"), "--step", "2", "-q"]) == 0
    assert main(["track", str(video), "--out", str(tmp_path / "file"), "--step", "2", "-q"]) == 0
    for name in ("street.txt", "street.flags.csv", "street.det.txt"):
        assert (tmp_path / "live" / name).read_bytes() == (tmp_path / "file" / name).read_bytes()
    frames = {int(line.split(",")[0]) for line in (tmp_path / "live" / "street.txt").read_text().splitlines()}
    assert {2, 14, 28, 30} <= frames  # frame 30 comes after the last tracked one, 29: its boxes held there
    record = json.loads((tmp_path / "live" / "street.run.json").read_text())
    assert record["live"]["frames_final"] == 30 and record["config"]["input"]["step"] == 2


def _parts(n_parts: int, then: BaseException | None, pause: float = 0.0):
    """A stand-in for sotmot.stream: ``n_parts`` parts of 10 frames (two boxes a frame), each ``pause`` seconds
    after the one before, then ``then`` raised (None: the stream ends)."""
    from sotmot.api import Committed
    from sotmot.types import Tracks

    def stream(frames, detections=None, **kwargs):
        for k in range(n_parts):
            f = np.repeat(np.arange(10 * k + 1, 10 * k + 11), 2)
            tracks = Tracks(frames=f, ids=np.tile([1, 2], 10), boxes=np.tile([[10.0, 20, 30, 60]], (20, 1)),
                            scores=np.full(20, 0.9), interpolated=np.zeros(20, bool), from_sot=np.zeros(20, bool),
                            confidence=np.full(20, 0.9))
            time.sleep(pause)
            yield Committed(10 * k + 1, 10 * k + 10, tracks, Tracks.empty())
        if then is not None:
            raise then

    return stream


def test_a_live_run_stopped_keeps_what_is_final_and_says_how_far(tmp_path, monkeypatch, capsys):
    import sotmot.api

    video = write_video(tmp_path / "cam.avi", n=5)
    monkeypatch.setattr(sotmot.api, "stream", _parts(2, KeyboardInterrupt()))
    out = tmp_path / "out"
    assert main(["track", "--live", str(video), "--out", str(out), "-q"]) == 130
    assert "frames 1-20 are final" in capsys.readouterr().err
    lines = (out / "cam.txt").read_text().splitlines()
    assert len(lines) == 40 and lines[-1].startswith("20,2,")
    record = json.loads((out / "cam.run.json").read_text())
    assert record["live"]["frames_final"] == 20 and record["live"]["complete"] is False
    assert record["live"]["stopped"] == "interrupted" and record["results_sha256"] is None
    assert record["live"]["bytes"]["cam.txt"] == (out / "cam.txt").stat().st_size

    from sotmot.errors import InputError

    monkeypatch.setattr(sotmot.api, "stream", _parts(1, InputError("cam", "frame 11 is 640 x 480, not 120 x 80")))
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "failed"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "frame 11 is 640 x 480" in err and "frames 1-10 are final" in err
    assert json.loads((tmp_path / "failed" / "cam.run.json").read_text())["live"]["stopped"].startswith("failed")


@pytest.mark.parametrize("then, code", [(KeyboardInterrupt(), 130), (None, 2)])
def test_a_live_run_stopped_before_anything_is_final_leaves_nothing(tmp_path, monkeypatch, then, code):
    import sotmot.api
    from sotmot.errors import InputError

    video = write_video(tmp_path / "cam.avi", n=5)
    monkeypatch.setattr(sotmot.api, "stream", _parts(0, then or InputError("cam", "no frames")))
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "out"), "-q"]) == code
    assert not (tmp_path / "out").exists()  # made by this run, nothing written: gone again
    (tmp_path / "kept").mkdir()
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "kept"), "-q"]) == code
    assert (tmp_path / "kept").is_dir() and not any((tmp_path / "kept").iterdir())  # not made here: kept


@pytest.mark.parametrize("argv, message", [
    (["--live", "VIDEO", "SEQ"], "not with SEQ_DIR"),
    (["--live", "VIDEO", "--eval"], "not with --eval"),
    (["--live", "VIDEO", "--resume", "--workers", "2"], "not with --resume, --workers"),
    (["--live", "VIDEO", "--detections", "file"], "a live source has no det.txt"),
    (["--live", "VIDEO", "--det", "d.txt", "--detections", "model"], "choose one"),
    (["--live", "missing.avi"], "missing.avi: not found: a live source is a camera's number"),
    (["rtsp://10.0.0.5/live"], "rtsp://10.0.0.5/live: a stream is tracked with --live URL"),
    ([], "nothing to track"),
])
def test_what_cannot_be_tracked_live_is_said_before_anything_opens(tmp_path, capsys, argv, message):
    video = write_video(tmp_path / "cam.avi", n=5)
    argv = [str(video) if a == "VIDEO" else str(tmp_path / a) if a in ("SEQ", "missing.avi") else a for a in argv]
    assert main(["track", *argv, "--out", str(tmp_path / "out"), "-q"]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("source, name, said", [
    ("0", "camera0", "0"), ("12", "camera12", "12"),
    ("rtsp://10.0.0.5:554/live/ch1?tcp", "10.0.0.5-554-live-ch1", "rtsp://10.0.0.5:554/live/ch1?tcp"),
    ("rtsp://admin:s3cret@10.0.0.5/live", "10.0.0.5-live", "rtsp://admin:***@10.0.0.5/live"),
    ("http://viewer@cam.local/video.mjpg", "cam.local-video.mjpg", "http://viewer@cam.local/video.mjpg"),
    ("http://cam.local/a@b", "cam.local-a-b", "http://cam.local/a@b"),
    ("/videos/street.mp4", "street", "/videos/street.mp4"),
])
def test_a_live_source_names_its_results_and_never_says_its_password(source, name, said):
    from sotmot.io.video import shown

    assert live_name(source) == name and shown(source) == said


def test_a_stream_over_http_is_tracked_as_the_file_it_serves(tmp_path, capsys):
    """A URL goes to OpenCV as it is (its FFmpeg reads http://, rtsp://, ...): a local web server's copy of a
    video gives the file's results, under a name made of the host and path."""
    import functools
    import http.server
    import threading

    video = write_video(tmp_path / "cam.avi", n=40)
    det = tmp_path / "det.txt"  # the dark block write_video draws
    det.write_text("".join(f"{f},-1,{10 + 3 * f},20,20,40,0.9\n" for f in range(1, 41)))
    flags = ["--appearance", "none", "--det", str(det), "-q"]
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(tmp_path))
    handler.log_message = lambda *args: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/cam.avi"
        code = main(["track", "--live", url, "--out", str(tmp_path / "net"), *flags])
    finally:
        server.shutdown()
    if code == 2 and "OpenCV cannot open" in capsys.readouterr().err:
        pytest.skip("this OpenCV build reads no http:// stream")
    assert code == 0
    assert main(["track", "--live", str(video), "--out", str(tmp_path / "file"), *flags]) == 0
    name = f"127.0.0.1-{server.server_address[1]}-cam.avi"
    got = (tmp_path / "net" / f"{name}.txt").read_text()
    assert len(got.splitlines()) >= 30 and got == (tmp_path / "file" / "cam.txt").read_text()
    record = json.loads((tmp_path / "net" / f"{name}.run.json").read_text())
    assert record["inputs"]["live"]["source"] == url and record["live"]["complete"]


def test_a_camera_the_tracker_cannot_keep_up_with_is_said_and_recorded(tmp_path, monkeypatch, caplog):
    """Frames final more than two windows after they came: a warning, and ``behind`` in the run record (a
    camera's frames at 1,000 a second, parts of 10 frames each 0.05 s apart, windows of 0.01 s)."""
    import sotmot.api
    import sotmot.live

    monkeypatch.setattr(sotmot.api, "stream", _parts(3, None, pause=0.05))
    monkeypatch.setattr(sotmot.live, "open_live", lambda source, fps: (iter([]), 1000.0, "camera0"))
    with caplog.at_level("WARNING"):
        assert main(["track", "--live", "0", "--out", str(tmp_path), "--window", "0.01", "-q"]) == 0
    live = json.loads((tmp_path / "camera0.run.json").read_text())["live"]
    assert live["behind"] is True and live["late_s"] > 0.02 and live["complete"]
    assert "tracking is slower than the source" in caplog.text
