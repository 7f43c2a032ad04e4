"""Timing of the geometric stages: merging, corners, RCD matching.

Segments are the walls of random rectangular rooms, each wall in 10 overlapping
noisy pieces (LSL-like), plus 20 % short clutter; the walls of a room meet at
corners. A last merge row takes round walls, whose chains of pieces all bend,
the worst case (every group is rebuilt pair by pair). Prints the median of
several runs per size and the ratio to the smallest size, to show how each
stage grows.

    .venv/bin/python benchmarks/bench_geometry.py
"""

from __future__ import annotations

import time

import numpy as np

from evmap.maps.corners import find_corners
from evmap.maps.matching import match_rcds
from evmap.maps.merging import merge_segments


def rooms(n_segments: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Rectangular rooms, each wall in 10 noisy pieces, plus 20 % short clutter."""
    rng = np.random.default_rng(seed)
    n_rooms = max(1, int(0.8 * n_segments) // 40)
    side = np.sqrt(n_rooms) * 6.0
    p, q = [], []
    for _ in range(n_rooms):
        lo = rng.uniform(0, side, 2)
        hi = lo + rng.uniform(2, 5, 2)
        corners = np.array([lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]])
        for a, b in zip(corners, np.roll(corners, -1, axis=0)):
            t0 = np.linspace(0, 1, 11)[:-1] + rng.uniform(-0.01, 0.01, 10)
            t1 = t0 + 0.1 + rng.uniform(0.0, 0.02, 10)
            t0[0], t1[-1] = 0.0, 1.0
            p.append(a + t0[:, None] * (b - a) + rng.normal(0, 0.003, (10, 2)))
            q.append(a + t1[:, None] * (b - a) + rng.normal(0, 0.003, (10, 2)))
    clutter = n_segments - 40 * n_rooms
    c = rng.uniform(0, side + 5, (clutter, 2))
    p.append(c)
    q.append(c + rng.uniform(-0.3, 0.3, (clutter, 2)) + 0.01)
    return np.concatenate(p), np.concatenate(q)


def circles(n_segments: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Round walls (2 m radius) in 60 pieces of 6 deg: every chain bends, the worst case."""
    rng = np.random.default_rng(seed)
    n = max(1, n_segments // 60)
    centres = rng.uniform(0, 12 * np.sqrt(n), (n, 2))
    a = np.linspace(0, 2 * np.pi, 61)
    start = 2 * np.stack([np.cos(a[:-1]), np.sin(a[:-1])], axis=1)
    end = 2 * np.stack([np.cos(a[1:] + 0.01), np.sin(a[1:] + 0.01)], axis=1)
    return (centres[:, None] + start).reshape(-1, 2), (centres[:, None] + end).reshape(-1, 2)


def median_seconds(fn, repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main() -> None:
    sizes = [100, 1000, 10000]
    base = {}
    print(f"{'stage':<10}{'n':>7}{'lines':>8}{'median s':>11}{'ratio':>8}")
    for n in sizes:
        p, q = rooms(n)
        merged = merge_segments(p, q)
        rows = [
            ("merge", len(merged.p), median_seconds(lambda p=p, q=q: merge_segments(p, q))),
            (
                "corners",
                len(find_corners(merged.p, merged.q).xy),
                median_seconds(lambda merged=merged: find_corners(merged.p, merged.q, viewpoint=(1.0, 1.0))),
            ),
        ]
        for stage, count, seconds in rows:
            base.setdefault(stage, seconds)
            print(f"{stage:<10}{n:>7}{count:>8}{seconds:>11.4f}{seconds / base[stage]:>8.1f}")
    p, q = circles(10000)
    seconds = median_seconds(lambda: merge_segments(p, q))
    count = len(merge_segments(p, q).p)
    ratio = seconds / base["merge"]
    print(f"{'merge':<10}{len(p):>7}{count:>8}{seconds:>11.4f}{ratio:>8.1f}  round walls: every chain bends")
    rng = np.random.default_rng(1)
    for n in [8, 50, 200]:
        a_dir, s_dir = rng.uniform(-np.pi, np.pi, (2, n))
        a_rng, s_rng = rng.uniform(0.5, 5, (2, n))
        s_dir = a_dir + rng.normal(0, 0.05, n)
        s_rng = a_rng + rng.normal(0, 0.02, n)
        seconds = median_seconds(
            lambda a_dir=a_dir, a_rng=a_rng, s_dir=s_dir, s_rng=s_rng: match_rcds(a_dir, a_rng, s_dir, s_rng)
        )
        base.setdefault("match", seconds)
        count = len(match_rcds(a_dir, a_rng, s_dir, s_rng)[0])
        print(f"{'match':<10}{n:>7}{count:>8}{seconds:>11.5f}{seconds / base['match']:>8.1f}")


if __name__ == "__main__":
    main()
