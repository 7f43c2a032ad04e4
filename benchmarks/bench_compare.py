"""Benchmark of ``evmap compare``: 200 worlds x 6 rules, a local Dask cluster against ``--scheduler synchronous``.

Prints the wall time of each, the speed-up (target: at least 1.7x on two cores),
the time per world per rule, the median fusion time of each rule on a world,
and checks that both runs give the same numbers (timings aside).

Also the machine's own ceiling, measured before and after: the same pure-Python
loop (no memory traffic, nothing shared) run in one process, then in as many
processes at once as the cluster has workers. On a virtual machine whose cores
slow each other down (shared physical cores, a busy host), N such processes do
less than N times the work, and no scheduling does better than that ratio.

    .venv/bin/python benchmarks/bench_compare.py [--worlds 200] [--seed 1] [--workers N] [--synchronous-first]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import resource
import statistics
import time

from evmap.maps.app.compare_args import DEFAULT_RULES
from evmap.maps.app.compare_runner import run_comparison


def timed(**kwargs):  # type: ignore[no-untyped-def]
    """The comparison, its wall seconds and the CPU seconds of this process and its (reaped) children."""
    start, before = time.perf_counter(), _cpu()
    result = run_comparison(DEFAULT_RULES, **kwargs)
    return result, time.perf_counter() - start, _cpu() - before


def _cpu() -> float:
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def spin(_: int = 0) -> float:
    """Seconds of a fixed pure-Python loop (about 1 s)."""
    start, total = time.perf_counter(), 0
    for i in range(15_000_000):
        total += i
    return time.perf_counter() - start


def ceiling(workers: int) -> float:
    """How much faster ``workers`` processes get through ``workers`` loops than one process through one each
    after the other: the loop's time alone against the wall time of all at once, times ``workers``."""
    alone = statistics.median(spin() for _ in range(3))
    with multiprocessing.get_context("spawn").Pool(workers) as pool:
        pool.map(spin, range(workers))  # the processes started and warm
        start = time.perf_counter()
        pool.map(spin, range(workers), chunksize=1)
        together = time.perf_counter() - start
    return workers * alone / together


def numbers(rows):  # type: ignore[no-untyped-def]
    return [{k: v for k, v in row.items() if not k.startswith("seconds")} for row in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--workers", type=int, help="processes of the local cluster (default: one per CPU)")
    parser.add_argument("--synchronous-first", action="store_true", help="run the synchronous peer first")
    args = parser.parse_args()
    rules = len(DEFAULT_RULES)

    def cluster():  # type: ignore[no-untyped-def]
        return timed(worlds=args.worlds, seed=args.seed, workers=args.workers, progress=False)

    def synchronous():  # type: ignore[no-untyped-def]
        return timed(worlds=args.worlds, seed=args.seed, scheduler="synchronous", progress=False)

    workers = args.workers or os.cpu_count() or 1
    before = ceiling(workers)
    if args.synchronous_first:
        (peer, peer_wall, peer_cpu), (result, wall, cpu) = synchronous(), cluster()
    else:
        (result, wall, cpu), (peer, peer_wall, peer_cpu) = cluster(), synchronous()
    after = ceiling(workers)

    order = "synchronous first" if args.synchronous_first else "cluster first"
    print(f"{args.worlds} worlds x {rules} rules on a local Dask cluster: {wall:.1f} s wall ({wall / 60:.2f} min)")
    print(
        f"  synchronous (one process): {peer_wall:.1f} s; speed-up x{peer_wall / wall:.2f} (target >= 1.7 on 2 cores;"
        f" {order})"
    )
    print(
        f"  the machine's ceiling for {workers} processes (a pure-Python loop, one alone against {workers} at once):"
        f" x{before:.2f} before, x{after:.2f} after; the cluster reached {peer_wall / wall / max(before, after):.0%}"
        " of the higher"
    )
    print(f"  CPU seconds: cluster {cpu:.1f} (cores busy {cpu / wall:.2f}), synchronous {peer_cpu:.1f}")
    print(f"  per world per rule: {1000 * wall / (args.worlds * rules):.1f} ms wall on the cluster")
    same = numbers(result.rows) == numbers(peer.rows) and numbers(result.summary) == numbers(peer.summary)
    print(f"  same numbers on both schedulers: {same}")
    sim = statistics.median(r["seconds_simulate"] for r in result.rows if r["rule"] == DEFAULT_RULES[0])
    print(f"  median sensing per world (once, shared by the rules): {1000 * sim:.1f} ms")
    print("  median fusion per world, by rule (ms):")
    base = statistics.median(r["seconds_per_world"] for r in result.rows if r["rule"] == "dempster")
    for rule in DEFAULT_RULES:
        med = statistics.median(r["seconds_per_world"] for r in result.rows if r["rule"] == rule)
        print(f"    {rule:<13} {1000 * med:7.1f}   x{med / base:.2f} of dempster")


if __name__ == "__main__":
    main()
