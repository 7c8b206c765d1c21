"""The Python API (issue #43): ``sotmot.track`` on frames in memory, a folder and a video gives what
``sotmot track`` writes, byte for byte; its errors are sotmot's own; ``import sotmot`` stays light; and the
examples of docs/api.md run."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sotmot
from sotmot.cli import main
from sotmot.errors import ConfigError, InputError

from conftest import DATA, ROOT, require

CLIP = DATA / "MOT16-02-clip30"


class LazyFrames:
    """A sequence of frames decoded when indexed, as a user's frame store would be (PETS09 whole in memory
    would be a gigabyte)."""

    def __init__(self, paths):
        self.paths = paths

    def __len__(self):
        return len(self.paths)

    def __getitem__(self, k):
        import cv2

        return cv2.imread(str(self.paths[k]))


def _det_array(seq: Path) -> np.ndarray:
    return np.loadtxt(seq / "det" / "det.txt", delimiter=",", ndmin=2)[:, [0, 2, 3, 4, 5, 6]]


def _cli_results(seq: Path, out: Path, *extra: str) -> bytes:
    assert main(["track", str(seq), "--out", str(out), "-q", *extra]) == 0
    return next(p for p in out.glob("*.txt") if not p.name.endswith((".low.txt", ".det.txt"))).read_bytes()


def test_frames_in_memory_a_one_pass_iterable_and_the_folder_give_the_command_lines_results(tmp_path):
    import cv2

    seq = require(CLIP)
    expected = _cli_results(seq, tmp_path / "cli")
    frames = [cv2.imread(str(p)) for p in sorted((seq / "img1").glob("*.jpg"))]
    det = _det_array(seq)
    as_list = sotmot.track(frames, detections=det, frame_rate=30, name="MOT16-02")
    assert as_list.save(tmp_path / "list.txt").read_bytes() == expected
    assert all(f.flags.writeable for f in frames), "the caller's frames were made read-only"
    one_pass = sotmot.track((f for f in frames), detections=det, frame_rate=30)
    assert one_pass.save(tmp_path / "iter.txt").read_bytes() == expected
    folder = sotmot.track(str(seq))
    assert folder.save(tmp_path / "folder.txt").read_bytes() == expected
    assert folder.tracks.boxes.shape == (len(folder.tracks), 4) and folder.tracks.frames.min() >= 1
    as_file = sotmot.track(frames, detections=seq / "det" / "det.txt", frame_rate=30)
    assert as_file.save(tmp_path / "file.txt").read_bytes() == expected


@pytest.mark.slow
def test_pets09_from_a_frame_store_gives_the_command_lines_results(tmp_path):
    seq = require(DATA / "PETS09-S2L1")
    expected = _cli_results(seq, tmp_path / "cli")
    frames = LazyFrames(sorted((seq / "img1").glob("*.jpg")))
    result = sotmot.track(frames, detections=_det_array(seq), frame_rate=7)
    assert result.save(tmp_path / "api.txt").read_bytes() == expected


def test_a_video_tracked_by_the_api_as_by_the_command_line(tmp_path):
    """Video in, the bundled detector finding the people: the API, the command line and the video's frames
    held in memory agree."""
    import cv2

    seq = require(CLIP)
    video = tmp_path / "street.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10, (640, 360))
    for path in sorted((seq / "img1").glob("*.jpg"))[:12]:
        writer.write(cv2.resize(cv2.imread(str(path)), (640, 360), interpolation=cv2.INTER_AREA))
    writer.release()
    expected = _cli_results(video, tmp_path / "cli")
    assert len(expected) > 0
    result = sotmot.track(str(video))
    assert result.save(tmp_path / "api.txt").read_bytes() == expected
    capture, frames = cv2.VideoCapture(str(video)), []
    while True:
        ok, image = capture.read()
        if not ok:
            break
        frames.append(image)
    in_memory = sotmot.track(frames, frame_rate=10)
    assert in_memory.save(tmp_path / "frames.txt").read_bytes() == expected


def test_a_config_dict_reaches_the_tracker(tmp_path):
    seq = require(CLIP)
    result = sotmot.track(seq, config={"association": {"l_max_seconds": 3}, "confirm": {"enabled": False}})
    assert result.config.association.l_max_seconds == 3 and len(result.dropped) == 0
    toml = tmp_path / "c.toml"
    toml.write_text("[association]\nl_max_seconds = 3\n[confirm]\nenabled = false\n")
    assert sotmot.track(seq, config=toml).save(tmp_path / "a.txt").read_bytes() == \
        result.save(tmp_path / "b.txt").read_bytes()


def test_scores_of_a_result_a_file_and_a_folder_agree(tmp_path):
    seq = require(CLIP)
    result = sotmot.track(seq)
    saved = result.save(tmp_path / "r.txt")
    by_result = result.scores(gt=seq / "gt" / "gt.txt")
    assert sotmot.evaluate(saved, seq) == by_result == sotmot.evaluate(result.tracks, seq / "gt" / "gt.txt",
                                                                       length=30, name="MOT16-02")
    assert 0 < by_result["HOTA"] <= 100


@pytest.mark.parametrize("rows, message", [
    ([[1, 10, 20, 30, 60, 0.9], [2, 10, 20, 0, 60, 0.8]], r"detections row:2: box width and height must be positive"),
    ([[31, 10, 20, 30, 60, 0.9]], r"detections row:1: frame 31 is outside 1..30"),
    ([[1, 10, 20, 30, np.nan, 0.9]], r"detections row:1: column 6 is 'nan'"),
    ([[1, 10, 20, 30, 60]], r"must be an \(N, 6\) array"),
])
def test_bad_detections_are_one_error_naming_the_row(rows, message):
    with pytest.raises(InputError, match=message):
        sotmot.track(require(CLIP), detections=np.array(rows, dtype=float))


def test_bad_frames_and_settings_are_clear_errors(tmp_path):
    frame = np.zeros((48, 64, 3), np.uint8)
    det = np.array([[1, 10, 10, 10, 20, 0.9]])
    with pytest.raises(ConfigError, match="frame_rate is needed"):
        sotmot.track([frame], detections=det)
    with pytest.raises(InputError, match="frame 1 is a float64 array"):
        sotmot.track([frame.astype(float)], detections=det, frame_rate=5)
    with pytest.raises(InputError, match="frame 2 is a uint8 array of shape \\(10, 10, 3\\)"):
        sotmot.track([frame, np.zeros((10, 10, 3), np.uint8)], detections=np.vstack([det, det + [1, 0, 0, 0, 0, 0]]),
                     frame_rate=5,
                     config={"appearance": {"flip": False}})
    with pytest.raises(InputError, match="frame 3 is None, not an image"):  # a list with a failed cv2.imread in it
        sotmot.track([frame, frame, None], detections=det, frame_rate=5)
    with pytest.raises(InputError, match="frame 2 is None, not an image"):  # the same, read once from a generator
        sotmot.track((f for f in [frame, None]), detections=det, frame_rate=5)
    with pytest.raises(InputError, match="no frames"):
        sotmot.track([], detections=det, frame_rate=5)
    with pytest.raises(InputError, match="not found"):
        sotmot.track(tmp_path / "nowhere")
    with pytest.raises(ConfigError, match="does not apply to a folder"):
        sotmot.track(require(CLIP), frame_rate=25)
    with pytest.raises(ConfigError, match="unknown section"):
        sotmot.track(require(CLIP), config={"assoc": {}})


def test_save_never_writes_over_the_sequences_own_files(tmp_path):
    import shutil

    seq = Path(shutil.copytree(require(CLIP), tmp_path / "seq"))
    result = sotmot.track(seq)
    before = (seq / "det" / "det.txt").read_bytes()
    with pytest.raises(InputError, match="which this run reads"):
        result.save(seq / "det" / "det.txt")
    assert (seq / "det" / "det.txt").read_bytes() == before


def test_import_sotmot_loads_nothing_heavy():
    code = ("import sys, time; t = time.perf_counter(); import sotmot; t = time.perf_counter() - t; "
            "heavy = [m for m in ('numpy', 'cv2', 'openvino', 'onnxruntime', 'torch', 'scipy', 'sotmot.api') "
            "if m in sys.modules]; print(heavy, t)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[0] == "[]", out
    assert sotmot.track.__module__ == "sotmot.api" and sotmot.TrackerConfig.__name__ == "TrackerConfig"
    assert set(sotmot.__all__) >= {"track", "evaluate", "TrackerConfig", "Tracks"}
    with pytest.raises(AttributeError):
        sotmot.no_such_name


def _examples() -> list[str]:
    text = (ROOT / "docs" / "api.md").read_text()
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


@pytest.mark.parametrize("example", range(len(_examples())))
def test_the_examples_of_docs_api_md_run(example, tmp_path, monkeypatch, capsys):
    require(CLIP)
    code = _examples()[example].replace("../shared/data", str(DATA))
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"docs/api.md example {example + 1}", "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.strip()


def test_the_result_says_what_the_run_found_by_itself_as_its_run_record_does(tmp_path):
    import json

    walking = require(DATA / "MOT16-05-clip30")  # a walking camera
    motion_only = {"appearance": {"backend": "none"}}
    found = sotmot.track(walking, config=motion_only).found
    assert found["camera_motion"]["moving"] and found["confidence_method"] == "dpm" and "line_check" not in found
    assert main(["track", str(walking), "--appearance", "none", "--out", str(tmp_path), "-q"]) == 0
    record = json.loads((tmp_path / "MOT16-05-clip30.run.json").read_text())
    assert {key: record[key] for key in found} == found and "line_check" not in record
    hand_held = require(DATA / "MOT17-labels" / "MOT17-10-SDP")  # no frames: the line check bounds its gaps
    assert sotmot.track(hand_held, config=motion_only).found["line_check"] == {"interpolate_max_seconds": 1.5}
    windows = {**motion_only, "windows": {"seconds": 0.5}, "association": {"l_max_seconds": 0.2}}
    assert sotmot.track(walking, config=windows).found == {}  # decided window by window
