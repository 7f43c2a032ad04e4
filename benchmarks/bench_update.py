"""Speed of ``BeliefMap.update`` on large maps: one new scan touching a small area.

A synthetic building (a grid of 4 m rooms, each with a door) is turned into a
belief map of 1,000, 10,000 and 100,000 lines: every wall one line of one raw
segment, judged by the noise-elimination sources, its corners found, each room's
floor open space. Then one observation, simulated from a pose in a room of the
middle of the building (a sonar scan and an LSL scan of the true walls), is
folded in. Prints the time of the first update (which also makes the map's
spatial grid, once) and the median of the next five against the number of
lines; target < 0.2 s and not growing with the map.

    .venv/bin/python benchmarks/bench_update.py
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import shapely

from evmap.maps import new_map
from evmap.maps.belief_map import BeliefMap
from evmap.maps.corners import find_corners
from evmap.maps.noise import noise_evidence
from evmap.maps.observation import Observation
from evmap.sources.config import load_config
from evmap.sources.sim.lsl import lsl_segments
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.surfaces import Surfaces

ROOM = 4.0
DOOR = (1.5, 2.4)  # the door's span along each room's south wall (m from its corner)


def building(rooms: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall segments p, q of a square grid of about ``rooms`` rooms (three segments a room)."""
    n = max(1, round(float(np.sqrt(rooms))))
    p, q = [], []
    for i in range(n + 1):
        for j in range(n + 1):
            x, y = i * ROOM, j * ROOM
            if i < n:  # south wall of room (i, j), with its door
                p += [(x, y), (x + DOOR[1], y)]
                q += [(x + DOOR[0], y), (x + ROOM, y)]
            if j < n:  # west wall
                p.append((x, y))
                q.append((x, y + ROOM))
    return np.array(p, dtype=float), np.array(q, dtype=float)


def building_map(p: np.ndarray, q: np.ndarray, config) -> BeliefMap:
    """A belief map holding the walls p-q as lines, their corners, and every room's open floor."""
    bm = new_map(config)
    n = round(float(p[:, 0].max() / ROOM))
    for i in range(n):
        for j in range(n):
            bm.add_open_space(shapely.box(i * ROOM + 0.2, j * ROOM + 0.2, (i + 1) * ROOM - 0.2, (j + 1) * ROOM - 0.2))
    ids = bm.segments.append(p, q, np.zeros(len(p), dtype=np.intp), np.full(len(p), "real"))
    ev = noise_evidence(p, q, shapely.Polygon(), config)
    bm.segments.relation[ids] = ev.relation
    bm.segments.mass[ids] = ev.fused
    corners = find_corners(p, q, config.corners)
    node = {}
    for k, xy in enumerate(corners.xy):
        bm.add_point(f"XC{k}", xy, "corner", _mass(bm, ev.fused[corners.ends[k][0, 0]]))
        for line, end in corners.ends[k].tolist():
            node[line, end] = f"XC{k}"
    for k in range(len(p)):
        ends = []
        for e, xy in ((0, p[k]), (1, q[k])):
            if (k, e) not in node:
                node[k, e] = f"XE{k}_{e}"
                bm.add_point(node[k, e], xy, "endpoint", _mass(bm, ev.fused[k]))
            ends.append(node[k, e])
        history = [
            {
                "stage": "noise_elimination",
                "poses": [0],
                "relation": str(ev.relation[k]),
                "length": float(ev.length[k]),
                "mass": _mass(bm, ev.fused[k]).to_dict(),
            }
        ]
        bm.add_line(
            f"XL{k}",
            *ends,
            _mass(bm, ev.fused[k]),
            history=history,
            fit=[p[k].tolist(), q[k].tolist()],
            members=[k],
            reinforced=False,
        )
        bm.segments.line[k] = f"XL{k}"
    return bm


def _mass(bm, row):
    from evidential import MassFunction

    return MassFunction.from_dense(bm.frame, row, open_world=True)


def observation(p: np.ndarray, q: np.ndarray, room: tuple[int, int], config, pose_index: int) -> Observation:
    """Sonar and LSL scans of the true walls from the middle of a room."""
    surfaces = Surfaces(
        vertices=np.concatenate([p, q]),
        vertex_ids=np.array([f"v{k}" for k in range(2 * len(p))]),
        segments=np.column_stack([np.arange(len(p)), len(p) + np.arange(len(p))]),
        segment_ids=np.array([f"w{k}" for k in range(len(p))]),
        lsl_opaque=np.ones(len(p), dtype=bool),
        sonar_reflective=np.ones(len(p), dtype=bool),
    )
    pose = np.array([(room[0] + 0.45) * ROOM, (room[1] + 0.55) * ROOM, 0.3])
    rng = np.random.default_rng([7, pose_index, 1])
    scan = simulate_scan(surfaces, pose, config.sensors.sonar, rng=rng)
    segments = lsl_segments(surfaces, pose, config.sensors.lsl, np.random.default_rng([7, pose_index, 101]), pose_index)
    return Observation(pose_index, scan, segments)


def main() -> None:
    config = load_config()
    print(f"{'lines':>8} {'build s':>8} {'first update ms':>16} {'update ms (median of 5 more)':>29}")
    for rooms in (330, 3300, 33000):
        p, q = building(rooms)
        start = time.perf_counter()
        bm = building_map(p, q, config)
        built = time.perf_counter() - start
        n = round(float(p[:, 0].max() / ROOM))
        times = []
        for k in range(6):  # the first update also makes the map's spatial grid, once
            obs = observation(p, q, (n // 2 + k, n // 2), config, pose_index=1 + k)
            start = time.perf_counter()
            bm.update(obs)
            times.append(time.perf_counter() - start)
        print(f"{len(p):>8} {built:>8.1f} {times[0] * 1e3:>16.1f} {statistics.median(times[1:]) * 1e3:>29.1f}")


if __name__ == "__main__":
    main()
