"""``sotmot.stream``: a one-pass stream of frames tracked in committed windows gives, part by part, the tracks
``sotmot.track`` gives with the same windows; it reads its frames in a thread of its own while windows are
tracked, never more than a window ahead (two windows of frames on disk at most), raises its source's errors, and
says what is wrong with its input before it reads a frame."""

from __future__ import annotations

import tempfile
import time

import numpy as np
import pytest

import sotmot
from sotmot.errors import ConfigError, InputError
from sotmot.types import Tracks

from conftest import DATA, require

CLIP = DATA / "MOT16-02-clip30"
#: Windows of 15 frames overlapping by 6 at 30 fps: the 30-frame clip in three.
SMALL = {"association": {"l_max_seconds": 0.2}, "windows": {"seconds": 0.5}}


def _clip(n: int) -> tuple[list[np.ndarray], np.ndarray]:
    import cv2

    seq = require(CLIP)
    frames = [cv2.imread(str(p)) for p in sorted((seq / "img1").glob("*.jpg"))[:n]]
    det = np.loadtxt(seq / "det" / "det.txt", delimiter=",", ndmin=2)[:, [0, 2, 3, 4, 5, 6]]
    return frames, det[det[:, 0] <= n]


def _same(a: Tracks, b: Tracks) -> bool:
    return all(np.array_equal(x, y) for x, y in ((a.frames, b.frames), (a.ids, b.ids), (a.boxes, b.boxes),
                                                 (a.scores, b.scores)))


@pytest.mark.parametrize("n, parts", [(30, [(1, 12), (13, 21), (22, 30)]), (24, [(1, 12), (13, 24)]),
                                      (15, [(1, 15)])])
def test_a_stream_gives_the_windowed_tracks_part_by_part(n, parts):
    frames, det = _clip(n)
    got = list(sotmot.stream((f for f in frames), det, frame_rate=30, config=SMALL, name="MOT16-02"))
    assert [(p.first, p.last) for p in got] == parts  # consecutive, from frame 1 to the stream's last
    for p in got:
        assert ((p.tracks.frames >= p.first) & (p.tracks.frames <= p.last)).all() and p.detected is None
    whole = sotmot.track(frames, det, frame_rate=30, config=SMALL, name="MOT16-02")
    assert _same(Tracks.concatenate([p.tracks for p in got]), whole.tracks)
    assert _same(Tracks.concatenate([p.dropped for p in got]), whole.dropped)
    assert len(whole.tracks) > 100 and len({*whole.tracks.ids}) > 5


def test_a_stream_without_detections_runs_the_detector_on_each_window():
    frames, _ = _clip(20)
    got = list(sotmot.stream(iter(frames), frame_rate=30, config=SMALL))
    assert [(p.first, p.last) for p in got] == [(1, 12), (13, 20)]
    whole = sotmot.track(frames, frame_rate=30, config=SMALL)
    assert len(whole.tracks) and _same(Tracks.concatenate([p.tracks for p in got]), whole.tracks)
    for p in got:  # the detector's boxes of each part's own frames (sotmot track --live writes them)
        assert len(p.detected) and p.first <= p.detected.frames.min() and p.detected.frames.max() <= p.last


def test_a_stream_is_read_while_windows_are_tracked_and_keeps_two_windows_on_disk(tmp_path, monkeypatch):
    """Two walkers at 5 fps, 8-s windows (40 frames, overlapping by the 4-s gap, 20): the frames are read in a
    thread of their own while a window is tracked, up to a window ahead (frame start + 80), never further; each
    part comes out once its window's last frame and the next have come."""
    import sotmot.windows

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    det = np.array([(f, x0 + dx * f, y, 30, 60, 0.9) for f in range(1, 121)
                    for x0, dx, y in ((10, 3.0, 20), (400, -3.0, 120))])
    read, held, ahead = [], [], []

    def frames():
        for f in range(1, 121):
            held.append(len(list(tmp_path.glob("sotmot-stream-*/*.npy"))))
            read.append(f)
            yield np.full((240, 800, 3), 128, np.uint8)

    track_window = sotmot.windows.track_window

    def waiting(info, windows, k, *args, **kwargs):  # tracks once the reader has read all it may, or 20 s
        want, deadline = min(windows[k][0] + 80, 120), time.monotonic() + 20
        while len(read) < want and time.monotonic() < deadline:
            time.sleep(0.005)
        ahead.append(len(read) - windows[k][1])
        return track_window(info, windows, k, *args, **kwargs)

    monkeypatch.setattr(sotmot.windows, "track_window", waiting)
    config = {"windows": {"seconds": 8}, "appearance": {"backend": "none"}, "confirm": {"enabled": False}}
    parts = sotmot.stream(frames(), det, frame_rate=5, config=config)
    assert not read  # nothing is read before the first part is asked for
    seen = [(p.first, p.last, len(read)) for p in parts]
    # windows (1, 40), (21, 60), (41, 80), (61, 100), (81, 120), each read up to 80 frames past its start
    assert [(first, last) for first, last, _ in seen] == [(1, 30), (31, 50), (51, 70), (71, 90), (91, 120)]
    assert [n for *_, n in seen] == [81, 101, 120, 120, 120]
    assert ahead == [41, 41, 40, 20, 0]  # read while tracked: a window and a frame past the window's end
    assert max(held) <= 81  # two windows and a frame on disk at most
    assert not list(tmp_path.glob("sotmot-stream-*"))  # the spool is gone with the stream
    whole = sotmot.track([np.full((240, 800, 3), 128, np.uint8)] * 120, det, frame_rate=5, config=config)
    assert whole.tracks.n_tracks == 2 and len(whole.tracks) == 240


def test_a_stream_raises_its_sources_error_and_stops_reading_when_left():
    frames, det = _clip(30)

    def broken():
        yield from frames[:20]
        raise OSError("the camera is gone")

    with pytest.raises(OSError, match="the camera is gone"):
        list(sotmot.stream(broken(), det[det[:, 0] <= 20], frame_rate=30, config=SMALL))
    read = []

    def endless():
        while True:
            read.append(1)
            yield frames[0]

    parts = sotmot.stream(endless(), det[det[:, 0] <= 20], frame_rate=30, config=SMALL)
    assert next(parts).last == 12
    parts.close()  # the caller stops: the reader stops too
    n = len(read)
    time.sleep(0.2)
    assert len(read) == n <= 31


def test_a_streams_bad_input_is_an_error_before_a_frame_is_read(tmp_path):
    def never():
        raise AssertionError("a frame was read")
        yield

    with pytest.raises(InputError, match="row:2: box width and height must be positive"):
        sotmot.stream(never(), [[1, 10, 20, 30, 60, 0.9], [2, 10, 20, 0, 60, 0.8]], frame_rate=30)
    with pytest.raises(ConfigError, match="less than twice the overlap"):
        sotmot.stream(never(), frame_rate=30, config={"windows": {"seconds": 6}})
    with pytest.raises(ConfigError, match="frame_rate is needed"):
        sotmot.stream(never(), frame_rate=None)
    with pytest.raises(InputError, match="an iterable of images"):
        sotmot.stream(str(tmp_path / "video.mp4"), frame_rate=30)
    with pytest.raises(InputError, match="no frames"):
        list(sotmot.stream(iter([]), frame_rate=30))
    with pytest.raises(InputError, match="frame 1 is a float64 array"):
        list(sotmot.stream(iter([np.zeros((48, 64, 3))]), frame_rate=30))
    with pytest.raises(InputError, match=r"frame 1 is a path \('a.jpg'\), not an image"):
        list(sotmot.stream(iter(["a.jpg"]), frame_rate=30))
    with pytest.raises(InputError, match="frame 3 is None, not an image"):  # a failed cv2.imread on the way
        list(sotmot.stream(iter([np.zeros((48, 64, 3), np.uint8)] * 2 + [None]), frame_rate=30))


def test_detections_past_the_streams_end_are_an_error_when_it_ends():
    frames, det = _clip(30)
    with pytest.raises(InputError, match="frame 30 is past the stream's last frame, 20"):
        list(sotmot.stream(iter(frames[:20]), det, frame_rate=30, config=SMALL))
