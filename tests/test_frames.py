"""Frames read straight from a video: no temporary frame folder, a bounded cache, each frame decoded once a pass."""

import tempfile
from collections import Counter

import numpy as np
import pytest

from conftest import DATA, require, write_sequence, write_video
from sotmot.config import TrackerConfig
from sotmot.errors import InputError
from sotmot.io import FrameReader, read_seqinfo
from sotmot.io.frames import VideoFile


@pytest.fixture(scope="module")
def clip_video(tmp_path_factory):
    """MOT16-05-clip30's frames as an MPEG-4 video, and its public detections."""
    import cv2

    info = read_seqinfo(require(DATA / "MOT16-05-clip30"))
    path = tmp_path_factory.mktemp("video") / "clip.mp4"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), info.frame_rate, (info.width, info.height))
    reader = FrameReader(info, cache_size=1)
    for f in range(1, info.length + 1):
        writer.write(np.ascontiguousarray(reader(f)))
    writer.release()
    return path, info.det_path


def cv2_write(path, value: int) -> None:
    """A 64 x 48 JPEG of one grey level, ``value`` times 20."""
    import cv2

    cv2.imwrite(str(path), np.full((48, 64, 3), 20 * value, np.uint8))


def counting(monkeypatch) -> Counter:
    """Counts every frame a video source decodes, by frame."""
    seen: Counter = Counter()
    original = VideoFile.read

    def read(self, frame):
        seen[frame] += 1
        return original(self, frame)

    monkeypatch.setattr(VideoFile, "read", read)
    return seen


def test_frames_in_any_order_are_the_frames_read_in_order(tmp_path):
    video = write_video(tmp_path / "walk.avi", n=40)
    info = read_seqinfo(video)
    in_order = [FrameReader(info, cache_size=1)(f).copy() for f in range(1, 41)]
    reader = FrameReader(info, cache_size=1)
    for f in [40, 3, 4, 30, 31, 1, 39, 12, 12, 2]:  # back, ahead by one, far ahead, the same frame
        np.testing.assert_array_equal(reader(f), in_order[f - 1])
    assert reader.source.seeks >= 4  # going back seeks; one frame ahead reads on


def test_a_video_read_backwards_seeks_once_a_block_not_once_a_frame(tmp_path):
    video = write_video(tmp_path / "walk.avi", n=40)
    info = read_seqinfo(video)
    in_order = [FrameReader(info, cache_size=1)(f).copy() for f in range(1, 41)]
    reader = FrameReader(info, cache_size=8)
    reader(35)
    for f in range(34, 4, -1):  # 30 steps back, as the end extension walks before a trajectory's first box
        np.testing.assert_array_equal(reader(f), in_order[f - 1])
        assert reader.cached <= 8
    assert reader.source.seeks <= 6  # a block of 6 frames a seek (one frame at a time: 30 seeks)
    assert reader.source.decodes <= 31 + 6


def test_a_walking_reader_keeps_the_frames_it_passes_so_a_walk_back_from_there_needs_no_seek(tmp_path):
    """The end extension reads a video forward, in frame order; a walk back from an end then finds the frames
    before it in the cache: they were read on the way, not grabbed past."""
    video = write_video(tmp_path / "walk.avi", n=40)
    info = read_seqinfo(video)
    in_order = [FrameReader(info, cache_size=1)(f).copy() for f in range(1, 41)]
    reader = FrameReader.walking(info)
    for f in (3, 12, 20):  # forward, a few frames apart
        np.testing.assert_array_equal(reader(f), in_order[f - 1])
    for f in range(19, 13, -1):  # six steps back from frame 20
        np.testing.assert_array_equal(reader(f), in_order[f - 1])
    assert reader.source.seeks == 0 and reader.cached <= reader.cache_size
    reader(13)  # seven back: beyond the block kept, one seek
    assert reader.source.seeks == 1
    plain = FrameReader(info, cache_size=8)  # not walking: forward, the frames between are grabbed past
    for f in (3, 12, 20):
        plain(f)
    assert plain.source.decodes == 3 and plain.cached == 3


def test_a_video_whose_seeks_cost_more_reads_farther_ahead(tmp_path):
    from sotmot.io.frames import SKIP_AHEAD

    info = read_seqinfo(write_video(tmp_path / "walk.avi", n=80))
    in_order = [FrameReader(info, cache_size=1)(f).copy() for f in range(1, 81)]
    video = VideoFile(info)
    assert video.skip_ahead == SKIP_AHEAD  # nothing measured yet
    np.testing.assert_array_equal(video.read(1), in_order[0])
    np.testing.assert_array_equal(video.read(40), in_order[39])  # 39 ahead: a seek, timed
    assert video.seeks == 1 and video.skip_ahead >= SKIP_AHEAD
    video._seek_seconds, video._frame_seconds = 0.5, 0.005  # as an H.264 file with a key frame every 250
    assert video.skip_ahead == 100
    np.testing.assert_array_equal(video.read(80), in_order[79])  # 39 ahead again: read on, no seek
    assert video.seeks == 1
    video.close()


def test_the_frame_cache_never_holds_more_than_its_bound(tmp_path):
    info = read_seqinfo(write_video(tmp_path / "walk.avi", n=30))
    reader = FrameReader(info, cache_size=3)
    rng = np.random.default_rng(0)
    for f in rng.integers(1, 31, 200):
        reader(int(f))
        assert reader.cached <= 3
    again = FrameReader(info, cache_size=3)
    for f in [5, 6, 7, 5, 6, 7, 8, 5]:  # 5, 6, 7 decoded once while they stay in the cache; 5 again after 8
        again(f)
    assert again.source.decodes == 5


def test_jpeg_frames_decoded_ahead_are_the_frames_once_each_two_ahead_at_most_errors_when_asked(tmp_path):
    from sotmot.io.frames import PREFETCH_AHEAD

    seq = write_sequence(tmp_path, [], length=8)
    for f in range(1, 9):  # frames that differ, so a frame given for another would show
        cv2_write(seq / "img1" / f"{f:06d}.jpg", f)
    info = read_seqinfo(seq)
    plain = [FrameReader(info, cache_size=1)(f).copy() for f in range(1, 9)]
    reader = FrameReader(info, cache_size=2)
    reader.prefetch(3)
    np.testing.assert_array_equal(reader(3), plain[2])
    reader.prefetch(3)  # held now: not decoded again
    for f in (0, 9):  # outside the sequence: nothing to decode
        reader.prefetch(f)
    assert reader.source.decodes == 1
    for f in (4, 5, 6):  # three asked ahead, two kept: 4 is forgotten
        reader.prefetch(f)
    assert PREFETCH_AHEAD == 2 and sorted(reader._ahead) == [5, 6]
    for f in (4, 5, 6):
        np.testing.assert_array_equal(reader(f), plain[f - 1])
    assert reader.cached <= 2
    (seq / "img1" / "000008.jpg").write_bytes(b"not a jpeg")
    reader.prefetch(8)  # the error waits for the frame to be asked for
    with pytest.raises(InputError, match="frame 8 cannot be decoded"):
        reader(8)
    reader.close()


def test_a_video_is_decoded_ahead_only_by_a_reader_that_owns_its_decoding(tmp_path):
    """A plain reader never decodes a video ahead (one decoder, which the caller reads in order); a reader made to
    decode ``ahead`` (the pass over the frames) decodes every frame in its own thread, in the order asked: the
    frames are those read in order, and the caller's thread never touches the video."""
    import threading

    info = read_seqinfo(write_video(tmp_path / "walk.avi", n=10))
    reader = FrameReader(info, cache_size=2)
    reader.prefetch(2)
    assert reader.source.decodes == 0 and reader.cached == 0
    plain = [FrameReader(info, cache_size=1)(f).copy() for f in range(1, 11)]
    owner = FrameReader(info, cache_size=1, ahead=True)
    threads = set()
    read = owner.source.read
    owner.source.read = lambda frame: threads.add(threading.current_thread().name) or read(frame)
    frames = [1, 2, 4, 5, 9, 10]
    for k, f in enumerate(frames):  # as the pass asks: this frame, and the next one ahead
        for ahead in frames[k:k + 2]:
            owner.prefetch(ahead)
        np.testing.assert_array_equal(owner(f), plain[f - 1])
    assert threading.current_thread().name not in threads and len(threads) == 1
    assert owner.source.seeks == 0 and owner.decode_seconds > 0
    owner.close()


def test_a_walking_reader_keeps_a_block_of_a_video_and_little_of_jpegs(tmp_path):
    from sotmot.io.frames import READ_BACK_CACHE, WALK_CACHE

    video = FrameReader.walking(read_seqinfo(write_video(tmp_path / "walk.avi", n=10)))
    jpegs = FrameReader.walking(read_seqinfo(write_sequence(tmp_path, [], length=4)))
    assert (video.cache_size, jpegs.cache_size) == (READ_BACK_CACHE, WALK_CACHE) and WALK_CACHE < READ_BACK_CACHE


def test_a_video_tracks_with_no_temporary_frame_folder(clip_video, model_0288, tmp_path, monkeypatch):
    from sotmot.cli import main

    video, det = clip_video
    made: list = []
    real = tempfile.mkdtemp

    def mkdtemp(*args, **kwargs):
        made.append((args, kwargs))
        return real(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkdtemp", mkdtemp)  # TemporaryDirectory makes its folder with it
    out = tmp_path / "out"
    assert main(["track", str(video), "--det", str(det), "--out", str(out), "--reid-model", str(model_0288),
                 "-q"]) == 0
    assert made == []
    assert sorted(p.name for p in out.iterdir()) == ["clip.flags.csv", "clip.run.json", "clip.txt"]


def test_with_sot_each_frame_of_a_video_is_decoded_once_before_association(clip_video, model_0288, monkeypatch):
    from sotmot.pipeline import finish_sequence, prepare_sequence

    video, det = clip_video
    config = (TrackerConfig().replace("appearance", model=str(model_0288)).replace("detection", file=str(det))
              .replace("sot", variant="template").replace("motion", compensation="off"))  # motion: the test below
    decodes = counting(monkeypatch)
    prepared = prepare_sequence(video, config)
    length = prepared.info.length
    assert prepared.detections.from_sot.any()  # the SOT step ran and found boxes
    assert decodes == Counter(range(1, length + 1))  # detections' features and SOT from one decode a frame
    decodes.clear()
    result = finish_sequence(prepared, config)  # the end extension reads frames near the trajectories' ends
    assert result.tracks.from_sot.any() or not decodes
    assert max(decodes.values(), default=0) <= 2 and sum(decodes.values()) <= length


def test_the_camera_motion_estimate_decodes_each_frame_of_a_video_at_most_twice(clip_video, monkeypatch):
    """MOT16-05 is filmed walking: auto's still check reads a frame per half second, finds the camera moving, and
    the estimate reads every frame once (small and grey; the stages that need colour read them again)."""
    from sotmot.config import MotionConfig
    from sotmot.io import read_detections
    from sotmot.motion import estimate_motion, still_check_pairs

    video, det = clip_video
    info = read_seqinfo(video)
    decodes = counting(monkeypatch)
    motion = estimate_motion(info, read_detections(det, info.length), MotionConfig())
    assert motion.moving
    checked = {f for pair in still_check_pairs(info.length, info.frame_rate, video=True) for f in pair}
    assert set(decodes) == set(range(1, info.length + 1)) and max(decodes.values()) <= 2
    assert {f for f, n in decodes.items() if n == 2} <= checked  # the check stops at the first pair that moved


def test_the_still_check_of_a_video_reads_the_frames_the_appearance_pass_decoded(tmp_path, monkeypatch):
    """A still camera filmed as a video: the pass that embeds the detections decodes every frame, and the camera
    check judges its pairs there (motion.PassMotion) instead of decoding their frames again."""
    import cv2

    import sotmot.plan
    from conftest import GeometryEmbedder
    from sotmot.pipeline import prepare_sequence

    rng = np.random.default_rng(0)
    background = cv2.GaussianBlur(rng.integers(0, 256, (120, 160, 3), dtype=np.uint8), (5, 5), 0)  # corners
    path, det = tmp_path / "still.avi", tmp_path / "det.txt"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (160, 120))
    lines = []
    for f in range(1, 31):
        image = background.copy()
        x = 10 + 3 * f
        image[40:100, x:x + 20] = 30  # someone walking; the camera stays
        writer.write(image)
        lines.append(f"{f},-1,{x},40,20,60,0.9,-1,-1,-1")
    writer.release()
    det.write_text("\n".join(lines) + "\n")
    config = TrackerConfig().replace("detection", file=str(det))
    decodes = counting(monkeypatch)
    prepared = prepare_sequence(path, config, embedder=GeometryEmbedder())
    assert not prepared.motion.moving
    assert decodes == Counter(range(1, 31))  # each frame once: the pass's decode served the check too
    monkeypatch.setattr(sotmot.plan, "in_pass", lambda info, config: False)
    decodes.clear()
    again = prepare_sequence(path, config, embedder=GeometryEmbedder())
    assert not again.motion.moving and max(decodes.values()) == 2  # without it, the check decodes its frames again


def test_a_moving_camera_filmed_as_a_video_is_measured_in_the_pass_that_decodes_it(clip_video, monkeypatch):
    """MOT16-05 is filmed walking: the pass over the video judges the still check's first pair moving and
    estimates every frame pair as it decodes the frame, so the whole preparation decodes each frame once, and
    the camera's motion is to the bit the estimate made after the pass from a second decode."""
    import sotmot.plan
    from conftest import GeometryEmbedder
    from sotmot.pipeline import prepare_sequence

    video, det = clip_video
    for compensation in ("auto", "on"):
        config = TrackerConfig().replace("detection", file=str(det)).replace("motion", compensation=compensation)
        decodes = counting(monkeypatch)
        measured = prepare_sequence(video, config, embedder=GeometryEmbedder())
        assert measured.motion.moving and decodes == Counter(range(1, measured.info.length + 1))
        with monkeypatch.context() as patched:
            patched.setattr(sotmot.plan, "in_pass", lambda info, config: False)
            decodes.clear()
            after = prepare_sequence(video, config, embedder=GeometryEmbedder())
        assert min(decodes.values()) >= 2  # the estimate after the pass decodes every frame again
        np.testing.assert_array_equal(measured.motion.pair, after.motion.pair)
        np.testing.assert_array_equal(measured.motion.confidence, after.motion.confidence)
        np.testing.assert_array_equal(measured.in_ref.boxes, after.in_ref.boxes)


def test_the_detectors_pass_over_a_moving_video_leaves_out_the_boxes_preprocessing_keeps(clip_video, monkeypatch):
    """With the detector's boxes the estimate masks the boxes preprocessing keeps, known only after the pass:
    the pass preprocesses each frame alone (preprocess.frame_preprocessor) and the run checks that the boxes
    came out the same. Probabilities (a detector's scores): measured in the pass, each frame decoded once. One
    score outside [0, 1] in the last frame: ``nms = "auto"`` takes IoM for the sequence where each frame before
    took IoU, a small box inside a larger one in frame 1 survives only the latter, so the pass's estimate is set
    aside and the motion measured again, the same as without the pass."""
    import sotmot.plan
    from conftest import GeometryEmbedder
    from sotmot.io import read_detections
    from sotmot.pipeline import prepare_sequence

    video, det = clip_video
    info = read_seqinfo(video)
    public = read_detections(det, info.length)

    class Replay:
        """Gives each frame, in the order asked, the public boxes of that frame as probabilities."""

        def __init__(self, odd: bool):
            self.frame, self.odd = 0, odd

        def detect(self, image):
            self.frame += 1
            mine = public.frames == self.frame
            boxes, scores = public.boxes[mine], 1 / (1 + np.exp(-public.scores[mine]))
            if self.odd and self.frame == 1:  # a head inside the first person's box
                x, y, w, h = boxes[0]
                boxes, scores = np.vstack([boxes, [x + w / 4, y, w / 2, h / 4]]), np.append(scores, 0.01)
            if self.odd and self.frame == info.length:
                scores = np.append(scores[:-1], 5.0)
            return boxes, scores

    config = TrackerConfig().replace("detection", source="model", weak_boxes="off")
    for odd in (False, True):
        decodes = counting(monkeypatch)
        measured = prepare_sequence(video, config, embedder=GeometryEmbedder(), detector=Replay(odd))
        assert measured.motion.moving and (decodes == Counter(range(1, info.length + 1))) is not odd
        with monkeypatch.context() as patched:
            patched.setattr(sotmot.plan, "in_pass", lambda info, config: False)
            after = prepare_sequence(video, config, embedder=GeometryEmbedder(), detector=Replay(odd))
        np.testing.assert_array_equal(measured.motion.pair, after.motion.pair)
        np.testing.assert_array_equal(measured.detections.boxes, after.detections.boxes)
