"""Speed of the paper's pipeline: one whole run of the default scenario, and how it grows.

Prints the median ``seconds.total`` of a single-pose run of the embedded corridor
(the computation only: sensing and fusion, no figures, no file I/O; target
< 0.1 s), the median ``seconds.total`` of 6-pose tours of generated worlds under
the default config (target < 0.5 s), then the fusion time of the same corridor as the number of LSL
segments grows (more sunlight phantoms in the same region), with the growth
ratio per tenfold more segments. With ``--tour-seeds``, every 6-pose tour among the first
``--tour-worlds`` worlds of each of those experiment seeds (each the median of 3 runs) instead
of the first six of seed 3: seeds the benchmark was not written on.

    .venv/bin/python benchmarks/bench_pipeline.py [--config paper] [--tour-seeds 77 78] [--tour-worlds 60]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from evmap.maps import new_map
from evmap.maps.app.run import run_scenario
from evmap.maps.observation import observe
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import default_scenario
from evmap.sources.sim.world import World
from evmap.sources.sim.worldgen import generate_world, world_seed

REPEATS = 15

TOURS = 6
"""Generated worlds with 6 poses timed (the first of experiment seed 3)."""


def median_run(scenario, config) -> tuple[float, dict[str, float]]:
    """Median of ``seconds.total`` over REPEATS runs, and the stages' medians."""
    runs = [run_scenario(scenario, config).seconds for _ in range(REPEATS)]
    return statistics.median(r["total"] for r in runs), {
        k: statistics.median(r[k] for r in runs) for k in ("simulate", "fuse")
    }


def fuse_time(scenario, config) -> tuple[int, float]:
    """Segments seen, and the median time of folding the one observation into a new map."""
    obs = observe(World(scenario), 0, config)
    times = []
    for _ in range(REPEATS):
        bm = new_map(config)
        start = time.perf_counter()
        bm.update(obs)
        times.append(time.perf_counter() - start)
    return len(obs.lsl), statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="default", help="packaged config name or file (default: default)")
    parser.add_argument("--tour-seeds", type=int, nargs="+", help="time every 6-pose tour of these experiment seeds")
    parser.add_argument("--tour-worlds", type=int, default=60, help="worlds of each tour seed looked at")
    args = parser.parse_args()
    config = load_config(args.config)
    corridor = default_scenario()
    total, stages = median_run(corridor, config)
    print(
        f"{args.config} config, the corridor, one pose: seconds.total median {total * 1e3:.1f} ms "
        f"(simulate {stages['simulate'] * 1e3:.1f} ms, fuse {stages['fuse'] * 1e3:.1f} ms); target < 100 ms"
    )

    # the first TOURS of seed 3, 5 runs each; or every one of the seeds asked for, 3 runs each
    seeds, worlds, most, repeats = (
        ([3], 200, TOURS, 5) if not args.tour_seeds else (args.tour_seeds, args.tour_worlds, None, 3)
    )
    tours = []
    for seed in seeds:
        for i in range(worlds):
            if len(tours) == most:
                break
            scenario = generate_world(world_seed(seed, i))
            if len(scenario.robot.poses) == 6:
                tours.append(statistics.median(run_scenario(scenario, config).seconds["total"] for _ in range(repeats)))
    runs = f"seeds {seeds}, each the median of {repeats} runs"
    print(
        f"{len(tours)} generated 6-pose tours: seconds.total median {statistics.median(tours) * 1e3:.0f} ms, "
        f"slowest {max(tours) * 1e3:.0f} ms, {sum(t > 0.5 for t in tours)} over 500 ms ({runs}); target < 500 ms"
    )

    print("\nfusion time against the number of LSL segments (phantoms added to the corridor's sunlight):")
    print(f"{'segments':>9} {'fuse ms':>9}")
    sizes, times = [], []
    for lines in (28, 100, 300, 1000, 3000):
        region = corridor.world.sunlight[0].model_copy(update={"lines": lines})
        world = corridor.world.model_copy(update={"sunlight": [region]})
        n, t = fuse_time(corridor.model_copy(update={"world": world}), config)
        sizes.append(n)
        times.append(t)
        print(f"{n:>9} {t * 1e3:>9.1f}")
    slope = np.polyfit(np.log10(sizes), np.log10(times), 1)[0]
    print(f"growth: time ~ segments^{slope:.2f} (x{10**slope:.1f} per tenfold more segments)")


if __name__ == "__main__":
    main()
