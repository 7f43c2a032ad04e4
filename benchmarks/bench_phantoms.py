"""Phantoms out, walls kept, on generated worlds: the paper's config against the default, both detectors.

For every seed, ``--worlds`` worlds are generated (:func:`evmap.sources.sim.worldgen.generate_world`,
multi-pose tours), sensed once per detector, and fused by each config under Dempster's
rule. The ground truth (segment truth, true walls, sunlight regions) is read only after
the pipeline ran. Pooled over segments of all worlds, per config and detector:

- ``recall``: eliminated phantom segments / phantom segments; ``recall2``: the same on
  worlds where every sunlight region is in sight and range of two poses or more;
- ``loss``: eliminated real segments / real segments;
- ``spurious``: unidentified objects farther than 0.3 m from every true surface or
  within 0.15 m of a believed map line, as a share of all unidentified objects;
- ``behind``: free cells of the occupancy grid behind a true wall (every pose's sight
  line to the cell crosses a true surface more than one cell before it), per world;
- ``glass``: glass walls heard at normal incidence explained by an unidentified object;
- ``s/pose``: median fusion seconds per pose.

``--ablation`` also runs the paper's config plus each new source alone.

    python benchmarks/bench_phantoms.py --worlds 30 --seeds 11 12
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from evmap.maps.app.compare import GLASS_RADIUS, visible_glass
from evmap.maps.belief_map import new_map
from evmap.maps.observation import observe
from evmap.maps.occupancy import occupancy_from_masses, occupancy_masses
from evmap.maps.pipeline import fold_observation
from evmap.sources.config import Config, config_from_data, load_config
from evmap.sources.geometry import point_segment_distances
from evmap.sources.sim.scenario import LslSensor, Scenario, Sensors
from evmap.sources.sim.world import World, visible
from evmap.sources.sim.worldgen import WorldGenParams, generate_world, world_seed

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
NEW_SOURCES = ("sonar_forward", "contour_free", "lsl_persistence")
TOUR = WorldGenParams(poses=(3, 6), window_share=0.6)


def ablation(paper: Config, name: str) -> Config:
    """The paper's config with one more noise-elimination source, taken from the default config."""
    data = paper.to_data()
    default = load_config(CONFIGS / "default.yaml").to_data()
    data["sources"][name] = default["sources"][name]
    data["stages"]["noise_elimination"] = [*data["stages"]["noise_elimination"], name]
    return config_from_data(data, f"paper+{name}")


def multi_pose(world: World, config: Config) -> bool:
    """Every sunlight region in range and in sight of two poses or more (ground truth: evaluation only)."""
    if not len(world.sunlight):
        return False
    _, lsl = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    seen = np.zeros(len(world.sunlight), dtype=int)
    for x, y, _ in world.poses:
        near = np.hypot(*(world.sunlight_centroids - (x, y)).T) <= lsl.max_range
        seen += near & visible(world.surfaces(), np.array([x, y]), world.sunlight_centroids)
    return bool((seen >= 2).all())


def behind_walls(bm, world: World, resolution: float = 0.05) -> int:
    """Free grid cells behind a true wall: every pose's sight line crosses a surface over a cell before the cell."""
    masses, origin = occupancy_masses(bm, resolution)
    grid = occupancy_from_masses(masses)
    rows, cols = np.nonzero((grid >= 0) & (grid <= 25))
    if not len(rows):
        return 0
    centre = origin + (np.column_stack([cols, rows]) + 0.5) * resolution
    s = world.surfaces()
    hidden = np.ones(len(centre), dtype=bool)
    for x, y, _ in world.poses:
        o = np.array([x, y])
        d = centre - o
        dist = np.hypot(*d.T)
        shortened = o + d * (np.maximum(dist - resolution, 0) / np.maximum(dist, 1e-9))[:, None]
        hidden &= _crosses(o, shortened, s.p, s.q)
    return int(hidden.sum())


def _crosses(o, ends, p, q):
    """Whether each segment o-end crosses any of the segments p-q."""
    r = ends - o
    e = q - p
    out = np.zeros(len(ends), dtype=bool)
    for k in range(0, len(ends), 4096):
        rr = r[k : k + 4096, None, :]
        den = rr[..., 0] * e[None, :, 1] - rr[..., 1] * e[None, :, 0]
        w = p[None] - o
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / den
            u = (w[..., 0] * rr[..., 1] - w[..., 1] * rr[..., 0]) / den
        out[k : k + 4096] = ((t > 0) & (t < 1) & (u >= 0) & (u <= 1)).any(axis=1)
    return out


def _distances(xy, p, q):
    """(M, N) distances from points to segments."""
    return point_segment_distances(xy[:, None, :], p[None], q[None])


def run_world(scenario: Scenario, configs: dict[str, Config]) -> dict[str, dict[str, float]]:
    """Fuse the world by every config; evaluate against its truth afterwards."""
    world = World(scenario)
    base = next(iter(configs.values()))
    observations = [observe(world, k, base) for k in range(len(world.poses))]
    out = {}
    for name, config in configs.items():
        bm = new_map(config)
        start = time.perf_counter()
        for obs in observations:
            fold_observation(bm, obs, config)
        seconds = time.perf_counter() - start
        # ------------------------------------------------ ground truth from here on
        store = bm.segments
        noise, real = store.truth == "noise", store.truth == "real"
        surfaces = world.surfaces()
        unidentified = np.array([u.xy for u in bm.unidentified()], dtype=float).reshape(-1, 2)
        lines = bm.lines(min_belief=0.5)
        spurious = 0
        if len(unidentified):
            far = _distances(unidentified, surfaces.p, surfaces.q).min(axis=1) > 0.3
            on_line = np.zeros(len(unidentified), dtype=bool)
            if lines:
                lp, lq = np.array([ln.p for ln in lines]), np.array([ln.q for ln in lines])
                on_line = _distances(unidentified, lp, lq).min(axis=1) <= 0.15
            spurious = int((far | on_line).sum())
        glass = visible_glass(world, config)
        explained = 0
        if len(glass) and len(unidentified):
            d = _distances(unidentified, surfaces.p[glass], surfaces.q[glass])
            explained = int((d <= GLASS_RADIUS).any(axis=0).sum())
        out[name] = {
            "noise": int(noise.sum()),
            "noise_out": int((store.eliminated & noise).sum()),
            "real": int(real.sum()),
            "real_out": int((store.eliminated & real).sum()),
            "unidentified": len(unidentified),
            "spurious": spurious,
            "glass": len(glass),
            "glass_explained": explained,
            "behind": behind_walls(bm, world),
            "seconds_per_pose": seconds / len(observations),
            "multi": multi_pose(world, config),
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", type=int, default=20)
    parser.add_argument("--seeds", type=int, nargs="+", default=[11, 12])
    parser.add_argument("--ablation", action="store_true")
    args = parser.parse_args()
    paper = load_config(CONFIGS / "paper.yaml")
    configs = {"paper": paper, "default": load_config(CONFIGS / "default.yaml")}
    if args.ablation:
        configs |= {f"paper+{name}": ablation(paper, name) for name in NEW_SOURCES}
    totals: dict[tuple[str, str], dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for detector in ("threshold", "column_max"):
        for seed in args.seeds:
            for index in range(args.worlds):
                scenario = generate_world(world_seed(seed, index), TOUR, name=f"s{seed}-w{index}")
                scenario = scenario.model_copy(update={"sensors": Sensors(lsl=LslSensor(detector=detector))})
                for name, row in run_world(scenario, configs).items():
                    for key, value in row.items():
                        totals[(name, detector)][key].append(value)
    print(f"seeds {args.seeds}, {args.worlds} worlds each, Dempster's rule, pooled over segments")
    header = "config           detector    recall recall2  loss   spurious behind/world glass   s/pose"
    print(header)
    for (name, detector), t in totals.items():
        a = {k: np.array(v) for k, v in t.items()}
        multi = a["multi"].astype(bool)
        print(
            f"{name:16s} {detector:10s} {a['noise_out'].sum() / max(a['noise'].sum(), 1):6.3f} "
            f"{a['noise_out'][multi].sum() / max(a['noise'][multi].sum(), 1):6.3f} "
            f"{a['real_out'].sum() / max(a['real'].sum(), 1):7.4f} "
            f"{a['spurious'].sum() / max(a['unidentified'].sum(), 1):7.3f} "
            f"{a['behind'].mean():10.1f}   "
            f"{a['glass_explained'].sum()}/{a['glass'].sum():<5d} {np.median(a['seconds_per_pose']):6.3f}"
            f"   ({multi.sum()} multi-pose worlds)"
        )


if __name__ == "__main__":
    main()
