"""Where the phantom recall stops: the phantoms the default config keeps, by the evidence they had.

For every seed, ``--worlds`` worlds are generated with the detector fixed (as in
``bench_phantoms.py``: :class:`evmap.sources.sim.worldgen.WorldGenParams`
``column_max_share`` 0 or 1) and run under the default config, Dempster's rule. Each
phantom segment the final map keeps falls in one class by the features the
pipeline sensed for it (:func:`evmap.maps.sensed.kept_features`):

- ``none``: contour ``clear``, ``unobserved`` by every other pose, ``silent`` to the
  sonar: no source says anything of it;
- ``seen``: the same, but ``seen`` again by another pose (another phantom lying on it);
- ``other``: some evidence of noise, too weak to remove it.

The ``none`` class splits by what the other poses' rays did where the phantom lies
(:func:`evmap.maps.contour_free_space.ray_tally` over every pose the map remembers):

- ``hidden``: other poses' rays cross its place, and every one ended in front of it (on
  what that pose saw nearer: its own sunlit patches, or a wall);
- ``glimpsed``: some other pose's rays reached it unhidden, fewer than a look takes
  (``min_rays``), none through it;
- ``unlooked``: no other pose's ray crosses its place (out of their view or range).

Printed per detector, over all worlds and over the worlds where every sunlight region
a pose sees is seen by two poses or more (``recall2``'s): the phantoms, those kept,
the three classes, the recall, and the recall were every phantom with any evidence
removed (only the ``none`` class kept): how far evidence of these sensors can go.

    python benchmarks/bench_phantom_evidence.py --worlds 30 --seeds 21 22
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np
from bench_phantoms import DETECTORS  # this folder's: the same two detectors

from evmap.maps.app.compare_hazards import sunlight_seen_twice
from evmap.maps.app.run import Run, run_scenario
from evmap.maps.contour_free_space import RayParams, ray_tally
from evmap.maps.sensed import kept_features, sensed
from evmap.sources.config import load_config
from evmap.sources.sim.worldgen import generate_world, world_seed
from evmap.sources.sim.worldgen_params import WorldGenParams

QUIET = {"contour_free": "clear", "sonar_forward": "silent"}
"""The contour's and the sonar's features' values that are no evidence either way."""


def kept_by_evidence(seed: int, worlds: int, share: float) -> dict[str, Counter[str]]:
    """Phantoms and the classes of those kept, over all worlds (``all``) and those seen twice (``twice``)."""
    config = load_config("default")
    counts: dict[str, Counter[str]] = {"all": Counter(), "twice": Counter()}
    for i in range(worlds):
        run = run_scenario(generate_world(world_seed(seed, i), WorldGenParams(column_max_share=share)), config)
        store = run.map.segments
        phantoms = np.flatnonzero((store.truth == "noise") & store.raw)
        kept = phantoms[~store.eliminated[phantoms]]
        features = kept_features(run.map, kept)
        quiet = np.all([features[name] == value for name, value in QUIET.items()], axis=0)
        persistence = features["lsl_persistence"]
        none = kept[quiet & (persistence == "unobserved")]
        found = Counter(
            worlds=1,
            phantoms=len(phantoms),
            kept=len(kept),
            none=len(none),
            seen=int((quiet & (persistence == "seen")).sum()),
        )
        found["other"] = found["kept"] - found["none"] - found["seen"]
        found.update(_unobserved(run, none))
        counts["all"] += found
        if sunlight_seen_twice(run.world, run.config):
            counts["twice"] += found
    return counts


def _unobserved(run: Run, none: np.ndarray) -> Counter[str]:
    """The ``none`` phantoms (store rows) by what the other poses' rays did where they lie (module doc)."""
    store = run.map.segments
    tally = ray_tally(
        store.p[none], store.q[none], store.pose[none], sensed(run.map), RayParams.of_stripe(run.config.sensors.lsl)
    )
    reached = (tally.other_ends + tally.other_misses).sum(axis=1) > 0
    hidden = ~reached & (tally.other_hidden.sum(axis=1) > 0)
    return Counter(hidden=int(hidden.sum()), glimpsed=int(reached.sum()), unlooked=int((~reached & ~hidden).sum()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worlds", type=int, default=20)
    parser.add_argument("--seeds", type=int, nargs="+", default=[11, 12])
    args = parser.parse_args()
    print(f"seeds {args.seeds}, {args.worlds} worlds each per detector, default config, Dempster's rule")
    print(
        "detector   worlds     phantoms   kept   none (hidden glimpsed unlooked)   seen  other  recall"
        "  recall, only none kept"
    )
    for detector, share in DETECTORS.items():
        total: dict[str, Counter[str]] = {"all": Counter(), "twice": Counter()}
        for seed in args.seeds:
            for key, found in kept_by_evidence(seed, args.worlds, share).items():
                total[key] += found
        for key, c in total.items():
            n = c["phantoms"] or float("nan")
            print(
                f"{detector:10s} {key:5s} {c['worlds']:4d} {c['phantoms']:8d} {c['kept']:6d} {c['none']:6d} "
                f"({c['hidden']:6d} {c['glimpsed']:8d} {c['unlooked']:8d}) {c['seen']:6d} "
                f"{c['other']:6d} {1 - c['kept'] / n:7.3f} {1 - c['none'] / n:9.3f}"
            )


if __name__ == "__main__":
    main()
