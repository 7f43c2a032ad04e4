"""Phantoms out, walls kept, on generated worlds: the configs side by side, for each LSL detector.

For every seed, ``--worlds`` worlds are generated with the detector fixed
(:class:`evmap.sources.sim.worldgen.WorldGenParams` ``column_max_share`` 0 or 1, every
other parameter at its default: tours of 3-6 poses, a quarter single-pose, facades,
halls, clutter) and compared by :func:`evmap.maps.app.compare_runner.run_comparison` under
Dempster's rule, every config on the same scans. Printed per config and detector,
pooled over the segments of all worlds and seeds (``summary.md`` of ``evmap compare``
defines each):

- ``recall``: eliminated phantom segments / phantom segments; ``recall2``: the same on
  the worlds where every sunlight region a pose sees is seen by two poses or more;
- ``loss``: eliminated real segments / real segments;
- ``spurious``: the mean share of spurious unidentified objects per world;
- ``behind``: the mean share of the free grid cells that lie behind true surfaces;
  ``opaque``: of those hidden by opaque surfaces alone; ``kept``: the mean share of the
  places the stripe saw free that the grid keeps free;
- ``glass``: the mean share of glass walls seen at normal incidence that are explained; ``heard``: of those the
  sonar really heard at normal incidence (``glass_heard_explained``);
- ``s/pose``: the median over worlds of the fusion seconds per pose.

    python benchmarks/bench_phantoms.py --worlds 30 --seeds 11 12 [--configs ablation]
"""

from __future__ import annotations

import argparse
import statistics
from collections import defaultdict

from evmap.maps.app.compare_runner import run_comparison
from evmap.sources.sim.scenario import parse_scenario
from evmap.sources.sim.worldgen_params import WorldGenParams

DETECTORS = {"threshold": 0.0, "column_max": 1.0}
"""Detector -> the generator's ``column_max_share``."""

COLUMNS = (
    "spurious_unidentified",
    "free_behind_walls",
    "free_behind_opaque",
    "free_seen_kept",
    "glass_explained",
    "glass_heard_explained",
)
"""The per-world figures averaged over the worlds."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", type=int, default=20)
    parser.add_argument("--seeds", type=int, nargs="+", default=[11, 12])
    parser.add_argument("--configs", default="paper,default", help="as evmap compare --configs")
    parser.add_argument("--scheduler", help="as evmap compare's (default: a local cluster)")
    args = parser.parse_args()
    sums: dict[tuple[str, str], dict[str, float]] = defaultdict(lambda: defaultdict(float))
    means: dict[tuple[str, str], dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for detector, share in DETECTORS.items():
        for seed in args.seeds:
            comparison = run_comparison(
                ["dempster"], args.worlds, seed, configs=args.configs, params=WorldGenParams(column_max_share=share),
                scheduler=args.scheduler, progress=False,
            )  # fmt: skip
            poses = {name: len(parse_scenario(text, name).robot.poses) for name, text in comparison.scenarios.items()}
            for row in comparison.rows:
                key = row["config"], detector
                s = sums[key]
                s["noise"] += row["noise_segments"]
                s["noise_out"] += row["noise_eliminated"]
                s["real"] += row["real_segments"]
                s["real_out"] += row["real_eliminated"]
                if row["sunlight_seen_twice"]:
                    s["noise2"] += row["noise_segments"]
                    s["noise2_out"] += row["noise_eliminated"]
                    s["twice"] += 1
                for column in COLUMNS:
                    if row[column] is not None:
                        means[key][column].append(row[column])
                means[key]["s/pose"].append(row["seconds_per_world"] / poses[row["world"]])
    print(f"seeds {args.seeds}, {args.worlds} worlds each per detector, Dempster's rule, pooled over segments")
    print(
        "config                  detector    recall recall2   loss  spurious  behind  opaque    kept   glass  "
        "heard  s/pose"
    )
    for (name, detector), s in sums.items():
        m = {k: statistics.fmean(v) if v else float("nan") for k, v in means[name, detector].items()}
        print(
            f"{name:23s} {detector:10s} {s['noise_out'] / max(s['noise'], 1):6.3f} "
            f"{s['noise2_out'] / max(s['noise2'], 1):6.3f} {s['real_out'] / max(s['real'], 1):7.4f} "
            f"{m['spurious_unidentified']:8.3f} {m['free_behind_walls']:7.3f} {m['free_behind_opaque']:7.4f} "
            f"{m['free_seen_kept']:7.3f} {m['glass_explained']:7.3f} {m['glass_heard_explained']:6.3f} "
            f"{statistics.median(means[name, detector]['s/pose']):6.3f}   ({int(s['twice'])} worlds seen twice)"
        )


if __name__ == "__main__":
    main()
