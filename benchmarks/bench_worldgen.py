"""Benchmark of the world generator and of the worlds it makes: generation time, poses, fusion time per pose.

For ``--worlds`` worlds of the experiment ``--seed`` (as ``evmap compare`` draws them), prints the
median generation time, the mix of detectors and tour lengths, and, by number of poses, the median
CPU seconds per pose of one world in ``evmap compare`` under Dempster's rule
(:func:`evmap.maps.app.compare_runner.compare_world`: generation, sensing, fusion, metrics): a tour of six
poses should cost about six single-pose runs.

    .venv/bin/python benchmarks/bench_worldgen.py [--worlds 40] [--seed 1]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import Counter, defaultdict

from evmap.maps.app.compare_runner import compare_world
from evmap.sources.sim.worldgen import generate_world, world_seed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=40)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    generation, per_pose = [], defaultdict(list)
    detectors: Counter[str] = Counter()
    for index in range(args.worlds):
        start = time.perf_counter()
        scenario = generate_world(world_seed(args.seed, index))
        generation.append(time.perf_counter() - start)
        count = len(scenario.robot.poses)
        detectors[scenario.sensors.lsl.detector] += 1
        start = time.process_time()
        compare_world(index, args.seed, ["dempster"])
        per_pose[count].append((time.process_time() - start) / count)
    print(f"{args.worlds} worlds, seed {args.seed}")
    print(f"  generation: median {1000 * statistics.median(generation):.1f} ms per world")
    print(f"  detectors: {dict(detectors)}")
    for count, values in sorted(per_pose.items()):
        median = 1000 * statistics.median(values)
        print(f"  {len(values):3d} worlds of {count} poses: median {median:.0f} ms CPU per pose")


if __name__ == "__main__":
    main()
