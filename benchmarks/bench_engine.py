"""Benchmark of the evidential engine against pyds and torchbelief (Dempster's rule).

Workloads (random masses, fixed seed):
  (a) frame of 3, full power set, two MassFunction objects
  (b) frame of 10, 50 random focal sets each
  (c) frame of 16, 200 each, through ``combine`` on objects, result included
  (d) frame of 20, 1000 each
  (e) 10,000 independent pairs on {real, noise}, one ``combine_batch`` call

Peers: py-dempster-shafer (pyds, dict of frozensets) and torchbelief (dense
tensors for frames up to 16, ``SparseMass`` for sparse workloads, batched dense
tensors for (e)), on the CPU with one thread. Prints median times and ratios
(peer time / our time). A peer that is not installed is skipped with a line
saying so. Install the peers with ``pip install -e '.[bench]'``.

Each workload runs in a fresh process, ours and its peers together.

Run: ``python benchmarks/bench_engine.py``
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable

import numpy as np

from evidential import Frame, MassFunction, combine, combine_batch

try:
    import pyds
except ImportError:
    pyds = None
try:
    import torch
    import torchbelief as tb

    torch.set_num_threads(1)
except ImportError:
    torch = tb = None


def median_time(f: Callable[[], object], budget: float = 1.0, most: int = 200) -> float:
    """Median wall time of ``f`` over repeats filling about ``budget`` seconds."""
    times: list[float] = []
    while len(times) < most and (len(times) < 3 or sum(times) < budget):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def random_masses(rng: np.random.Generator, n: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k distinct non-empty focal sets on n elements and Dirichlet masses."""
    masks = np.sort(rng.choice((1 << n) - 1, size=k, replace=False) + 1).astype(np.int64)
    return masks, rng.dirichlet(np.ones(k))


def sparse_workload(name: str, n: int, k: int, rng: np.random.Generator) -> list[tuple[str, float]]:
    frame = Frame([f"e{i}" for i in range(n)])
    (a, wa), (b, wb) = random_masses(rng, n, k), random_masses(rng, n, k)
    m1 = MassFunction(frame, dict(zip(a.tolist(), wa.tolist())))
    m2 = MassFunction(frame, dict(zip(b.tolist(), wb.tolist())))
    rows = [("evidential", median_time(lambda: combine(m1, m2, rule="dempster")))]
    if tb is not None:
        s1 = tb.SparseMass(torch.from_numpy(a), torch.from_numpy(wa), n)
        s2 = tb.SparseMass(torch.from_numpy(b), torch.from_numpy(wb), n)
        rows.append(("torchbelief sparse", median_time(lambda: s1.dempster(s2))))
        if n <= 16:
            tf = tb.Frame(n)
            d1, d2 = (torch.from_numpy(m.dense()) for m in (m1, m2))
            rows.append(("torchbelief dense", median_time(lambda: tb.dempster(d1, d2, tf))))
    if pyds is not None:

        def sets(masks):
            return [frozenset(i for i in range(n) if int(mask) >> i & 1) for mask in masks]

        p1 = pyds.MassFunction(dict(zip(sets(a), wa.tolist())))
        p2 = pyds.MassFunction(dict(zip(sets(b), wb.tolist())))
        rows.append(("pyds", median_time(lambda: p1.combine_conjunctive(p2), budget=2.0 if k < 1000 else 0.1)))
    return rows


def batch_workload(rng: np.random.Generator, pairs: int = 10_000) -> list[tuple[str, float]]:
    def batch() -> np.ndarray:
        return np.column_stack([np.zeros(pairs), rng.dirichlet(np.ones(3), pairs)])

    M1, M2 = batch(), batch()
    rows = [("evidential", median_time(lambda: combine_batch(M1, M2, rule="dempster")))]
    if tb is not None:
        tf = tb.Frame(2)
        t1, t2 = torch.from_numpy(M1), torch.from_numpy(M2)
        rows.append(("torchbelief batched", median_time(lambda: tb.dempster(t1, t2, tf))))
    if pyds is not None:
        hyp = [frozenset(), frozenset({"real"}), frozenset({"noise"}), frozenset({"real", "noise"})]
        p1 = [pyds.MassFunction({h: v for h, v in zip(hyp, row) if v > 0}) for row in M1]
        p2 = [pyds.MassFunction({h: v for h, v in zip(hyp, row) if v > 0}) for row in M2]
        rows.append(("pyds pair by pair", median_time(lambda: [x & y for x, y in zip(p1, p2)], budget=2.0)))
    return rows


WORKLOADS: dict[str, Callable[[np.random.Generator], list[tuple[str, float]]]] = {
    "(a) frame 3, full power set": lambda rng: sparse_workload("a", 3, 7, rng),
    "(b) frame 10, 50 focal sets": lambda rng: sparse_workload("b", 10, 50, rng),
    "(c) frame 16, 200 focal sets": lambda rng: sparse_workload("c", 16, 200, rng),
    "(d) frame 20, 1000 focal sets": lambda rng: sparse_workload("d", 20, 1000, rng),
    "(e) 10,000 pairs on {real, noise}": lambda rng: batch_workload(rng),
}


def measure(index: int) -> list[tuple[str, float]]:
    """Run workload ``index`` (ours and the peers, in this process)."""
    title = list(WORKLOADS)[index]
    return WORKLOADS[title](np.random.default_rng([12345, index]))


def main() -> None:
    if pyds is None:
        print("pyds not installed: skipped (pip install py-dempster-shafer==0.7)")
    if tb is None:
        print("torchbelief not installed: skipped (pip install torchbelief==0.3.0 torch==2.13.0)")
    print(f"{'workload':36} {'implementation':22} {'median':>12} {'peer / ours':>12}")
    # each workload in a fresh process (ours and its peers together), so that the memory one
    # workload leaves behind (frames of 20 elements take hundreds of MB) does not tilt the next
    spawn = multiprocessing.get_context("spawn")
    for index, title in enumerate(WORKLOADS):
        with spawn.Pool(1) as pool:
            rows = pool.apply(measure, (index,))
        ours = rows[0][1]
        for name, t in rows:
            ratio = "" if name == "evidential" else f"{t / ours:11.1f}x"
            print(f"{title:36} {name:22} {t * 1e6:10.1f}us {ratio:>12}")


if __name__ == "__main__":
    main()
