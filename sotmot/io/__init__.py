"""MOTChallenge input and output: sequence info, detections, ground truth, results, frames."""

from sotmot.io.frames import FrameReader
from sotmot.io.sequence import read_seqinfo
from sotmot.io.mot import (
    atomic_path,
    check_output_dir,
    detections_from_array,
    GroundTruth,
    SeqInfo,
    format_results,
    gt_style,
    is_plain_name,
    read_detections,
    read_ground_truth,
    read_results,
    refuse_overwriting,
    results_path,
    same_file,
    write_results,
    write_bytes_atomic,
    write_files_atomic,
    write_text_atomic,
)

__all__ = [
    "FrameReader", "GroundTruth", "SeqInfo", "atomic_path", "check_output_dir", "detections_from_array",
    "format_results", "gt_style", "is_plain_name", "read_detections", "read_ground_truth", "read_results",
    "read_seqinfo", "refuse_overwriting", "results_path", "same_file", "write_bytes_atomic", "write_files_atomic",
    "write_results", "write_text_atomic",
]
