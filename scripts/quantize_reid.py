#!/usr/bin/env python3
"""Build an INT8 OpenVINO IR of a re-ID model by post-training quantisation (NNCF), from crops of our own clips.

Issue #42 asks whether re-ID in INT8 keeps the tracker's accuracy while it
runs faster. This script builds the quantised model; it never downloads one.
The calibration crops come from the public detections of the 30-frame clips
(``MOT16-*-clip30`` by default: other videos than the full-length sequences
the accuracy check tracks), each crop also mirrored, as the flip average feeds
the network. Quantisation only measures activation ranges on these crops; no
label is read.

    bash scripts/bootstrap.sh --bench        # installs nncf (a benchmark-only dependency)
    .venv/bin/python scripts/quantize_reid.py --out .cache/reid-int8/reid-0288-int8.xml
    .venv/bin/sotmot track ../shared/data/PETS09-S2L1 --reid-model .cache/reid-int8/reid-0288-int8.xml --out r --eval

The output is an ``.xml`` with its ``.bin`` beside it; an existing file is
refused. Prints the crops used and the machine; the accuracy and speed of the
model it writes are measured by ``bench_accuracy.py`` and ``bench_speed.py``
given it as ``--model``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA
from sotmot.appearance.base import CROP_HEIGHT, CROP_WIDTH, crop_boxes
from sotmot.benchmarks import machine
from sotmot.io import FrameReader, read_detections, read_seqinfo
from sotmot.models import resolve_model_file


def calibration_crops(folders: list[Path], per_sequence: int, seed: int = 0) -> np.ndarray:
    """Up to ``per_sequence`` detection crops ``(N, 256, 128, 3)`` uint8 BGR from each folder (a random choice of
    its public detections, fixed by ``seed``), each followed by its mirror image."""
    rng = np.random.default_rng(seed)
    out = []
    for folder in folders:
        info = read_seqinfo(folder)
        dets = read_detections(info.det_path, info.length, (info.width, info.height))
        chosen = np.sort(rng.choice(len(dets), size=min(per_sequence, len(dets)), replace=False))
        reader = FrameReader(info, cache_size=1)
        for frame in np.unique(dets.frames[chosen]):
            rows = chosen[dets.frames[chosen] == frame]
            crops = crop_boxes(reader(int(frame)), dets.boxes[rows])
            out += [crops, crops[:, :, ::-1]]
    return np.concatenate(out) if out else np.zeros((0, CROP_HEIGHT, CROP_WIDTH, 3), np.uint8)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", help="ONNX re-ID model (default: the bundled person-reidentification-retail-0288)")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--sequences", default="MOT16-02-clip30,MOT16-04-clip30,MOT16-05-clip30,MOT16-10-clip30,"
                                               "MOT16-13-clip30",
                        help="comma-separated folders under --data whose crops calibrate (default: %(default)s)")
    parser.add_argument("--per-sequence", type=int, default=120, help="crops per sequence (default: %(default)s)")
    parser.add_argument("--preset", default="mixed", choices=["performance", "mixed"],
                        help="NNCF preset: symmetric (performance) or asymmetric activations (mixed)")
    parser.add_argument("--out", type=Path, required=True, help="the INT8 IR to write (.xml; .bin beside it)")
    args = parser.parse_args(argv)
    try:
        import nncf
        import openvino as ov
    except ImportError as exc:
        parser.error(f"{exc}; install the benchmark dependencies: bash scripts/bootstrap.sh --bench")
    if args.out.suffix != ".xml":
        parser.error(f"--out {args.out}: give the .xml path of the IR to write")
    if args.out.exists() or args.out.with_suffix(".bin").exists():
        parser.error(f"--out {args.out}: exists; choose another path (this script never writes over a file)")
    folders = [args.data / name for name in args.sequences.split(",") if name]
    missing = [str(f) for f in folders if not (f / "seqinfo.ini").is_file()]
    if missing:
        parser.error(f"no sequence at {', '.join(missing)}")
    crops = calibration_crops(folders, args.per_sequence)
    print(f"{len(crops)} calibration crops (mirrored ones included) from {len(folders)} sequences")
    source = resolve_model_file(args.model, "reid")
    model = ov.Core().read_model(str(source))
    model.reshape({model.inputs[0]: ov.PartialShape([-1, 3, CROP_HEIGHT, CROP_WIDTH])})
    batches = [np.ascontiguousarray(crops[i:i + 1].transpose(0, 3, 1, 2), dtype=np.float32)
               for i in range(len(crops))]
    preset = nncf.QuantizationPreset.MIXED if args.preset == "mixed" else nncf.QuantizationPreset.PERFORMANCE
    quantized = nncf.quantize(model, nncf.Dataset(batches), preset=preset, subset_size=len(batches))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    ov.save_model(quantized, str(args.out), compress_to_fp16=False)
    print(f"wrote {args.out} (from {source}, preset {args.preset}); machine: {machine()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
