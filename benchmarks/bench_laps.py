"""A patrol lapped again and again: does an update cost more as the robot passes the same places?

The three poses of ``configs/scenarios/patrol.yaml`` (default config) are folded
into one map lap after lap, each pass a new pose of the map (its own pose
index), with the same readings. Printed per lap: the median CPU time of an
update, the map's lines and stored segments; then the ratio of the last lap's
median to that of the first lap after the sensed features' window is full
(:data:`~evmap.maps.sensed.LATEST_POSES` poses): an update costs what a place
holds, not how often it was seen (target: about 1).

    .venv/bin/python benchmarks/bench_laps.py [--laps 20]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import time

from evmap import configs
from evmap.maps.belief_map import new_map
from evmap.maps.observation import observe
from evmap.maps.sensed import LATEST_POSES
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import load_scenario
from evmap.sources.sim.world import World


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laps", type=int, default=20)
    args = parser.parse_args()
    config = load_config("default")
    world = World(load_scenario(configs.path("scenarios/patrol.yaml")))
    seen = [observe(world, k, config) for k in range(len(world.poses))]
    bm = new_map(config)
    medians = []
    print(f"{'lap':>4} {'ms/update':>10} {'lines':>6} {'segments':>9}")
    for lap in range(args.laps):
        times = []
        for k, obs in enumerate(seen):
            start = time.process_time()
            bm.update(dataclasses.replace(obs, pose_index=lap * len(seen) + k))
            times.append(time.process_time() - start)
        medians.append(1000 * statistics.median(times))
        print(f"{lap:4d} {medians[-1]:10.1f} {bm.graph.number_of_edges():6d} {len(bm.segments):9d}", flush=True)
    full = math.ceil(LATEST_POSES / len(seen))
    if args.laps > full:
        print(f"last lap / lap {full} (window full): {medians[-1] / medians[full]:.2f}")


if __name__ == "__main__":
    main()
