"""Benchmark of the evidential engine against pyds and torchbelief (Dempster's rule).

Workloads (random masses, fixed seed):
  (a) frame of 3, full power set, two MassFunction objects
  (b) frame of 10, 50 random focal sets each
  (c) frame of 16, 200 each, through ``combine`` on objects, result included
  (d) frame of 20, 1000 each
  (e) 10,000 independent pairs on {real, noise}, one ``combine_batch`` call

Peers: py-dempster-shafer (pyds, dict of frozensets) and torchbelief (dense
tensors for frames up to 16, ``SparseMass`` for sparse workloads, batched dense
tensors for (e)), on the CPU with one thread. Prints median times and the
ratio peer time / our time (of the medians, then the lowest and highest ratio
of the rounds; :func:`measured` says how the rounds are laid out). A peer that
is not installed is skipped with a line saying so. Install the peers with
``pip install -e '.[bench]'``.

For frames of up to 16 elements, the row "numpy floor (kernel)" times the
engine's pairwise sums alone (intersections, products, one ``bincount``, one
scan), without objects or normalisation: what numpy cannot go below.

Each workload runs in a fresh process, ours and its peers together; ours is
also timed alone in a fresh process that loads no peer (the "alone" row), as a
user of evidential runs it: loading torch changes how the process allocates
memory, and a benchmark that only ran beside it could flatter us.

Run: ``python benchmarks/bench_engine.py``
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from evidential import Frame, MassFunction, combine, combine_batch

pyds = torch = tb = None


def load_peers() -> None:
    """Import the peers that are installed (into this module's globals)."""
    global pyds, torch, tb
    try:
        import pyds
    except ImportError:
        pass
    try:
        import torch
        import torchbelief as tb

        torch.set_num_threads(1)
    except ImportError:
        torch = tb = None


Impl = tuple[str, Callable[[], object]]


class Row(NamedTuple):
    name: str
    median: float
    """Seconds per call, median of the rounds."""
    ratios: np.ndarray
    """This implementation's time over ours, round by round."""


def rounds_of(impls: list[Impl], budget: float = 3.0, most: int = 25) -> list[np.ndarray]:
    """Seconds per call of each implementation, in rounds that alternate between them.

    Each round times every implementation once, over a batch of calls lasting
    about 5 ms, so that all see the same state of the machine (this VM's speed
    drifts within a process).
    """
    number = []
    for _, f in impls:
        t = time.perf_counter()
        f()
        number.append(max(1, int(0.005 / max(time.perf_counter() - t, 1e-7))))
    times: list[list[float]] = [[] for _ in impls]
    start = time.perf_counter()
    while len(times[0]) < most and (len(times[0]) < 5 or time.perf_counter() - start < budget):
        for (_, f), k, ts in zip(impls, number, times):
            t = time.perf_counter()
            for _ in range(k):
                f()
            ts.append((time.perf_counter() - t) / k)
    return [np.array(ts) for ts in times]


def measured(close: list[Impl], slow: list[Impl]) -> list[Row]:
    """Ours (first of ``close``) and the peers: the close ones timed in alternating
    rounds with ours, then each slow one (pure Python, 50x and more) in rounds of
    its own, after the others: its millions of small objects would slow whatever
    runs next, an artefact of the benchmark rather than a property of either."""
    times = rounds_of(close)
    rows = [Row(name, float(np.median(ts)), ts / times[0]) for (name, _), ts in zip(close, times)]
    for name, f in slow:
        (ts,) = rounds_of([(name, f)])
        rows.append(Row(name, float(np.median(ts)), ts / rows[0].median))
    return rows


def random_masses(rng: np.random.Generator, n: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k distinct non-empty focal sets on n elements and Dirichlet masses."""
    masks = np.sort(rng.choice((1 << n) - 1, size=k, replace=False) + 1).astype(np.int64)
    return masks, rng.dirichlet(np.ones(k))


def sparse_workload(n: int, k: int, rng: np.random.Generator) -> list[Row]:
    frame = Frame([f"e{i}" for i in range(n)])
    (a, wa), (b, wb) = random_masses(rng, n, k), random_masses(rng, n, k)
    m1 = MassFunction(frame, dict(zip(a.tolist(), wa.tolist())))
    m2 = MassFunction(frame, dict(zip(b.tolist(), wb.tolist())))
    impls: list[Impl] = [("evidential", lambda: combine(m1, m2, rule="dempster"))]
    if n <= 16:

        def bare_kernel() -> np.ndarray:
            """The engine's pairwise sums alone (no objects, no normalisation): numpy's floor here."""
            table = np.bincount(np.bitwise_and.outer(a, b).ravel(), np.multiply.outer(wa, wb).ravel(), 1 << n)
            return np.flatnonzero(table != 0)

        impls.append(("numpy floor (kernel)", bare_kernel))
    slow: list[Impl] = []
    if tb is not None:
        s1 = tb.SparseMass(torch.from_numpy(a), torch.from_numpy(wa), n)
        s2 = tb.SparseMass(torch.from_numpy(b), torch.from_numpy(wb), n)
        impls.append(("torchbelief sparse", lambda: s1.dempster(s2)))
        if n <= 16:
            tf = tb.Frame(n)
            d1, d2 = (torch.from_numpy(m.dense()) for m in (m1, m2))
            impls.append(("torchbelief dense", lambda: tb.dempster(d1, d2, tf)))
    if pyds is not None:

        def sets(masks):
            return [frozenset(i for i in range(n) if int(mask) >> i & 1) for mask in masks]

        p1 = pyds.MassFunction(dict(zip(sets(a), wa.tolist())))
        p2 = pyds.MassFunction(dict(zip(sets(b), wb.tolist())))
        slow.append(("pyds", lambda: p1.combine_conjunctive(p2)))
    return measured(impls, slow)


def batch_workload(rng: np.random.Generator, pairs: int = 10_000) -> list[Row]:
    def batch() -> np.ndarray:
        return np.column_stack([np.zeros(pairs), rng.dirichlet(np.ones(3), pairs)])

    M1, M2 = batch(), batch()
    impls: list[Impl] = [("evidential", lambda: combine_batch(M1, M2, rule="dempster"))]
    slow: list[Impl] = []
    if tb is not None:
        tf = tb.Frame(2)
        t1, t2 = torch.from_numpy(M1), torch.from_numpy(M2)
        impls.append(("torchbelief batched", lambda: tb.dempster(t1, t2, tf)))
    if pyds is not None:
        hyp = [frozenset(), frozenset({"real"}), frozenset({"noise"}), frozenset({"real", "noise"})]
        p1 = [pyds.MassFunction({h: v for h, v in zip(hyp, row) if v > 0}) for row in M1]
        p2 = [pyds.MassFunction({h: v for h, v in zip(hyp, row) if v > 0}) for row in M2]
        slow.append(("pyds pair by pair", lambda: [x & y for x, y in zip(p1, p2)]))
    return measured(impls, slow)


WORKLOADS: dict[str, Callable[[np.random.Generator], list[Row]]] = {
    "(a) frame 3, full power set": lambda rng: sparse_workload(3, 7, rng),
    "(b) frame 10, 50 focal sets": lambda rng: sparse_workload(10, 50, rng),
    "(c) frame 16, 200 focal sets": lambda rng: sparse_workload(16, 200, rng),
    "(d) frame 20, 1000 focal sets": lambda rng: sparse_workload(20, 1000, rng),
    "(e) 10,000 pairs on {real, noise}": lambda rng: batch_workload(rng),
}


def measure(index: int, peers: bool) -> list[Row]:
    """Run workload ``index`` in this process: ours and the peers, or ours alone."""
    if peers:
        load_peers()
    title = list(WORKLOADS)[index]
    return WORKLOADS[title](np.random.default_rng([12345, index]))


def in_fresh_process(index: int, peers: bool) -> list[Row]:
    # a fresh process per run, so that the memory one workload leaves behind (frames of
    # 20 elements take hundreds of MB) does not tilt the next
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        return pool.apply(measure, (index, peers))


def main() -> None:
    load_peers()
    if pyds is None:
        print("pyds not installed: skipped (pip install py-dempster-shafer==0.7)")
    if tb is None:
        print("torchbelief not installed: skipped (pip install torchbelief==0.3.0 torch==2.13.0)")
    print(f"{'workload':36} {'implementation':22} {'median':>12} {'peer / ours':>12} {'rounds':>14}")
    for index, title in enumerate(WORKLOADS):
        rows = in_fresh_process(index, peers=True)
        alone = in_fresh_process(index, peers=False)[0]._replace(name="evidential alone")
        for row in [rows[0], alone, *rows[1:]]:
            ratio = spread = ""
            if row is not rows[0] and row is not alone:
                ratio = f"{row.median / rows[0].median:11.1f}x"
                spread = f"{row.ratios.min():.1f}-{row.ratios.max():.1f}x"
            print(f"{title:36} {row.name:22} {row.median * 1e6:10.1f}us {ratio:>12} {spread:>14}")


if __name__ == "__main__":
    main()
