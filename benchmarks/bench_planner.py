"""Benchmark of the planner's API on synthetic building maps of 1,000 to 100,000 lines.

A building is a square grid of 4 m rooms; every wall between two grid vertices is
two lines with a 1 m door gap between them (corners at the grid vertices, free
end points at the doors), with random beliefs, some reinforced, a few
unidentified objects, and the rooms' interiors as the sonar open space.

Prints, per map size: median per-query times of ``nearest_obstacle`` and
``is_segment_clear`` (a shapely STRtree of the obstacles, caught up with the
map's changes; clearance timed with ``unknown="free"`` to match the peer, and
with the default that also asks for known free space), on a map that does not
change and right after a change (one object's
mass folded before each query, as a planner alternating ``update`` and queries
sees it), and of a brute-force numpy peer over all obstacles (the ratio shows
that the queries do not grow with the map); the one-off build of the obstacle
tree, the rebuild of the listings' arrays after a change, ``save`` +
``load`` of ``map.json``, and the occupancy grid. Targets (issue 6), at 100,000
lines: nearest_obstacle < 100 us, is_segment_clear < 200 us (also right after
a change), save + load < 5 s.

Run: ``.venv/bin/python benchmarks/bench_planner.py [--sizes 1000 10000 100000]``
"""

from __future__ import annotations

import argparse
import gc
import math
import tempfile
import time
from pathlib import Path

import numpy as np
import orjson
import shapely

from evidential import Frame, MassFunction
from evmap.maps import BeliefMap

ROOM = 4.0
DOOR = (1.5, 2.5)
QUERIES = 2000


def building(n_lines: int, seed: int = 0) -> BeliefMap:
    """A grid of rooms with about ``n_lines`` lines (4 k (k + 1) for k x k rooms)."""
    rng = np.random.default_rng(seed)
    k = max(1, round((-1 + math.sqrt(1 + n_lines)) / 2))
    frame = Frame(["real", "noise"])
    bm = BeliefMap(frame, "dempster")

    def mass() -> MassFunction:
        real, noise = rng.uniform(0, 1), rng.uniform(0, 0.3)
        real *= 1 - noise
        return MassFunction(frame, {"real": real, "noise": noise, "real|noise": 1 - real - noise})

    def record() -> list[dict]:
        return [{"pose": 0, "sensor": "lsl", "source": "lsl_length", "mass": {"real": 0.6, "real|noise": 0.4}}]

    for i in range(k + 1):
        for j in range(k + 1):
            bm.add_point(f"C{i}_{j}", (i * ROOM, j * ROOM), "corner", mass(), record(),
                         shape="concave", reinforced=bool(rng.random() < 0.2))  # fmt: skip
    n = 0
    for i in range(k + 1):
        for j in range(k):
            for axis in (0, 1):  # a vertical wall (x = i ROOM) and a horizontal one (y = i ROOM)
                start, end = (f"C{i}_{j}", f"C{i}_{j + 1}") if axis == 0 else (f"C{j}_{i}", f"C{j + 1}_{i}")
                for side, corner, offset in ((0, start, DOOR[0]), (1, end, DOOR[1])):
                    xy = (i * ROOM, j * ROOM + offset) if axis == 0 else (j * ROOM + offset, i * ROOM)
                    door = f"E{n}"
                    bm.add_point(door, xy, "endpoint", mass(), record())
                    bm.add_line(f"L{n}", corner, door, mass(), record(),
                                members=[2 * n, 2 * n + 1], reinforced=bool(rng.random() < 0.2))  # fmt: skip
                    n += 1
    for u, xy in enumerate(rng.uniform(0.5, k * ROOM - 0.5, (max(1, n // 100), 2))):
        bm.add_point(f"U{u}", xy, "unidentified", mass(), record())
    rooms = [shapely.box(i * ROOM + 0.1, j * ROOM + 0.1, (i + 1) * ROOM - 0.1, (j + 1) * ROOM - 0.1)
             for i in range(k) for j in range(k)]  # fmt: skip
    bm.open_space = shapely.MultiPolygon(rooms)
    return bm


def median_us(calls) -> float:
    times = []
    for call in calls:
        t = time.perf_counter_ns()
        call()
        times.append(time.perf_counter_ns() - t)
    return float(np.median(times)) / 1e3


def after_change_us(bm: BeliefMap, ids: list[str], calls) -> float:
    """Median time of each call right after a change: one object's mass folded (not timed) before each."""
    evidence = MassFunction(bm.frame, {"real": 0.3, "real|noise": 0.7})
    times = []
    for n, call in enumerate(calls):
        bm.fold(ids[n % len(ids)], evidence, {"pose": n, "sensor": "bench"})
        t = time.perf_counter_ns()
        call()
        times.append(time.perf_counter_ns() - t)
    return float(np.median(times)) / 1e3


def brute_nearest(p: np.ndarray, q: np.ndarray, xy: np.ndarray) -> float:
    """Distance from xy to the nearest of all segments p-q, numpy over everything (the peer)."""
    d = q - p
    t = np.clip(((xy - p) * d).sum(1) / np.maximum((d * d).sum(1), 1e-300), 0, 1)
    return float(np.sqrt(((p + t[:, None] * d - xy) ** 2).sum(1)).min())


def bench(n_lines: int) -> None:
    t = time.perf_counter()
    bm = building(n_lines)
    built = time.perf_counter() - t
    lines = bm.lines(min_belief=0.0)
    side = max(max(line.q) for line in lines)
    rng = np.random.default_rng(1)
    points = rng.uniform(0, side, (QUERIES, 2))
    ends = points + rng.uniform(-1.5, 1.5, (QUERIES, 2))

    t = time.perf_counter()
    bm.nearest_obstacle((0.0, 0.0))  # the first query makes the obstacle tree, caught up with changes since
    first = time.perf_counter() - t
    bm.set_attrs("L0", reinforced=True)  # a change drops the whole-map arrays of the listings: time their rebuild
    t = time.perf_counter()
    bm.lines(min_belief=1.0)
    arrays = time.perf_counter() - t
    nearest = median_us(lambda xy=xy: bm.nearest_obstacle(xy) for xy in points)
    clear = median_us(
        lambda a=a, b=b: bm.is_segment_clear(a, b, unknown="free") for a, b in zip(points, ends, strict=True)
    )
    clear_known = median_us(lambda a=a, b=b: bm.is_segment_clear(a, b) for a, b in zip(points, ends, strict=True))
    ids = [line.id for line in lines]
    nearest_changed = after_change_us(bm, ids, (lambda xy=xy: bm.nearest_obstacle(xy) for xy in points))
    clear_changed = after_change_us(
        bm, ids, (lambda a=a, b=b: bm.is_segment_clear(a, b, unknown="free") for a, b in zip(points, ends, strict=True))
    )
    strong = [line for line in lines if line.belief >= 0.5]
    p, q = np.array([line.p for line in strong]), np.array([line.q for line in strong])
    peer = median_us(lambda xy=xy: brute_nearest(p, q, xy) for xy in points[:200])
    geoms = shapely.linestrings(np.stack([p, q], axis=1))
    peer_clear = median_us(
        lambda a=a, b=b: bool((shapely.distance(geoms, shapely.LineString([a, b])) > 0.2).all())
        for a, b in zip(points[:50], ends[:50], strict=True)
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "map.json"
        t, cpu = time.perf_counter(), time.process_time()
        bm.save(path)
        loaded = BeliefMap.load(path)
        io_wall, io_cpu = time.perf_counter() - t, time.process_time() - cpu
        del loaded  # freeing a big map takes a while too: not part of load
        size = path.stat().st_size
        data = bm.to_data()
        gc.disable()  # as save and load do
        t = time.process_time()
        orjson.loads(orjson.dumps(data))
        peer_io = time.process_time() - t
        gc.enable()
    resolution = max(0.05, round(side / 2000, 2))
    t = time.perf_counter()
    grid = bm.occupancy_grid(resolution)
    occupancy = time.perf_counter() - t

    print(f"\n{len(lines):,} lines, {bm.graph.number_of_nodes():,} points (built in {built:.1f} s)")
    print(f"  one-off obstacle tree (first query) {first * 1e3:.0f} ms; "
          f"listings' arrays after a change (lines()) {arrays * 1e3:.0f} ms")  # fmt: skip
    print(f"  nearest_obstacle median             {nearest:8.1f} us   brute-force numpy peer {peer:9.1f} us  "
          f"(x{peer / nearest:.0f})")  # fmt: skip
    print(f"    right after a change (fold)       {nearest_changed:8.1f} us")
    print(f"  is_segment_clear median             {clear:8.1f} us   brute-force shapely peer {peer_clear:7.1f} us  "
          f"(x{peer_clear / clear:.0f})")  # fmt: skip
    print(f"    right after a change (fold)       {clear_changed:8.1f} us")
    print(f"    unknown space blocked (default)   {clear_known:8.1f} us   (the path must lie in the open space too)")
    print(f"  save + load ({size / 1e6:.1f} MB)   {io_wall:6.2f} s wall, {io_cpu:.2f} s CPU; "
          f"orjson round trip of the same data alone (peer) {peer_io:.2f} s CPU (x{io_cpu / peer_io:.1f})")  # fmt: skip
    print(f"  occupancy_grid {grid.shape[0]} x {grid.shape[1]} at {resolution} m   {occupancy:8.2f} s")


def python_speed() -> float:
    """CPU seconds of a plain Python loop of 10 million additions: the machine's pace, for reading the figures."""
    t = time.process_time()
    total = 0
    for i in range(10_000_000):
        total += i
    return time.process_time() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1_000, 10_000, 100_000])
    print(f"machine pace: 10M-addition Python loop in {python_speed():.2f} s CPU (a 2024 desktop: about 0.3 s)")
    for n in parser.parse_args().sizes:
        bench(n)


if __name__ == "__main__":
    main()
