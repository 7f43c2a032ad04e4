"""Benchmark of the evidential engine against pyds and torchbelief (Dempster's rule).

Workloads (random masses, fixed seed):
  (a) frame of 3, full power set, two MassFunction objects
  (b) frame of 10, 50 random focal sets each
  (c) frame of 16, 200 each, through ``combine`` on objects, result included
  (d) frame of 20, 1000 each
  (e) 10,000 independent pairs on {real, noise}, one ``combine_batch`` call
  (f) frame of 20, one sparse mass function (1000 focal sets): belief and
      plausibility of 100 sets in one call each, and the pignistic probabilities
  (g) frame of 20, the dense pignistic transform of all 2**20 sets (peak extra
      memory per call by ``tracemalloc`` printed beside it)
  (h) one combination of two MassFunction objects on {real, noise}
  (i) 100 mass functions on a frame of 10 (8 focal sets each) in one ``combine``
      call, against folding them pairwise with ``combine``

Peers: py-dempster-shafer (pyds, dict of frozensets) and torchbelief (dense
tensors for frames up to 16, ``SparseMass`` for sparse workloads, batched dense
tensors for (e)), on the CPU with one thread. Prints median times and the
ratio peer time / our time (of the medians, then the lowest and highest ratio
of the rounds; :func:`measured` says how the rounds are laid out). A peer that
is not installed is skipped with a line saying so. Install the peers with
``pip install -e '.[bench]'``.

For frames of up to 16 elements, the row "numpy floor (kernel)" times the
engine's pairwise sums alone (intersections, products, one ``bincount``, one
scan), without objects or normalisation: what numpy cannot go below. Below the
rows, ours and the floor are timed again call by call (:func:`call_by_call`):
one call of each, back to back, which one first alternating, a thousand times,
so that every pair of calls sees the same load; printed as ours / floor, the
median of the pairs' ratios with its quartiles and the ratio of the fastest
calls (timeit's advice: the minimum is what the machine does unhindered), in
wall-clock and in CPU time (``time.thread_time``).

Each workload runs in a fresh process, ours and its peers together; ours is
also timed alone in a fresh process that loads no peer (the "alone" row), as a
user of evidential runs it: loading torch changes how the process allocates
memory, and a benchmark that only ran beside it could flatter us.

Run: ``python benchmarks/bench_engine.py`` (``--only c`` for workload (c) alone, ``--only ce`` for two).
"""

from __future__ import annotations

import argparse
import multiprocessing
import time
import tracemalloc
from collections.abc import Callable
from functools import reduce
from typing import NamedTuple

import numpy as np

from evidential import Frame, MassFunction, combine, combine_batch
from evidential import transforms as T

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
    notes: tuple[str, ...] = ()
    """Lines printed below the workload's rows."""


FLOOR_PAIRS = 1000
"""Pairs of calls (ours, the floor) of :func:`call_by_call`."""


def call_by_call(ours: Callable[[], object], floor: Callable[[], object], pairs: int = FLOOR_PAIRS) -> np.ndarray:
    """Seconds per call of ours and of the floor, pair by pair: (pairs, 2, 2) for (ours, floor) x (wall, CPU).

    Each pair is one call of each, back to back (ours first in even pairs, the
    floor first in odd ones), so that both see the same state of the machine:
    its load changes over seconds, a pair lasts a millisecond.
    """
    for f in (ours, floor, ours, floor):
        f()
    calls = (ours, floor)
    times = np.empty((pairs, 2, 2))
    for i in range(pairs):
        for j in (0, 1) if i % 2 == 0 else (1, 0):
            f = calls[j]
            c, t = time.thread_time_ns(), time.perf_counter_ns()
            f()
            times[i, j] = time.perf_counter_ns() - t, time.thread_time_ns() - c
    return times / 1e9


def floor_note(times: np.ndarray) -> str:
    """ours / floor from :func:`call_by_call`: the median of the pairs' ratios (quartiles), the ratio of the minima."""
    parts = []
    for clock, k in (("wall", 0), ("CPU", 1)):
        ratios = times[:, 0, k] / times[:, 1, k]
        q1, median, q3 = np.quantile(ratios, [0.25, 0.5, 0.75])
        fastest = times[:, 0, k].min() / times[:, 1, k].min()
        parts.append(f"{clock} {median:.2f}x ({q1:.2f}-{q3:.2f}), fastest {fastest:.2f}x")
    return f"ours / numpy floor, {len(times)} pairs of calls back to back: " + "; ".join(parts)


def orders(k: int) -> list[list[int]]:
    """Orders of ``k`` implementations in which each runs right after every other one equally
    often: a Williams design, ``k`` orders (``2k`` for odd ``k``).

    Examples
    --------
    >>> orders(4)
    [[0, 1, 3, 2], [1, 2, 0, 3], [2, 3, 1, 0], [3, 0, 2, 1]]
    """
    first = [0] + [(j + 1) // 2 if j % 2 else k - j // 2 for j in range(1, k)]
    rows = [[(x + r) % k for x in first] for r in range(k)]
    return rows + [row[::-1] for row in rows] if k % 2 else rows


def rounds_of(impls: list[Impl], budget: float = 3.0, most: int = 25) -> list[np.ndarray]:
    """Seconds per call of each implementation, in rounds that alternate between them.

    Each round times every implementation once, over a batch of calls lasting
    about 5 ms (counted on a second call: the first of a fresh process can take
    twice as long), so that all see the same state of the machine (this VM's speed
    drifts within a process). Whatever runs right after a peer that sweeps large
    tensors (torchbelief dense) finds the caches cold, so the order changes from
    round to round by :func:`orders`, each implementation following each other
    equally often; the rounds end on a whole cycle of orders. (Rotating one order
    would not do: with three implementations or more, the same one would always
    follow the slow peer.)
    """
    number = []
    for _, f in impls:
        f()
        t = time.perf_counter()
        f()
        number.append(max(1, int(0.005 / max(time.perf_counter() - t, 1e-7))))
    times: list[list[float]] = [[] for _ in impls]
    plan = orders(len(impls))
    start = time.perf_counter()
    while len(times[0]) % len(plan) or (
        len(times[0]) < most and (len(times[0]) < 5 or time.perf_counter() - start < budget)
    ):
        for i in plan[len(times[0]) % len(plan)]:
            f, k = impls[i][1], number[i]
            t = time.perf_counter()
            for _ in range(k):
                f()
            times[i].append((time.perf_counter() - t) / k)
    return [np.array(ts) for ts in times]


def measured(close: list[Impl], slow: list[Impl]) -> list[Row]:
    """Ours (first of ``close``) and the peers: the close ones timed in alternating
    rounds with ours, then each slow one (pure Python, 50x and more) in rounds of
    its own, after the others: its millions of small objects would slow whatever
    runs next, an artefact of the benchmark rather than a property of either.
    pyds on frames of 2 or 3 elements, within a few times ours, is a close one:
    timed in other rounds than ours, its ratio would follow the machine's drift."""
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
        pairs = call_by_call(impls[0][1], bare_kernel)
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
        (impls if n <= 3 else slow).append(("pyds", lambda: p1.combine_conjunctive(p2)))
    rows = measured(impls, slow)
    if n <= 16:
        rows[0] = rows[0]._replace(notes=(floor_note(pairs),))
    return rows


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


def query_workload(rng: np.random.Generator) -> list[Row]:
    n, k = 20, 1000
    frame = Frame([f"e{i}" for i in range(n)])
    masks, weights = random_masses(rng, n, k)
    m = MassFunction(frame, dict(zip(masks.tolist(), weights.tolist())))
    queries = rng.integers(1, 1 << n, size=100)

    def ours() -> object:
        return m.belief(queries), m.plausibility(queries), m.pignistic()

    impls: list[Impl] = [("evidential", ours)]
    slow: list[Impl] = []
    if tb is not None:
        s = tb.SparseMass(torch.from_numpy(masks), torch.from_numpy(weights), n)
        events = torch.from_numpy(queries)
        impls.append(("torchbelief sparse", lambda: (s.belief(events), s.plausibility(events), s.pignistic())))
    if pyds is not None:
        p = pyds.MassFunction({frozenset(i for i in range(n) if int(x) >> i & 1): w for x, w in zip(masks, weights)})
        sets = [frozenset(i for i in range(n) if int(q) >> i & 1) for q in queries]
        slow.append(("pyds", lambda: ([p.bel(a) for a in sets], [p.pl(a) for a in sets], p.pignistic())))
    return measured(impls, slow)


def peak_memory(f: Callable[[], object]) -> float:
    """Peak memory allocated during one call of ``f``, in MB (tracemalloc: numpy and torch CPU tensors)."""
    tracemalloc.start()
    f()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6


def pignistic_workload(rng: np.random.Generator) -> list[Row]:
    n = 20
    dense = rng.dirichlet(np.ones(1 << n))
    impls: list[Impl] = [("evidential", lambda: T.pignistic(dense))]
    if tb is not None:  # torchbelief's dense frames stop at 16: its sparse mass over all the sets
        s = tb.SparseMass(torch.arange(1 << n), torch.from_numpy(dense), n)
        impls.append(("torchbelief sparse", s.pignistic))
    for name, f in impls:
        print(f"(g) peak extra memory per call, {name}: {peak_memory(f):.1f} MB")
    return measured(impls, [])


def pair_workload(rng: np.random.Generator) -> list[Row]:
    frame = Frame(["real", "noise"])
    (a, b) = (rng.dirichlet(np.ones(3)) for _ in range(2))
    m1 = MassFunction(frame, dict(zip([1, 2, 3], a.tolist())))
    m2 = MassFunction(frame, dict(zip([1, 2, 3], b.tolist())))
    impls: list[Impl] = [("evidential", lambda: combine(m1, m2))]
    if tb is not None:
        s1 = tb.SparseMass(torch.tensor([1, 2, 3]), torch.from_numpy(a), 2)
        s2 = tb.SparseMass(torch.tensor([1, 2, 3]), torch.from_numpy(b), 2)
        impls.append(("torchbelief sparse", lambda: s1.dempster(s2)))
    if pyds is not None:
        hyp = [frozenset({"real"}), frozenset({"noise"}), frozenset({"real", "noise"})]
        p1, p2 = pyds.MassFunction(dict(zip(hyp, a.tolist()))), pyds.MassFunction(dict(zip(hyp, b.tolist())))
        impls.append(("pyds", lambda: p1 & p2))
    return measured(impls, [])


def nary_workload(rng: np.random.Generator) -> list[Row]:
    n, k = 10, 8
    frame = Frame([f"e{i}" for i in range(n)])
    masses = [MassFunction(frame, dict(zip(*(x.tolist() for x in random_masses(rng, n, k))))) for _ in range(100)]
    impls: list[Impl] = [
        ("evidential", lambda: combine(*masses)),
        ("evidential fold", lambda: reduce(lambda x, y: combine(x, y), masses)),
    ]
    slow: list[Impl] = []
    if pyds is not None:
        ps = [
            pyds.MassFunction(
                {frozenset(i for i in range(n) if x >> i & 1): w for x, w in zip(m.masks.tolist(), m.masses)}
            )
            for m in masses
        ]
        slow.append(("pyds", lambda: ps[0].combine_conjunctive(ps[1:])))
    return measured(impls, slow)


WORKLOADS: dict[str, Callable[[np.random.Generator], list[Row]]] = {
    "(a) frame 3, full power set": lambda rng: sparse_workload(3, 7, rng),
    "(b) frame 10, 50 focal sets": lambda rng: sparse_workload(10, 50, rng),
    "(c) frame 16, 200 focal sets": lambda rng: sparse_workload(16, 200, rng),
    "(d) frame 20, 1000 focal sets": lambda rng: sparse_workload(20, 1000, rng),
    "(e) 10,000 pairs on {real, noise}": lambda rng: batch_workload(rng),
    "(f) frame 20, 100 bel + 100 pl + BetP": query_workload,
    "(g) frame 20, dense pignistic": pignistic_workload,
    "(h) one pair on {real, noise}": pair_workload,
    "(i) 100 sources, frame 10, one call": nary_workload,
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
    parser = argparse.ArgumentParser(description=__doc__.partition("\n")[0])
    parser.add_argument("--only", default="", help="the letters of the workloads to run (default: all)")
    only = parser.parse_args().only
    load_peers()
    if pyds is None:
        print("pyds not installed: skipped (pip install py-dempster-shafer==0.7)")
    if tb is None:
        print("torchbelief not installed: skipped (pip install torchbelief==0.3.0 torch==2.13.0)")
    print(f"{'workload':36} {'implementation':22} {'median':>12} {'peer / ours':>12} {'rounds':>14}")
    for index, title in enumerate(WORKLOADS):
        if only and title[1] not in only:
            continue
        rows = in_fresh_process(index, peers=True)
        alone = in_fresh_process(index, peers=False)[0]._replace(name="evidential alone")
        for row in [rows[0], alone, *rows[1:]]:
            ratio = spread = ""
            if row is not rows[0] and row is not alone:
                ratio = f"{row.median / rows[0].median:11.1f}x"
                spread = f"{row.ratios.min():.1f}-{row.ratios.max():.1f}x"
            print(f"{title:36} {row.name:22} {row.median * 1e6:10.1f}us {ratio:>12} {spread:>14}")
        for note in rows[0].notes:
            print(f"{title:36} {note}")


if __name__ == "__main__":
    main()
