"""Whole robot logs into one belief map: time per update, its growth, peak memory, and the laser's line fit.

Usage: ``python benchmarks/bench_logs.py [--limit N] [LOG ...]`` (default: the
Intel and Freiburg 079 corrected logs in ``/work/shared/data/carmen``). Every scan
of each log (the first N with ``--limit``) is read, its segments extracted with the default
:class:`~evmap.sources.laser_params.LaserParams` (fitted to the log's noise), scored by :mod:`evmap.sources.line_fit`
and folded into one map (:func:`evmap.maps.app.log_run.run_log`, the
computation of ``evmap log``). Printed per log: scans, median update (extraction
and update, ms), the ratio of the medians of the last and the first tenth of
the log, the same two in CPU time of the process (steadier than the clock on a
shared machine), peak resident memory (MB, of the whole process so far), total
seconds, mean coverage, median error, the final map's lines, the pairs of its
believed lines (Bel(real) >= 0.5) that merging would relate as drawn (parallel within its
tolerances: duplicates), and of them those its lines' fits relate too (the others are
related only as their corners draw them). The config is ``default``, what ``evmap log`` uses when
not told. Targets: median
<= 30 ms, ratio <= 1.5, peak < 1 GB, Intel under 60 s; coverage >= 0.95 at an
error <= 2 cm on both logs.
"""

from __future__ import annotations

import argparse
import resource
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TypeVar

import numpy as np

from evmap.maps.app.log_run import run_log
from evmap.maps.belief_map import BeliefMap
from evmap.maps.merging import related_pairs
from evmap.sources.config import load_config
from evmap.sources.config_model import Config

DATA = Path("/work/shared/data/carmen")
T = TypeVar("T")
LOGS = [DATA / "intel-corrected.log.gz", DATA / "freiburg-079-corrected.log.gz"]


def bench(path: Path, limit: int | None = None) -> dict[str, float]:
    """The figures of one log (see the module doc), of its first ``limit`` scans if given."""
    times: list[tuple[float, float]] = []
    start = time.perf_counter()
    config = load_config("default")
    run = run_log(path, config, limit=limit, progress=lambda records: _timed(records, times))
    total = time.perf_counter() - start
    per_scan, cpu = np.diff(np.array(times), axis=0).T
    tenth = max(1, len(per_scan) // 10)
    return {
        "scans": run.log.scans,
        "median_ms": 1000 * run.log.per_scan_median,
        "ratio": float(np.median(per_scan[-tenth:]) / np.median(per_scan[:tenth])),
        "cpu_ms": 1000 * float(np.median(cpu)),
        "cpu_ratio": float(np.median(cpu[-tenth:]) / np.median(cpu[:tenth])),
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "total_s": total,
        "coverage": run.log.coverage_mean,
        "error_cm": 100 * run.log.rms_error_median,
        "lines": run.map.graph.number_of_edges(),
        **_related_believed(run.map, config),
    }


def _related_believed(bm: BeliefMap, config: Config) -> dict[str, int]:
    """Pairs of the map's believed lines that merging relates, as drawn (``related``: parallel duplicates left in
    the map), and of them those related by the lines' fits too (``by_fits``; the others only as corners draw
    them)."""
    lines = bm.lines(min_belief=0.5)
    if not lines:
        return {"related": 0, "by_fits": 0}
    drawn = np.array([(line.p, line.q) for line in lines], dtype=float)
    fits = np.array([bm.graph.edge(*bm.ends(line.id))["fit"] for line in lines], dtype=float)
    a, b, _ = related_pairs(drawn[:, 0], drawn[:, 1], config.merge)
    fa, fb, _ = related_pairs(fits[:, 0], fits[:, 1], config.merge)
    return {"related": len(a), "by_fits": len(set(zip(a.tolist(), b.tolist())) & set(zip(fa.tolist(), fb.tolist())))}


def _timed(records: Iterable[T], times: list[tuple[float, float]]) -> Iterator[T]:
    """The records handed on, the clock and the process's CPU time read at each (and at the end) into ``times``."""
    for record in records:
        times.append((time.perf_counter(), time.process_time()))
        yield record
    times.append((time.perf_counter(), time.process_time()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--limit", type=int, help="only the first N scans of each log")
    parser.add_argument("logs", nargs="*", type=Path, default=LOGS)
    args = parser.parse_args()
    print(
        f"{'log':32} {'scans':>6} {'ms/upd':>7} {'last/1st':>8} {'cpu ms':>7} {'last/1st':>8} {'peak MB':>8} "
        f"{'total s':>8} {'cover':>6} {'err cm':>6} {'lines':>6} {'related':>7} {'by fits':>7}"
    )
    for path in args.logs:
        f = bench(path, args.limit)
        print(
            f"{path.name:32} {f['scans']:6d} {f['median_ms']:7.1f} {f['ratio']:8.2f} {f['cpu_ms']:7.1f} "
            f"{f['cpu_ratio']:8.2f} {f['peak_mb']:8.0f} {f['total_s']:8.1f} {f['coverage']:6.3f} {f['error_cm']:6.2f} "
            f"{f['lines']:6d} {f['related']:7d} {f['by_fits']:7d}",
            flush=True,
        )


if __name__ == "__main__":
    main()
