"""Laser line extraction on whole CARMEN logs: PLE coverage and error, and time per scan.

Usage: ``python benchmarks/bench_logs.py [LOG ...]`` (default: the Intel and
Freiburg 079 corrected logs in ``/work/shared/data/carmen``). Every scan of each
log is read, its segments extracted with the default
:class:`~evmap.sources.laser.LaserParams` and scored by
:mod:`evmap.sources.line_fit`. Targets: mean coverage >= 0.95 at a median
per-scan error <= 2 cm on both logs.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from evmap.sources.laser import LaserParams, laser_segments
from evmap.sources.line_fit import log_fit, scan_fit
from evmap.sources.logs.carmen import read_carmen

DATA = Path("/work/shared/data/carmen")
LOGS = [DATA / "intel-corrected.log.gz", DATA / "freiburg-079-corrected.log.gz"]


def bench(path: Path, params: LaserParams) -> tuple[int, float, float, float]:
    """Scans, mean coverage, median error (m) and extraction time per scan (s) of one log."""
    fits, seconds = [], 0.0
    for record in read_carmen(path):
        start = time.perf_counter()
        segs = laser_segments(record.scan, params, record.index)
        seconds += time.perf_counter() - start
        fits.append(scan_fit(record.scan, segs.segments.p, segs.segments.q))
    coverage, error = log_fit(fits)
    return len(fits), coverage, error, seconds / max(len(fits), 1)


def main(paths: list[str]) -> None:
    params = LaserParams()
    print(f"params: {params.model_dump()}")
    print(f"{'log':32} {'scans':>6} {'coverage':>9} {'error cm':>9} {'ms/scan':>8}")
    for path in map(Path, paths or LOGS):
        scans, coverage, error, per_scan = bench(path, params)
        print(f"{path.name:32} {scans:6d} {coverage:9.3f} {100 * error:9.2f} {1000 * per_scan:8.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
