"""Speed of the simulated sonar scan: how the time grows with the size of the building.

A synthetic building: an n x n grid of 2.5 m rooms, each wall with a 0.9 m door in
its middle (so every wall is two segments with free ends), a pillar in every
third room. One 360-reading scan from a room near the middle, first order only
and with double bounces. Prints the median of repeated runs, the number of
segments within sonar range, and each size's time as a ratio to the smallest.

Target (issue 3): 10,000 segments, a few hundred in range: first order < 10 ms,
with second order < 50 ms median.

Run: ``.venv/bin/python benchmarks/bench_sonar.py``
"""

from __future__ import annotations

import time

import numpy as np

from evmap.sources.params import SonarParams
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.surfaces import Surfaces

ROOM = 2.5
DOOR = 0.9


def building(n: int) -> Surfaces:
    """An n x n grid of rooms with doors: 4 n (n + 1) segments."""
    half = (ROOM - DOOR) / 2
    pts, segs = [], []
    for i in range(n + 1):
        for j in range(n):
            for a, b in ((j * ROOM, j * ROOM + half), ((j + 1) * ROOM - half, (j + 1) * ROOM)):
                for p, q in (((a, i * ROOM), (b, i * ROOM)), ((i * ROOM, a), (i * ROOM, b))):
                    segs.append((len(pts), len(pts) + 1))
                    pts += [p, q]
    vertices, inverse = np.unique(np.round(np.array(pts), 9), axis=0, return_inverse=True)
    segments = inverse.reshape(-1)[np.array(segs)]
    centers = np.array([((j + 0.7) * ROOM, (i + 0.3) * ROOM) for i in range(n) for j in range(n) if (i + j) % 3 == 0])
    k, v = len(centers), len(vertices)
    return Surfaces(
        vertices=vertices,
        vertex_ids=np.array([f"v{i}" for i in range(v)]),
        segments=segments,
        segment_ids=np.array([f"s{i}" for i in range(len(segments))]),
        lsl_opaque=np.ones(len(segments), bool),
        sonar_reflective=np.ones(len(segments), bool),
        cylinder_centers=centers.reshape(-1, 2),
        cylinder_radii=np.full(k, 0.15),
        cylinder_ids=np.array([f"c{i}" for i in range(k)]),
        cylinder_lsl_opaque=np.ones(k, bool),
        cylinder_sonar_reflective=np.ones(k, bool),
    )


def median_ms(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def main() -> None:
    params = SonarParams()
    rows = []
    for n in (5, 16, 50):
        world = building(n)
        c = (n // 2 + 0.4) * ROOM
        pose = np.array([c, c + 0.35, 0.3])
        d = np.hypot(*((world.p + world.q) / 2 - pose[:2]).T)
        in_range = int(np.sum(d <= params.max_range + ROOM / 2))
        t1 = median_ms(lambda world=world, pose=pose: simulate_scan(world, pose, params, max_order=1), 30)
        t2 = median_ms(lambda world=world, pose=pose: simulate_scan(world, pose, params, max_order=2), 30)
        scan = simulate_scan(world, pose, params)
        rows.append((len(world.segments), in_range, t1, t2, int(np.sum(scan.order == 2))))
    head = ("segments", "in range", "1st order ms", "ratio", "2nd order ms", "ratio", "2nd-order readings")
    print(" ".join(f"{h:>{w}}" for h, w in zip(head, (9, 9, 13, 6, 13, 6, 19))))
    for segs, near, t1, t2, n2 in rows:
        print(f"{segs:>9} {near:>9} {t1:>13.2f} {t1 / rows[0][2]:>6.2f} {t2:>13.2f} {t2 / rows[0][3]:>6.2f} {n2:>19}")
    segs, _, t1, t2, _ = rows[-1]
    print(
        f"targets at {segs} segments: first order {t1:.1f} ms (< 10: {'ok' if t1 < 10 else 'MISSED'}), "
        f"with second order {t2:.1f} ms (< 50: {'ok' if t2 < 50 else 'MISSED'})"
    )


if __name__ == "__main__":
    main()
