#!/usr/bin/env python3
"""A new user's probe of what sotmot does with files (issue #89): well over 100 runs of the CLI and the Python API
on copies of a 30-frame clip, its frames as a video and as a folder of images, each checked for what must never
happen, whatever the run's own answer:

* ``lost``: a file the user owns changed or vanished (every file of the inputs is hashed before and after each run;
  an earlier run's results count as the user's too, unless the run was asked to write them again);
* ``inside``: something new inside a sequence folder or folder of images;
* ``traceback``: a Python traceback instead of a message (exit statuses other than 0, 1, 2 and 130 count too);
* ``unsaid``: a partial result read (``eval``, ``render``, ``sotmot.evaluate``) without a word that it is partial.

The runs are motion only (``--appearance none``) where re-ID would change nothing the probe looks at. Prints one
line per run (case, exit status, problems) and the counts; ``--json`` writes every run.

    python scripts/probe_files.py --json probe.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import DEFAULT_DATA

CLIP = "MOT16-02-clip30"
SOTMOT = [str(Path(sys.executable).parent / "sotmot")]  # the command a user runs, beside this Python
MOTION = ["--appearance", "none", "-q"]


def tree(*roots: Path) -> dict[str, str]:
    """Every file below ``roots`` (links followed) with its SHA-256."""
    out = {}
    for root in roots:
        paths = [root] if root.is_file() else sorted(p for p in root.rglob("*") if p.is_file())
        for path in paths:
            out[str(path)] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def make_inputs(data: Path, work: Path) -> dict[str, Path]:
    """A copy of the clip, its frames as an MJPG video and as a folder of images, an earlier run's results."""
    import cv2

    seq = work / "data" / CLIP
    shutil.copytree(data / CLIP, seq)
    frames = sorted((seq / "img1").glob("*.jpg"))
    first = cv2.imread(str(frames[0]))
    small = (first.shape[1] // 2, first.shape[0] // 2)
    video = work / "videos" / "street.avi"
    video.parent.mkdir()
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 30, small)
    images = work / "pictures" / "walk"
    images.mkdir(parents=True)
    for k, path in enumerate(frames, 1):
        image = cv2.resize(cv2.imread(str(path)), small)
        writer.write(image)
        cv2.imwrite(str(images / f"frame_{k}.jpg"), image)
    writer.release()
    one = work / "videos" / "one.avi"
    writer = cv2.VideoWriter(str(one), cv2.VideoWriter_fourcc(*"MJPG"), 30, small)
    writer.write(cv2.resize(first, small))
    writer.release()
    (work / "empty").mkdir()
    (work / "small.toml").write_text("[association]\nl_max_seconds = 0.2\n[windows]\nseconds = 0.5\n")
    return {"seq": seq, "video": video, "images": images, "one": one, "empty": work / "empty",
            "config": work / "small.toml"}


def cases(i: dict[str, Path], work: Path) -> list[tuple[str, list[str] | str]]:
    """``(name, argv of sotmot or Python source)`` of every run, in order (later runs find earlier runs' files)."""
    seq, video, images = str(i["seq"]), str(i["video"]), str(i["images"])
    out = str(work / "out")
    runs: list[tuple[str, list[str] | str]] = []
    sources = {"folder": seq, "video": video, "images": images}
    extra = {"folder": [], "video": [], "images": ["--fps", "30"]}
    for name, src in sources.items():
        e = extra[name]
        runs += [
            (f"track {name}", ["track", src, "--out", out, *e, *MOTION]),
            (f"track {name} again (same out)", ["track", src, "--out", out, *e, *MOTION]),
            (f"track {name} --resume", ["track", src, "--out", out, "--resume", *e, *MOTION]),
            (f"track {name} --out inside it", ["track", src, "--out", str(Path(src).parent / "res"), *e, *MOTION]
             if name == "video" else ["track", src, "--out", str(Path(src) / "res"), *e, *MOTION]),
            (f"track {name} --out ''", ["track", src, "--out", "", *e, *MOTION]),
            (f"track {name} --out a file", ["track", src, "--out", str(i["config"]), *e, *MOTION]),
            (f"track {name} --window", ["track", src, "--out", str(work / "win"), "--config", str(i["config"]), *e,
                                        *MOTION]),
            (f"track {name} --step 2", ["track", src, "--out", str(work / "step"), "--step", "2", *e, *MOTION]),
            (f"track {name} --unconfirmed file", ["track", src, "--out", str(work / "low"), "--unconfirmed",
                                                  "file", *e, *MOTION]),
            (f"track {name} --eval", ["track", src, "--out", str(work / "ev"), "--eval", *e, *MOTION]),
        ]
    runs += [
        ("track folder --out its det/", ["track", seq, "--out", str(i["seq"] / "det"), *MOTION]),
        ("track folder --out its img1/", ["track", seq, "--out", str(i["seq"] / "img1"), *MOTION]),
        ("track folder --det its own det.txt --out det/", ["track", seq, "--det", str(i["seq"] / "det" / "det.txt"),
                                                           "--out", str(i["seq"] / "det"), *MOTION]),
        ("track video --det into the video's folder", ["track", video, "--det", str(i["seq"] / "det" / "det.txt"),
                                                       "--out", str(Path(video).parent), *MOTION]),
        ("track folder --config its own run record", ["track", seq, "--out", out, "--config",
                                                      str(Path(out) / f"{CLIP}.run.json"), *MOTION]),
        ("track an empty folder", ["track", str(i["empty"]), "--out", str(work / "e"), *MOTION]),
        ("track an empty folder --fps", ["track", str(i["empty"]), "--out", str(work / "e"), "--fps", "5", *MOTION]),
        ("track a one-frame video", ["track", str(i["one"]), "--out", str(work / "one"), *MOTION]),
        ("track a missing path", ["track", str(work / "nope"), "--out", str(work / "e"), *MOTION]),
        ("track a results file as a sequence", ["track", str(Path(out) / f"{CLIP}.txt"), "--out", out, *MOTION]),
        ("track folder, results path now a folder", f"RESULTS_AS_FOLDER {seq} {work / 'busy'}"),
        ("live video", ["track", "--live", video, "--out", str(work / "live"), *MOTION]),
        ("live video again into the same out", ["track", "--live", video, "--out", str(work / "live"), *MOTION]),
        ("live images folder", ["track", "--live", images, "--out", str(work / "live2"), *MOTION]),
    ]
    for name, src in sources.items():
        e = extra[name]
        results = str(Path(out) / f"{'street' if name == 'video' else 'walk' if name == 'images' else CLIP}.txt")
        runs += [
            (f"render {name}", ["render", src, results, "--out", str(work / f"r-{name}"), *e, "-q"]),
            (f"render {name} into itself", ["render", src, results, "--out",
                                            str(Path(src).parent / "r.mp4" if name == "video" else Path(src) / "r"),
                                            *e, "-q"]),
            (f"render {name} over its results", ["render", src, results, "--out", results, *e, "-q"]),
            (f"graph {name}", ["graph", src, "--out", str(work / f"g-{name}"), *e, *MOTION]),
            (f"graph {name} into itself", ["graph", src, "--out",
                                           str(Path(src).parent / "g" if name == "video" else Path(src) / "g"), *e,
                                           *MOTION]),
            (f"explain {name} --ids 1,2", ["explain", src, "--ids", "1,2", *e, *MOTION]),
            (f"explain {name} --ids 1,999", ["explain", src, "--ids", "1,999", *e, *MOTION]),
            (f"explain {name} --ids 1", ["explain", src, "--ids", "1", *e, *MOTION]),
            (f"explain {name} --tracklets 0,1", ["explain", src, "--tracklets", "0,1", *e, *MOTION]),
            (f"explain {name} --tracks", ["explain", src, "--tracks", *e, *MOTION]),
        ]
    runs += [
        ("eval", ["eval", out, seq]),
        ("eval --json fresh", ["eval", out, seq, "--json", str(work / "scores.json")]),
        ("eval --json in the sequence folder", ["eval", out, seq, "--json", str(i["seq"] / "scores.json")]),
        ("eval --json over gt.txt", ["eval", out, seq, "--json", str(i["seq"] / "gt" / "gt.txt")]),
        ("eval --json over the results", ["eval", out, seq, "--json", str(Path(out) / f"{CLIP}.txt")]),
        ("eval arguments swapped", ["eval", seq, out]),
        ("eval a partial windowed run", f"PARTIAL {seq} {work / 'partial'} {i['config']}"),
        ("compare --json fresh", ["compare", seq, "--solvers", "greedy,flow", "--json", str(work / "cmp.json"),
                                  *MOTION]),
        ("compare --json in the sequence folder", ["compare", seq, "--solvers", "greedy,flow", "--json",
                                                   str(i["seq"] / "cmp.json"), *MOTION]),
        ("compare a video", ["compare", video, "--solvers", "greedy", *MOTION]),
        ("models", ["models"]),
        ("models, SOTMOT_REID_MODEL missing", "ENV_MODELS"),
    ]
    api = {
        "save over the det.txt frames in memory were tracked from":
            "frames = [cv2.imread(str(p)) for p in sorted(Path(SEQ, 'img1').glob('*.jpg'))]\n"
            "r = sotmot.track(frames, detections=SEQ + '/det/det.txt', frame_rate=14, config=M)\n"
            "r.save(SEQ + '/det/det.txt')",
        "save over the first image of a list of paths":
            "files = sorted(Path(IMAGES).glob('*.jpg'))\n"
            "r = sotmot.track(files, detections=SEQ + '/det/det.txt', frame_rate=30, config=M)\nr.save(files[0])",
        "save into the sequence folder": "sotmot.track(SEQ, config=M).save(SEQ + '/res.txt')",
        "save into the folder of images": "sotmot.track(IMAGES, frame_rate=30, config=M).save(IMAGES + '/res.txt')",
        "save over the video": "sotmot.track(VIDEO, config=M).save(VIDEO)",
        "save to a folder": "sotmot.track(SEQ, config=M).save(WORK)",
        "save fresh": "sotmot.track(SEQ, config=M).save(WORK + '/api/res.txt')",
        "save fresh again": "sotmot.track(SEQ, config=M).save(WORK + '/api/res.txt')",
        "track None": "sotmot.track(None)",
        "track a number": "sotmot.track(3)",
        "track a folder with a name": "r = sotmot.track(SEQ, config=M, name='other')\nassert r.info.name == 'other'",
        "track with detections='model' as a path": "sotmot.track(SEQ, detections=SEQ + '/model', config=M)",
        "evaluate a partial run": "sotmot.evaluate(WORK + '/partial/' + CLIP + '.txt', SEQ)",
        "evaluate the whole run": "sotmot.evaluate(WORK + '/out/' + CLIP + '.txt', SEQ)",
        "stream with a name": "parts = list(sotmot.stream(iter([]), frame_rate=5, config=M))",
        "save a windowed result": "sotmot.track(SEQ, config={**M, 'windows': {'seconds': 0.5}, 'association': "
                                  "{'l_max_seconds': 0.2}}).save(WORK + '/api/win.txt')",
    }
    runs += [(f"api: {name}", f"API {source}") for name, source in api.items()]
    return runs


def run_api(source: str, i: dict[str, Path], work: Path) -> subprocess.CompletedProcess:
    prelude = ("import cv2, sotmot\nfrom pathlib import Path\nfrom sotmot.errors import SotmotError\n"
               f"SEQ, VIDEO, IMAGES, WORK, CLIP = {str(i['seq'])!r}, "
               f"{str(i['video'])!r}, {str(i['images'])!r}, {str(work)!r}, {CLIP!r}\n"
               f"M = {{'appearance': {{'backend': 'none'}}}}\n"
               "import warnings\nwarnings.simplefilter('always')\n"
               "try:\n" + "".join(f"    {line}\n" for line in source.splitlines()) +
               "except SotmotError as exc:\n    print('sotmot: error:', exc, file=__import__('sys').stderr)\n"
               "    raise SystemExit(2)\n")
    return subprocess.run([sys.executable, "-c", prelude], capture_output=True, text=True, timeout=600)


def run_special(kind: str, args: list[str], i: dict[str, Path], env: dict) -> subprocess.CompletedProcess:
    if kind == "ENV_MODELS":
        return subprocess.run([*SOTMOT, "models"], capture_output=True, text=True,
                              env={**env, "SOTMOT_REID_MODEL": "/nonexistent/reid.onnx"})
    if kind == "RESULTS_AS_FOLDER":
        seq, out = args
        first = subprocess.run([*SOTMOT, "track", seq, "--out", out, *MOTION], capture_output=True, text=True)
        if first.returncode:
            return first
        results = Path(out) / f"{CLIP}.txt"
        results.unlink()
        results.mkdir()
        return subprocess.run([*SOTMOT, "track", seq, "--out", out, *MOTION], capture_output=True, text=True)
    if kind == "PARTIAL":  # a windowed run stopped (Ctrl-C) once its first window is committed, then eval
        seq, out, config = args
        stop = ("import sotmot.windows as w\nreal = w.Stitcher.add\n"
                "def add(self, k, result):\n    if k == 1:\n        raise KeyboardInterrupt\n"
                "    return real(self, k, result)\nw.Stitcher.add = add\nfrom sotmot.cli import main\n"
                f"raise SystemExit(main(['track', {seq!r}, '--out', {out!r}, '--config', {config!r}, "
                f"'--appearance', 'none', '-q']))\n")
        stopped = subprocess.run([sys.executable, "-c", stop], capture_output=True, text=True, env=env)
        if stopped.returncode != 130:
            return stopped
        return subprocess.run([*SOTMOT, "eval", out, seq], capture_output=True, text=True)
    raise ValueError(kind)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA,
                        help="folder holding the clip (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write every run here")
    args = parser.parse_args()
    if not (args.data / CLIP).is_dir():
        parser.error(f"--data: no {CLIP} under {args.data}")
    rows = []
    with tempfile.TemporaryDirectory(prefix="sotmot-probe-") as tmp:
        work = Path(tmp)
        inputs = make_inputs(args.data, work)
        owned = [inputs["seq"], inputs["video"].parent, inputs["images"]]
        folders = [inputs["seq"], inputs["images"]]
        env = dict(os.environ)
        for name, what in cases(inputs, work):
            before = tree(*owned)
            listing = {str(f): sorted(str(p) for p in f.rglob("*")) for f in folders}
            results_before = tree(work / "out") if (work / "out").is_dir() else {}
            start = time.perf_counter()
            if isinstance(what, list):
                done = subprocess.run([*SOTMOT, *what], capture_output=True, text=True, env=env, timeout=600)
            elif what.startswith("API "):
                done = run_api(what[4:], inputs, work)
            else:
                kind, *rest = what.split()
                done = run_special(kind, rest, inputs, env)
            seconds = time.perf_counter() - start
            problems = []
            after = tree(*owned)
            changed = [p for p in before if before[p] != after.get(p)]
            if changed:
                problems.append(f"lost: {', '.join(Path(p).name for p in changed[:3])}")
            new = [p for f in folders for p in sorted(str(q) for q in f.rglob("*")) if p not in listing[str(f)]]
            if new:
                problems.append(f"inside: {', '.join(Path(p).name for p in new[:3])}")
            rewrites = isinstance(what, list) and what[:1] == ["track"] and str(work / "out") in what
            if results_before and not rewrites:
                now = tree(work / "out") if (work / "out").is_dir() else {}
                gone = [p for p in results_before if results_before[p] != now.get(p)]
                if gone:
                    problems.append(f"lost results: {', '.join(Path(p).name for p in gone[:3])}")
            if "Traceback" in done.stderr or done.returncode not in (0, 1, 2, 130):
                problems.append("traceback" if "Traceback" in done.stderr else f"exit {done.returncode}")
            if "partial" in name and "is partial" not in done.stderr:
                problems.append("unsaid: partial results read without a word")
            said = (done.stderr.strip().splitlines() or done.stdout.strip().splitlines() or [""])[-1][:150]
            rows.append({"case": name, "exit": done.returncode, "seconds": round(seconds, 1), "problems": problems,
                         "said": said})
            print(f"{len(rows):3d} {name:58s} exit {done.returncode:3d}  {'; '.join(problems) or 'ok':30s} {said}",
                  flush=True)
    bad = [r for r in rows if r["problems"]]
    print(f"\n{len(rows)} runs, {len(bad)} with a problem"
          + (": " + ", ".join(r["case"] for r in bad) if bad else ""))
    if args.json:
        from sotmot.io import write_text_atomic

        write_text_atomic(args.json, json.dumps({"runs": rows}, indent=1) + "\n")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
