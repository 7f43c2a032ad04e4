"""Benchmark of the engine's newer operations against pyds where pyds has an equivalent.

Operations (random masses, fixed seed), each timed for ours and pyds in the same
process, in alternating rounds (ours, pyds, ours, ...); the medians are printed
with the ratio pyds / ours (> 1: ours is faster), in µs:

  monte-carlo   Dempster's rule estimated from 10,000 samples, 3 sources on 30
                elements with 40 focal sets each (pyds ``combine_conjunctive(...,
                sample_count=...)``; ours ``monte_carlo_combine``)
  pignistic     BetP of a mass function with 200 focal sets on 16 elements
  condition     unnormalised conditioning of the same (``normalization=False``)
  nonspecific   the nonspecificity (pyds ``hartley_measure``)
  idm           the imprecise Dirichlet model of counts on 20 elements (s = 1)
  consonant     the consonant mass function of a possibility distribution on 20 elements
  single ...    one set's belief, plausibility or commonality: ``bel 2``, ``pl 2``, ``q 2`` of
                {real} on {real, noise} with 2 focal sets, ``bel 3``, ``pl 3`` of {a, b} on
                {a, b, c} with 5 (ours given the label, pyds a ready frozenset)

No timing is asserted in the tests. Run: ``python benchmarks/bench_engine_ops.py``
(pyds from ``pip install -e '.[bench]'``; skipped with a line if missing).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

from evidential import (
    Frame,
    MassFunction,
    condition,
    consonant_from_possibility,
    imprecise_dirichlet,
    monte_carlo_combine,
    nonspecificity,
)

ROUNDS = 7


def random_mass(frame: Frame, rng: np.random.Generator, count: int) -> MassFunction:
    """About ``count`` distinct random focal sets (Θ excluded) with Dirichlet masses."""
    masks = np.unique(rng.integers(1, frame.full, size=count, dtype=np.int64))
    weights = rng.dirichlet(np.ones(masks.size))
    return MassFunction(frame, {int(k): float(w) for k, w in zip(masks, weights)})


def to_pyds(m: MassFunction):
    import pyds

    return pyds.MassFunction([(tuple(m.frame.label(int(k)).split("|")), float(v)) for k, v in zip(m.masks, m.masses)])


def timed(fn: Callable[[], object], repeat: int) -> float:
    start = time.perf_counter()
    for _ in range(repeat):
        fn()
    return (time.perf_counter() - start) / repeat


def compare(name: str, ours: Callable[[], object], peer: Callable[[], object], repeat: int) -> None:
    ours(), peer()  # warm up
    mine, theirs = [], []
    for _ in range(ROUNDS):
        mine.append(timed(ours, repeat))
        theirs.append(timed(peer, repeat))
    a, b = statistics.median(mine), statistics.median(theirs)
    print(f"{name:<13} ours {a * 1e6:10.2f} µs   pyds {b * 1e6:10.2f} µs   pyds/ours {b / a:8.2f}")


def main() -> None:
    try:
        import pyds
    except ImportError:
        print("pyds is not installed (pip install -e '.[bench]'): nothing to compare")
        return
    rng = np.random.default_rng(7)

    big = Frame([f"e{i}" for i in range(30)])
    # half of each source's mass on Θ keeps the conflict moderate
    sources = [random_mass(big, rng, 40).discount(0.5) for _ in range(3)]
    peers = [to_pyds(m) for m in sources]
    seed = np.random.default_rng(1)
    compare(
        "monte-carlo",
        lambda: monte_carlo_combine(*sources, samples=10_000, rng=seed),
        lambda: peers[0].combine_conjunctive(peers[1:], sample_count=10_000),
        1,
    )

    frame = Frame([f"e{i}" for i in range(16)])
    m = random_mass(frame, rng, 200)
    p = to_pyds(m)
    event = "|".join(f"e{i}" for i in range(8))
    compare("pignistic", m.pignistic, p.pignistic, 20)
    compare(
        "condition",
        lambda: condition(m, event, normalise=False),
        lambda: p.condition(tuple(event.split("|")), normalization=False),
        20,
    )
    compare("nonspecific", lambda: nonspecificity(m), p.hartley_measure, 50)

    twenty = Frame([f"e{i}" for i in range(20)])
    counts = {name: int(c) for name, c in zip(twenty.elements, rng.integers(0, 50, 20))}
    compare(
        "idm",
        lambda: imprecise_dirichlet(twenty, counts, s=1.0),
        lambda: pyds.MassFunction.from_samples(counts, method="idm", s=1.0),
        50,
    )
    pi = rng.random(20)
    pi /= pi.max()
    poss = dict(zip(twenty.elements, pi.tolist()))
    compare(
        "consonant",
        lambda: consonant_from_possibility(twenty, poss),
        lambda: pyds.MassFunction.from_possibility(poss),
        50,
    )

    pair = MassFunction(Frame(["real", "noise"]), {"real": 0.6, "real|noise": 0.4})
    three = MassFunction(Frame(["a", "b", "c"]), {"a": 0.2, "b": 0.1, "a|b": 0.3, "b|c": 0.15, "a|b|c": 0.25})
    p2, p3, real, ab = to_pyds(pair), to_pyds(three), frozenset({"real"}), frozenset({"a", "b"})
    compare("single bel 2", lambda: pair.belief("real"), lambda: p2.bel(real), 20_000)
    compare("single pl 2", lambda: pair.plausibility("real"), lambda: p2.pl(real), 20_000)
    compare("single q 2", lambda: pair.commonality("real"), lambda: p2.q(real), 20_000)
    compare("single bel 3", lambda: three.belief("a|b"), lambda: p3.bel(ab), 20_000)
    compare("single pl 3", lambda: three.plausibility("a|b"), lambda: p3.pl(ab), 20_000)


if __name__ == "__main__":
    main()
