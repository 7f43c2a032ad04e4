"""What the occupancy grid calls free, against the truth: free cells on walls, behind walls, and the seen free kept.

For every packaged scenario (``configs/scenarios/``) and ``--worlds`` generated worlds of
each ``--seeds`` (:func:`evmap.sources.sim.worldgen.generate_world`, as ``evmap compare``
makes them), fused under the default config and Dempster's rule, the map's ROS grid
(5 cm, :func:`evmap.maps.occupancy.occupancy_grid`) is checked against the world's
true surfaces (evaluation only: nothing here is read by the pipeline). Printed per
scenario, and summed over the generated worlds of each seed:

- ``on walls``: free cells that a true surface the stripe sees crosses (a wall, a
  cylinder's rim), of the cells those surfaces cross: a planner would drive into them;
- ``behind``: free cells behind true surfaces (:func:`~evmap.maps.app.compare_hazards.free_behind_walls`),
  of all free cells;
- ``unheard``: of all free cells, those behind panes alone that no sonar reading heard at normal incidence
  (``behind`` less :func:`~evmap.maps.app.compare_hazards.free_behind_perceived`): free air the stripe saw
  through glass that neither sensor reported, beyond what the map can know;
- ``kept``: the places the stripe saw free that the grid keeps free
  (:func:`~evmap.maps.app.compare_hazards.free_seen_kept`);
- ``free s``: the seconds (CPU) of the map's free space (:func:`evmap.maps.free_space.free_space`).

With ``--glass LOW HIGH`` the generated worlds' facade panes and windows are LOW-HIGH m wide (the
generator's defaults: panes 1-2 m, windows 0.8-1.5 m): long glass, as in shopfronts and glass partitions.

    python benchmarks/bench_free_cells.py [--worlds 25] [--seeds 41] [--glass 2 5]
"""

from __future__ import annotations

import argparse
import time
from importlib.resources import files

import numpy as np

from evmap.maps.app.compare_configs import resolve_config
from evmap.maps.app.compare_hazards import (
    GRID_RESOLUTION,
    free_behind_perceived,
    free_behind_walls,
    free_seen_kept,
    stripe_seen,
)
from evmap.maps.app.compare_metrics import fuse_configs, heard_glass
from evmap.maps.app.run import Run
from evmap.maps.free_space import free_space
from evmap.maps.occupancy import FREE_MAX, occupancy_from_masses, occupancy_masses, segment_cells
from evmap.sources.sim.scenario import Scenario, load_scenario
from evmap.sources.sim.worldgen import generate_world, world_seed
from evmap.sources.sim.worldgen_params import WorldGenParams

RIM_SIDES = 32
"""A cylinder's rim is checked as a polygon of this many sides."""


def figures(run: Run) -> np.ndarray:
    """(free cells on walls, cells on walls, free cells behind walls, free cells, places kept, places seen,
    free-space seconds, free cells behind panes no reading heard) of one run."""
    start = time.process_time()
    free_space(run.map)
    seconds = time.process_time() - start
    masses, origin = occupancy_masses(run.map, GRID_RESOLUTION)
    grid = occupancy_from_masses(masses)
    s = run.world.surfaces()
    angle = np.linspace(0, 2 * np.pi, RIM_SIDES + 1)
    rim = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    centres, radii = s.cylinder_centers[s.cylinder_lsl_opaque], s.cylinder_radii[s.cylinder_lsl_opaque]
    ring = (centres[:, None] + radii[:, None, None] * rim[None]).reshape(-1, RIM_SIDES + 1, 2)
    p = np.concatenate([s.p[s.lsl_opaque], ring[:, :-1].reshape(-1, 2)])
    q = np.concatenate([s.q[s.lsl_opaque], ring[:, 1:].reshape(-1, 2)])
    cells = np.unique(segment_cells(p, q, origin, GRID_RESOLUTION, grid.shape)[0])
    value = grid.ravel()[cells]
    on_walls = int(((value >= 0) & (value <= FREE_MAX)).sum())
    behind, _, free = free_behind_walls(run.map, run.world)
    kept, seen = free_seen_kept(run.map, stripe_seen(run.world, run.config))
    perceived = free_behind_perceived(run.map, run.world, heard_glass(run.world, [o.sonar for o in run.observations]))
    return np.array([on_walls, len(cells), behind, free, kept, seen, seconds, behind - perceived], dtype=float)


def fused(scenario: Scenario) -> Run:
    """The scenario fused under the default config and Dempster's rule."""
    return fuse_configs(scenario, {"default": resolve_config("default")}, ["dempster"])["default", "dempster"]


def row(label: str, f: np.ndarray) -> str:
    return (
        f"{label:22} {int(f[0]):6d} / {int(f[1]):6d} {int(f[2]):8d} / {int(f[3]):8d} ({f[2] / max(f[3], 1):.4f}) "
        f"{f[7] / max(f[3], 1):8.4f} {f[4] / max(f[5], 1):7.3f} {f[6]:7.2f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=25)
    parser.add_argument("--seeds", type=int, nargs="+", default=[41])
    parser.add_argument("--glass", type=float, nargs=2, metavar=("LOW", "HIGH"), help="panes and windows (m)")
    args = parser.parse_args()
    params = WorldGenParams(pane_width=args.glass, window_width=args.glass) if args.glass else WorldGenParams()
    print(
        f"{'scene':22} {'on walls / wall cells':>15} {'behind / free cells':>28} {'unheard':>8} {'kept':>7} {'free s':>7}"
    )
    for path in sorted(files("evmap.configs").joinpath("scenarios").iterdir()):
        if path.name.endswith(".yaml"):
            print(row(path.name.removesuffix(".yaml"), figures(fused(load_scenario(path)))), flush=True)
    for seed in args.seeds:
        total = sum(
            figures(fused(generate_world(world_seed(seed, i), params, name=f"world-{i:04d}")))
            for i in range(args.worlds)
        )
        glass = f", glass {args.glass[0]:g}-{args.glass[1]:g} m" if args.glass else ""
        print(row(f"seed {seed}, {args.worlds} worlds{glass}", total), flush=True)


if __name__ == "__main__":
    main()
