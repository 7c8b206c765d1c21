"""MOTChallenge input and output: sequence info, detections, ground truth, results, frames; safe file writes."""

from sotmot.io.frames import FrameReader
from sotmot.io.sequence import read_seqinfo
from sotmot.io.files import (
    atomic_path,
    check_output_dir,
    guard_outputs,
    refuse_overwriting,
    same_file,
    write_bytes_atomic,
    write_files_atomic,
    write_text_atomic,
)
from sotmot.io.mot import (
    detections_from_array,
    GroundTruth,
    SeqInfo,
    format_results,
    gt_style,
    is_plain_name,
    is_row,
    read_detections,
    read_ground_truth,
    read_results,
    results_path,
    write_results,
)

__all__ = [
    "FrameReader", "GroundTruth", "SeqInfo", "atomic_path", "check_output_dir", "detections_from_array",
    "format_results", "gt_style", "guard_outputs", "is_plain_name", "is_row", "read_detections", "read_ground_truth",
    "read_results", "read_seqinfo", "refuse_overwriting", "results_path", "same_file", "write_bytes_atomic",
    "write_files_atomic", "write_results", "write_text_atomic",
]
