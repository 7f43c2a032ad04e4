"""Benchmark of ``evmap compare``: 200 worlds x 6 rules on a local Dask cluster (target: under 10 minutes).

Prints the wall time, the time per world per rule, the median fusion time of
each rule on a world, and the speed-up against Dask's synchronous scheduler
(one process) measured in the same run on the first worlds.

    .venv/bin/python benchmarks/bench_compare.py [--worlds 200] [--seed 1] [--peer-worlds 20]
"""

from __future__ import annotations

import argparse
import statistics
import time

from evmap.maps.app.compare import DEFAULT_RULES, run_comparison


def timed(**kwargs):  # type: ignore[no-untyped-def]
    start = time.perf_counter()
    result = run_comparison(DEFAULT_RULES, **kwargs)
    return result, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--peer-worlds", type=int, default=20, help="worlds of the single-process peer run")
    args = parser.parse_args()
    rules = len(DEFAULT_RULES)

    result, wall = timed(worlds=args.worlds, seed=args.seed, progress=False)
    _peer, peer_wall = timed(worlds=args.peer_worlds, seed=args.seed, scheduler="synchronous", progress=False)

    print(
        f"{args.worlds} worlds x {rules} rules on a local Dask cluster: {wall:.1f} s wall "
        f"({wall / 60:.2f} min; target < 10 min)"
    )
    print(f"  per world per rule: {1000 * wall / (args.worlds * rules):.1f} ms wall")
    print(
        f"  single process (synchronous, {args.peer_worlds} worlds): "
        f"{1000 * peer_wall / (args.peer_worlds * rules):.1f} ms per world per rule; "
        f"cluster speed-up x{(peer_wall / args.peer_worlds) / (wall / args.worlds):.2f}"
    )
    busy = sum(r["seconds_per_world"] for r in result.rows) + sum(
        r["seconds_simulate"] for r in result.rows if r["rule"] == DEFAULT_RULES[0]
    )
    print(
        f"  sensing + fusion measured inside the tasks: {busy:.1f} s, x{busy / wall:.2f} the wall time "
        "(world generation and Dask overhead not included)"
    )
    sim = statistics.median(r["seconds_simulate"] for r in result.rows if r["rule"] == DEFAULT_RULES[0])
    print(f"  median sensing per world (once, shared by the rules): {1000 * sim:.1f} ms")
    print("  median fusion per world, by rule (ms):")
    base = statistics.median(r["seconds_per_world"] for r in result.rows if r["rule"] == "dempster")
    for rule in DEFAULT_RULES:
        med = statistics.median(r["seconds_per_world"] for r in result.rows if r["rule"] == rule)
        print(f"    {rule:<13} {1000 * med:7.1f}   x{med / base:.2f} of dempster")


if __name__ == "__main__":
    main()
