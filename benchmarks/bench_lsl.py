"""How long one LSL rotational scan (15 snapshots, stripe points, polyline fit) takes.

Worlds are grids of 3 m rooms, each wall broken by a door, from about 100 to
10,000 segments; the robot stands in the middle room. Prints the median time of
a scan, the segments within LSL range, and the ratio to the smallest world.

    .venv/bin/python benchmarks/bench_lsl.py
"""

from __future__ import annotations

import time
from functools import partial

import numpy as np

from evmap.sources.params import LslParams
from evmap.sources.sim.lsl import lsl_segments, observe_lsl
from evmap.sources.sim.scenario import Scenario, default_scenario
from evmap.sources.sim.world import World


def building(rooms_per_side: int) -> World:
    """A grid of square rooms whose walls have 1 m door gaps: 8 segments per room."""
    walls = []
    size = 3.0
    for i in range(rooms_per_side):
        for j in range(rooms_per_side):
            x, y = i * size, j * size
            walls += [
                {"id": f"s{i}-{j}a", "points": [[x, y], [x + 1, y]]},
                {"id": f"s{i}-{j}b", "points": [[x + 2, y], [x + size, y], [x + size, y + 1]]},
                {"id": f"e{i}-{j}", "points": [[x + size, y + 2], [x + size, y + size], [x + 2, y + size]]},
                {"id": f"n{i}-{j}", "points": [[x + 1, y + size], [x, y + size], [x, y + 2]]},
                {"id": f"w{i}-{j}", "points": [[x, y + 1], [x, y]]},
            ]
    middle = (rooms_per_side // 2 + 0.5) * size
    data = {"version": 1, "name": "grid", "world": {"walls": walls}, "robot": {"poses": [[middle, middle + 0.3, 10]]}}
    return World(Scenario.model_validate(data))


def median_seconds(function, repeats: int = 30) -> float:
    function()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main() -> None:
    params = LslParams()
    corridor = World(default_scenario())
    t = median_seconds(lambda: observe_lsl(corridor, 0, params))
    print(f"corridor (default scenario, {len(corridor.surfaces().segments)} segments, 28 phantoms): {t * 1e3:.2f} ms")
    print(f"{'segments':>9} {'in range':>9} {'median ms':>10} {'ratio':>6}")
    base = None
    for side in (3, 11, 35):
        world = building(side)
        s = world.surfaces()
        origin = world.poses[0, :2]
        in_range = int((np.minimum(np.hypot(*(s.p - origin).T), np.hypot(*(s.q - origin).T)) <= params.max_range).sum())
        rng = np.random.default_rng(0)
        t = median_seconds(partial(lsl_segments, s, world.poses[0], params, rng))
        base = base or t
        print(f"{len(s.segments):>9} {in_range:>9} {t * 1e3:>10.2f} {t / base:>6.2f}")


if __name__ == "__main__":
    main()
