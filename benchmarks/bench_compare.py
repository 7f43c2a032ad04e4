"""Benchmark of ``evmap compare``: 200 worlds x 6 rules, a local Dask cluster against ``--scheduler synchronous``.

Prints the wall time of each, the speed-up (target: at least 1.7x on two cores),
the time per world per rule, the median fusion time of each rule on a world,
the peak memory of the largest worker and of this process, and checks that both
runs give the same numbers (timings aside).

    .venv/bin/python benchmarks/bench_compare.py [--worlds 200] [--seed 1] [--workers N] [--synchronous-first]
"""

from __future__ import annotations

import argparse
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

    if args.synchronous_first:
        (peer, peer_wall, peer_cpu), (result, wall, cpu) = synchronous(), cluster()
    else:
        (result, wall, cpu), (peer, peer_wall, peer_cpu) = cluster(), synchronous()

    order = "synchronous first" if args.synchronous_first else "cluster first"
    print(f"{args.worlds} worlds x {rules} rules on a local Dask cluster: {wall:.1f} s wall ({wall / 60:.2f} min)")
    print(
        f"  synchronous (one process): {peer_wall:.1f} s; speed-up x{peer_wall / wall:.2f} (target >= 1.7 on 2 cores;"
        f" {order})"
    )
    print(f"  CPU seconds: cluster {cpu:.1f} (cores busy {cpu / wall:.2f}), synchronous {peer_cpu:.1f}")
    worker = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  peak memory: {worker:.0f} MB the largest worker, {own:.0f} MB this process")
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
