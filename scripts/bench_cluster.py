#!/usr/bin/env python3
"""What the Dask cluster path costs: the same sequences through ``--workers N`` and through a local cluster.

Every sequence with frames under ``--data`` is tracked three ways with the
same configuration: one process (serial), ``--workers N`` processes on this
machine, and a Dask cluster of ``N`` single-thread worker processes started
here on the loopback address (``distributed.LocalCluster``; the same
scheduler protocol a real cluster speaks). One sequence is one task: the
split is by sequence. The cluster runs twice: with fresh worker processes
(spawned: imports and the model load on their first task) and again with the
same, warm workers, as a long-lived cluster serves. Prints the wall time of
each way, the cluster's overhead against ``--workers N`` (in all and per
sequence), and whether the results and flags are byte-identical to the
serial run; writes JSON.

    python scripts/bench_cluster.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --json bench_cluster.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from sotmot.runs import track_many
from common import DEFAULT_DATA, named_sequences
from sotmot.config import TrackerConfig
from sotmot.io import read_seqinfo, write_text_atomic
from sotmot.versions import machine


def outputs(folder: Path, names: list[str]) -> dict[str, bytes]:
    """Every results and flags file of ``names`` in ``folder``."""
    return {f"{n}{s}": (folder / f"{n}{s}").read_bytes() for n in names for s in (".txt", ".flags.csv")}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--workers", type=int, default=2, help="processes and cluster workers (default: %(default)s)")
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--json", type=Path, help="write the numbers here")
    parser.add_argument("--results", type=Path, help="keep the three ways' results here (default: a temp folder)")
    args = parser.parse_args(argv)
    try:
        import distributed
    except ImportError as exc:
        print(f"bench_cluster needs the dask extra ({exc}): pip install -e '.[dask]'", file=sys.stderr)
        return 2
    seqs = named_sequences(parser, args.data, args.sequences)
    if not seqs:
        print(f"no sequences with frames under {args.data}", file=sys.stderr)
        return 1
    names = [read_seqinfo(s).name for s in seqs]
    config = TrackerConfig().replace("appearance", model=args.model)
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="sotmot-cluster-") as scratch:
        tmp = args.results or scratch

        def timed(way: str, **kwargs) -> list:
            start = time.perf_counter()
            outcomes = track_many(seqs, Path(tmp) / way, config, **kwargs)
            seconds[way] = time.perf_counter() - start
            failed = [o.message for o in outcomes if o.status == "failed"]
            if failed:
                raise SystemExit(f"{way}: " + "; ".join(failed))
            print(f"{way}: {seconds[way]:.1f} s", file=sys.stderr, flush=True)
            return outcomes

        timed("serial")
        timed(f"workers {args.workers}", workers=args.workers)
        with distributed.LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                      host="127.0.0.1", dashboard_address=None) as cluster:
            address = "dask://" + cluster.scheduler_address.removeprefix("tcp://")
            timed("cluster", cluster=address)  # fresh workers: imports and the model load on the first task
            timed("cluster, warm", cluster=address)  # the same workers again, as a long-lived cluster serves
        serial = outputs(Path(tmp) / "serial", names)
        same = {way: outputs(Path(tmp) / way, names) == serial for way in seconds if way != "serial"}
    pool = seconds[f"workers {args.workers}"]
    overhead = {way: seconds[way] - pool for way in ("cluster", "cluster, warm")}
    lines = [f"{len(seqs)} sequences ({', '.join(names)}); one sequence per task", "",
             f"{'way':<14}{'seconds':>9}{'identical to serial':>21}"]
    lines += [f"{way:<14}{s:9.1f}{('yes' if same[way] else 'NO') if way in same else '-':>21}"
              for way, s in seconds.items()]
    lines += [""] + [f"{way} overhead against --workers {args.workers}: {extra:+.1f} s ({100 * extra / pool:+.1f} %), "
                     f"{extra / len(seqs):+.2f} s per sequence" for way, extra in overhead.items()]
    lines.append(f"machine: {machine()}")
    print("\n".join(lines))
    if args.json:
        write_text_atomic(args.json, json.dumps({
            "machine": machine(), "sequences": names, "workers": args.workers, "seconds": seconds,
            "identical_to_serial": same, "overhead_seconds": overhead,
            "overhead_share": {way: extra / pool for way, extra in overhead.items()},
        }, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
