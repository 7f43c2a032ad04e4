"""Comparing combination rules on many generated worlds with ground truth (``evmap compare``).

Every rule runs on every world with the same scans: each world
(:func:`evmap.sources.sim.worldgen.generate_world`) is sensed once, from all its poses,
and the same observations are folded into one belief map per rule
(:func:`fuse_rules`). Per world and rule (:func:`world_metrics`):

``noise_recall``
    noise (sunlight) segments eliminated / noise segments.
``real_loss``
    real segments eliminated / real segments.
``glass_explained``
    the share of the LSL-invisible, sonar-specular walls (glass, mirrors) seen
    at normal incidence from some pose, unobstructed (:func:`visible_glass`),
    that have an unidentified object within :data:`GLASS_RADIUS`.
``mean_conflict``
    the mean conflict K between the sonar and the LSL masses over all segments
    (a property of the evidence, not of the rule: equal for every rule).
``map_error``
    the mean distance to the nearest true surface of points every
    :data:`MAP_ERROR_STEP` along the final lines with belief at least 0.5 (m).
``seconds_per_world``
    the fusion time of the rule on the world (sensing, shared by the rules, is
    ``seconds_simulate``).

A ratio whose denominator is empty (no noise segment, no such glass wall, no
line) is left empty and excluded from the means. The summary is the mean over
the worlds, taken in world order, so every column but the ``seconds...`` ones is
the same whatever the parallelism (:func:`run_comparison`: a Dask cluster,
local by default, or one of Dask's local schedulers).

>>> from evmap.sources.config import load_config
>>> from evmap.sources.sim.worldgen import generate_world
>>> runs = fuse_rules(generate_world(2), load_config(), ["dempster", "yager"])
>>> sorted(runs), runs["dempster"].observations is runs["yager"].observations
(['dempster', 'yager'], True)
>>> m = world_metrics(runs["dempster"])
>>> set(METRICS) <= set(m), m["noise_segments"] > 0
(True, True)
"""

from __future__ import annotations

import argparse
import csv
import functools
import logging
import math
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evidential import RULES
from evmap.maps import new_map
from evmap.maps.app.run import Run
from evmap.maps.observation import observe
from evmap.maps.pipeline import fold_observation
from evmap.sources.config import Config, load_config
from evmap.sources.sim.scenario import Scenario
from evmap.sources.sim.surfaces import Surfaces
from evmap.sources.sim.world import World, cast_rays
from evmap.sources.sim.worldgen import WorldGenParams, generate_world, scenario_yaml, world_seed

__all__ = [
    "BELIEF_BINS",
    "COLUMNS",
    "COUNTS",
    "DEFAULT_RULES",
    "GLASS_RADIUS",
    "LOCAL_SCHEDULERS",
    "MAP_ERROR_STEP",
    "MAX_WORLDS",
    "METRICS",
    "Comparison",
    "WorldResult",
    "add_compare_parser",
    "check_rules",
    "compare_command",
    "compare_world",
    "fuse_rules",
    "line_beliefs",
    "map_error",
    "run_comparison",
    "summary_markdown",
    "visible_glass",
    "world_metrics",
    "write_comparison",
]

DEFAULT_RULES = ("dempster", "yager", "dubois_prade", "pcr6", "murphy", "bayes")
"""The rules ``evmap compare`` runs when ``--rules`` is not given."""

METRICS = ("noise_recall", "real_loss", "glass_explained", "mean_conflict", "map_error")
"""The figures per world and rule (see the module doc)."""

COUNTS = ("noise_segments", "real_segments", "lines", "unidentified")
"""Counts per world and rule: segments by truth, map lines with belief >= 0.5, unidentified objects."""

COLUMNS = ("rule", *METRICS, "max_conflict", *COUNTS, "seconds_per_world", "seconds_simulate")
"""The columns of ``summary.csv``; ``worlds.csv`` has ``world`` first. ``seconds...`` are timings."""

GLASS_RADIUS = 0.3
"""An unidentified object within this distance (m) of a glass wall explains it."""

MAP_ERROR_STEP = 0.05
"""Spacing (m) of the points along a map line whose distance to the true surfaces is measured."""

BELIEF_BINS = np.linspace(0.0, 1.0, 21)
"""Histogram bins of the line beliefs of real and phantom segments."""

LOCAL_SCHEDULERS = ("synchronous", "threads", "processes")
"""Dask's local schedulers, accepted by ``scheduler`` besides a cluster address."""

MAX_WORLDS = 1_000_000
"""Most worlds one comparison runs."""

_TRUTHS = ("real", "noise")


# --------------------------------------------------------------------- one world


def fuse_rules(scenario: Scenario, config: Config, rules: Sequence[str]) -> dict[str, Run]:
    """Sense the scenario once from every pose, then fold the same observations into one map per rule.

    Each :class:`~evmap.maps.app.run.Run` shares the world and the observations; its
    ``seconds`` are ``simulate`` (shared), ``fuse`` (this rule) and ``total``.
    """
    world = World(scenario)
    start = time.perf_counter()
    observations = [observe(world, k, config) for k in range(len(world.poses))]
    simulate = time.perf_counter() - start
    runs = {}
    for rule in rules:
        cfg = config.with_rule(rule)
        start = time.perf_counter()
        bm = new_map(cfg)
        outcomes = [fold_observation(bm, obs, cfg) for obs in observations]
        fuse = time.perf_counter() - start
        runs[rule] = Run(
            world, cfg, observations, outcomes, bm, {"simulate": simulate, "fuse": fuse, "total": simulate + fuse}
        )
    return runs


def world_metrics(run: Run, glass: NDArray[np.intp] | None = None) -> dict[str, float | int | None]:
    """The figures of one rule on one world (module doc); ``None`` where a ratio has no denominator.

    ``glass``: the indices of :func:`visible_glass` in the world's surfaces, if
    already computed (they do not depend on the rule).
    """
    store = run.map.segments
    noise = store.truth == "noise"
    real = store.truth == "real"
    surfaces = run.world.surfaces()
    if glass is None:
        glass = visible_glass(run.world, run.config)
    lines = run.map.lines(min_belief=0.5)
    unidentified = np.array([u.xy for u in run.map.unidentified()], dtype=float).reshape(-1, 2)
    explained = None
    if len(glass):
        d = _segment_distance(unidentified, surfaces.p[glass], surfaces.q[glass])  # (U, G)
        explained = float((d <= GLASS_RADIUS).any(axis=0).mean()) if len(unidentified) else 0.0
    return {
        "noise_recall": _share(store.eliminated & noise, noise),
        "real_loss": _share(store.eliminated & real, real),
        "glass_explained": explained,
        "mean_conflict": float(store.conflict.mean()) if len(store) else None,
        "map_error": map_error([line.p for line in lines], [line.q for line in lines], surfaces),
        "max_conflict": float(store.conflict.max()) if len(store) else None,
        "noise_segments": int(noise.sum()),
        "real_segments": int(real.sum()),
        "lines": len(lines),
        "unidentified": len(unidentified),
        "seconds_per_world": run.seconds["fuse"],
        "seconds_simulate": run.seconds["simulate"],
    }


def visible_glass(world: World, config: Config) -> NDArray[np.intp]:
    """Indices (into ``world.surfaces()``) of the LSL-transparent, sonar-specular walls seen at normal incidence.

    A wall is seen at normal incidence from a pose when the foot of the
    perpendicular from the pose lies strictly inside the wall, within the
    sonar's ``max_range`` (the scenario's, else the config's), and the sight
    line to it crosses no other surface (wall or cylinder, whatever its material).

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> world = World(default_scenario())
    >>> world.surfaces().segment_ids[visible_glass(world, load_config())].tolist()  # window 2 is beside the pose
    ['east-window-1']
    """
    s = world.surfaces()
    sonar, _ = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    candidates = np.flatnonzero(~s.lsl_opaque & s.sonar_reflective)
    if not len(candidates):
        return candidates
    p, q = s.p[candidates], s.q[candidates]
    d = q - p
    seen = np.zeros(len(candidates), dtype=bool)
    for x, y, _ in world.poses:
        t = ((x - p[:, 0]) * d[:, 0] + (y - p[:, 1]) * d[:, 1]) / (d**2).sum(axis=1)
        foot = p + t[:, None] * d
        dist = np.hypot(foot[:, 0] - x, foot[:, 1] - y)
        ok = (t > 0) & (t < 1) & (dist > 0) & (dist <= sonar.max_range)
        if not ok.any():
            continue
        angles = np.arctan2(foot[ok, 1] - y, foot[ok, 0] - x)
        _, hit = cast_rays((x, y), angles, s.p, s.q, s.cylinder_centers, s.cylinder_radii, sonar.max_range)
        seen[np.flatnonzero(ok)[hit == candidates[ok]]] = True
    return candidates[seen]


def map_error(p: Sequence[Any], q: Sequence[Any], surfaces: Surfaces) -> float | None:
    """Mean distance (m) from points every :data:`MAP_ERROR_STEP` along lines p-q to the nearest true surface.

    Each line gives ``ceil(length / step) + 1`` evenly spaced points, both ends
    included; ``None`` when there are no lines.

    >>> from evmap.sources.sim.scenario import default_scenario
    >>> s = World(default_scenario()).surfaces()
    >>> round(map_error([(1.0, 0.1)], [(2.0, 0.1)], s), 6)
    0.1
    """
    if not len(p):
        return None
    p, q = np.asarray(p, dtype=float).reshape(-1, 2), np.asarray(q, dtype=float).reshape(-1, 2)
    count = np.ceil(np.hypot(*(q - p).T) / MAP_ERROR_STEP).astype(int) + 1
    line = np.repeat(np.arange(len(p)), count)
    t = (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)) / np.repeat(count - 1, count)
    points = p[line] + t[:, None] * (q - p)[line]
    d = np.full(len(points), np.inf)
    if len(surfaces.segments):
        d = _segment_distance(points, surfaces.p, surfaces.q).min(axis=1)
    if len(surfaces.cylinder_radii):
        to_center = np.hypot(*(points[:, None, :] - surfaces.cylinder_centers[None]).transpose(2, 0, 1))
        d = np.minimum(d, np.abs(to_center - surfaces.cylinder_radii).min(axis=1))
    return float(d.mean())


def line_beliefs(run: Run) -> tuple[NDArray[np.float64], NDArray[np.str_]]:
    """Per segment: Bel(real) of the map line it ended in (0 if eliminated), and its truth.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.worldgen import generate_world
    >>> belief, truth = line_beliefs(fuse_rules(generate_world(2), load_config(), ["dempster"])["dempster"])
    >>> belief.shape == truth.shape, bool(((belief >= 0) & (belief <= 1)).all())
    (True, True)
    """
    store = run.map.segments
    by_line = {line.id: line.belief for line in run.map.lines(min_belief=0.0)}
    belief = np.array([by_line.get(lid, 0.0) if not gone else 0.0 for lid, gone in zip(store.line, store.eliminated)])
    return belief.reshape(-1), store.truth.copy()


def _segment_distance(
    points: NDArray[np.float64], p: NDArray[np.float64], q: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(M, N) distance from each point to each segment p-q."""
    d = q - p
    w = points[:, None, :] - p[None, :, :]
    length2 = np.maximum((d**2).sum(axis=1), np.finfo(float).tiny)
    t = np.clip((w * d[None]).sum(axis=2) / length2, 0.0, 1.0)
    return np.hypot(*(w - t[..., None] * d[None]).transpose(2, 0, 1))


def _share(part: NDArray[np.bool_], whole: NDArray[np.bool_]) -> float | None:
    n = int(whole.sum())
    return int(part.sum()) / n if n else None


# --------------------------------------------------------------------- many worlds


@dataclass(frozen=True)
class WorldResult:
    """One world's outcome: its name and YAML, a row per rule, and belief histograms.

    ``beliefs[rule]`` is an int array (2, len(BELIEF_BINS) - 1): segment counts per
    belief bin, real segments then noise segments.
    """

    world: str
    yaml: str
    rows: tuple[dict[str, Any], ...]
    beliefs: dict[str, NDArray[np.int64]]


@functools.lru_cache(maxsize=4)
def _config(path: str | None) -> Config:
    return load_config(path)


def compare_world(
    index: int, seed: int, rules: Sequence[str], config_path: str | None = None, params: WorldGenParams | None = None
) -> WorldResult:
    """World ``index`` of the experiment ``seed``: generated, sensed once, fused by every rule.

    >>> r = compare_world(0, 1, ["dempster", "bayes"])
    >>> r.world, [row["rule"] for row in r.rows], r.beliefs["bayes"].shape
    ('world-0000', ['dempster', 'bayes'], (2, 20))
    """
    config = _config(config_path)
    name = f"world-{index:04d}"
    scenario = generate_world(world_seed(seed, index), params, name=name)
    runs = fuse_rules(scenario, config, rules)
    glass = visible_glass(next(iter(runs.values())).world, config)
    rows, beliefs = [], {}
    for rule, run in runs.items():
        rows.append({"world": name, "rule": rule, **world_metrics(run, glass)})
        belief, truth = line_beliefs(run)
        beliefs[rule] = np.stack([np.histogram(belief[truth == t], BELIEF_BINS)[0] for t in _TRUTHS])
    return WorldResult(name, scenario_yaml(scenario), tuple(rows), beliefs)


@dataclass(frozen=True)
class Comparison:
    """The outcome of :func:`run_comparison`.

    Attributes
    ----------
    rules, worlds, seed : what was run.
    rows : one dict per world and rule (the ``worlds.csv`` rows), in world order.
    summary : one dict per rule (the ``summary.csv`` rows): means over the worlds.
    beliefs : rule -> (2, bins) segment counts per line-belief bin, real then noise.
    scenarios : world name -> its scenario YAML.
    """

    rules: tuple[str, ...]
    worlds: int
    seed: int
    rows: tuple[dict[str, Any], ...]
    summary: tuple[dict[str, Any], ...]
    beliefs: dict[str, NDArray[np.int64]]
    scenarios: dict[str, str]


def run_comparison(
    rules: Sequence[str],
    worlds: int,
    seed: int,
    *,
    config_path: str | Path | None = None,
    params: WorldGenParams | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
) -> Comparison:
    """Every rule on ``worlds`` generated worlds with the same scans, in parallel with Dask.

    Parameters
    ----------
    rules : names in :data:`evidential.RULES`.
    worlds : how many worlds (>= 1); world ``i`` has seed ``world_seed(seed, i)``.
    seed : the experiment's seed, 0 <= seed < 2**63.
    config_path : the config file (default: the packaged paper's); with a
        remote cluster its workers must be able to read it.
    params : the world generator's parameters.
    scheduler : ``None`` for a local Dask cluster of ``workers`` processes
        (default: one per CPU); one of :data:`LOCAL_SCHEDULERS` for Dask's
        in-process schedulers; else the address of a Dask scheduler.
    progress : show a progress bar on standard error.

    >>> c = run_comparison(["dempster", "yager"], 2, 1, scheduler="synchronous", progress=False)
    >>> [row["rule"] for row in c.summary], len(c.rows), sorted(c.scenarios)
    (['dempster', 'yager'], 4, ['world-0000', 'world-0001'])
    """
    rules = check_rules(rules)
    if not isinstance(worlds, int) or not 1 <= worlds <= MAX_WORLDS:
        raise ValueError(f"worlds must be an integer from 1 to {MAX_WORLDS}, got {worlds!r}")
    if not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise ValueError(f"seed must be an integer with 0 <= seed < 2**63, got {seed!r}")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    path = None if config_path is None else str(config_path)
    _config(path)  # a bad config fails here, before any work is sent out
    import dask

    tasks = [dask.delayed(compare_world, pure=True)(i, seed, rules, path, params) for i in range(worlds)]
    results = _compute(tasks, scheduler, workers, progress)
    return _aggregate(rules, worlds, seed, results)


def check_rules(rules: Sequence[str] | str) -> tuple[str, ...]:
    """Rule names from a sequence or a comma-separated string, checked against :data:`evidential.RULES`.

    >>> check_rules("dempster, yager")
    ('dempster', 'yager')
    >>> check_rules("dempster,nope")
    Traceback (most recent call last):
    ...
    ValueError: rules: unknown rule 'nope'; known rules: bayes, ...
    """
    names = [r.strip() for r in (rules.split(",") if isinstance(rules, str) else rules)]
    if not names or any(not n for n in names):
        raise ValueError(f"rules: need one or more comma-separated rule names, got {rules!r}")
    for n in names:
        if n not in RULES:
            raise ValueError(f"rules: unknown rule {n!r}; known rules: {', '.join(sorted(RULES))}")
    if len(set(names)) < len(names):
        raise ValueError(f"rules: a rule is named twice in {names}")
    return tuple(names)


def _compute(tasks: list[Any], scheduler: str | None, workers: int | None, progress: bool) -> list[WorldResult]:
    """Compute the tasks with a progress bar; results in task order."""
    from tqdm import tqdm

    bar = tqdm(total=len(tasks), desc="compare", unit="world", file=sys.stderr, disable=not progress)
    with bar:
        if scheduler in LOCAL_SCHEDULERS:
            import dask
            from dask.callbacks import Callback

            class _Progress(Callback):
                def _posttask(self, key: Any, result: Any, dsk: Any, state: Any, worker_id: Any) -> None:
                    if isinstance(result, WorldResult):
                        bar.update(1)

            with _Progress():
                return list(dask.compute(*tasks, scheduler=scheduler))

        from distributed import Client, LocalCluster, as_completed

        if scheduler is None:
            cluster = LocalCluster(
                n_workers=workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
            client = Client(cluster)
        else:
            cluster, client = None, Client(scheduler)
        try:
            futures = client.compute(tasks)
            for _ in as_completed(futures):
                bar.update(1)
            return client.gather(futures)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


def _aggregate(rules: tuple[str, ...], worlds: int, seed: int, results: list[WorldResult]) -> Comparison:
    rows = tuple(row for r in results for row in r.rows)
    summary = []
    for rule in rules:
        mine = [row for row in rows if row["rule"] == rule]
        line: dict[str, Any] = {"rule": rule}
        for column in COLUMNS[1:]:
            values = [row[column] for row in mine if row[column] is not None]
            line[column] = math.fsum(values) / len(values) if values else None
        line["worlds"] = len(mine)
        summary.append(line)
    beliefs = {rule: sum(r.beliefs[rule] for r in results) for rule in rules}
    return Comparison(rules, worlds, seed, rows, tuple(summary), beliefs, {r.world: r.yaml for r in results})


# --------------------------------------------------------------------- files


def write_comparison(comparison: Comparison, out: str | Path) -> None:
    """Write ``summary.csv``, ``worlds.csv``, ``summary.md``, the plots and ``worlds/*.yaml`` into ``out``.

    ``out`` must exist.
    """
    out = Path(out)
    _write_csv(out / "summary.csv", [*COLUMNS, "worlds"], comparison.summary)
    _write_csv(out / "worlds.csv", ["world", *COLUMNS], comparison.rows)
    (out / "summary.md").write_text(summary_markdown(comparison))
    scenarios = out / "worlds"
    scenarios.mkdir()
    for name, text in comparison.scenarios.items():
        (scenarios / f"{name}.yaml").write_text(text)
    _plot_recall_loss(comparison, out / "noise_recall_vs_real_loss.png")
    _plot_beliefs(comparison, out / "line_beliefs.png")


def summary_markdown(comparison: Comparison) -> str:
    """The summary table in Markdown, with a line saying what was run."""
    shown = [*METRICS, "lines", "unidentified", "seconds_per_world"]
    out = [
        f"# Rule comparison: {comparison.worlds} worlds, seed {comparison.seed}",
        "",
        "Means over the worlds (empty ratios excluded); every rule fused the same scans.",
        "",
        "| " + " | ".join(["rule", *shown]) + " |",
        "| " + " | ".join(["---", *["---:"] * len(shown)]) + " |",
    ]
    for row in comparison.summary:
        cells = [
            "" if row[c] is None else f"{row[c]:.4f}" if c.startswith("seconds") else f"{row[c]:.3f}" for c in shown
        ]
        out.append("| " + " | ".join([row["rule"], *cells]) + " |")
    return "\n".join(out) + "\n"


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[dict[str, Any]]) -> None:
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow(["" if row[c] is None else row[c] for c in columns])


def _plot_recall_loss(comparison: Comparison, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    markers = "DosP^vX*<>"
    for k, rule in enumerate(comparison.rules):
        color, marker = f"C{k % 10}", markers[k % len(markers)]
        size = max(30, 180 - 25 * k)  # decreasing, so that rules with equal means stay visible
        mine = [
            r
            for r in comparison.rows
            if r["rule"] == rule and r["noise_recall"] is not None and r["real_loss"] is not None
        ]
        ax.scatter([r["real_loss"] for r in mine], [r["noise_recall"] for r in mine], s=8, alpha=0.25, color=color)
        mean = next(r for r in comparison.summary if r["rule"] == rule)
        ax.scatter(
            mean["real_loss"], mean["noise_recall"], s=size, marker=marker, color=color, edgecolor="k", label=rule
        )
    ax.set_xlabel("real loss (real segments eliminated)")
    ax.set_ylabel("noise recall (phantom segments eliminated)")
    ax.set_title(f"{comparison.worlds} worlds: each world (dots) and the mean per rule")
    ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _plot_beliefs(comparison: Comparison, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(comparison.rules)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.2 * rows), squeeze=False, sharey=True)
    for ax, rule in zip(axes.flat, comparison.rules):
        for counts, label, color in zip(comparison.beliefs[rule], ("real", "phantom"), ("C0", "C3")):
            share = counts / max(int(counts.sum()), 1)
            ax.stairs(share, BELIEF_BINS, label=f"{label} ({int(counts.sum())})", color=color, fill=False, lw=1.5)
        ax.set_title(rule)
        ax.set_xlabel("Bel(real) of the segment's line (0: eliminated)")
        ax.legend(fontsize="small")
    for ax in axes.flat[n:]:
        ax.axis("off")
    axes[0, 0].set_ylabel("share of segments")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# --------------------------------------------------------------------- command


def add_compare_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``compare`` on ``subparsers`` (``evmap``'s commands); its handler is :func:`compare_command`.

    >>> parser = argparse.ArgumentParser(prog="evmap")
    >>> _ = add_compare_parser(parser.add_subparsers())
    >>> args = parser.parse_args(["compare", "--out", "x", "--worlds", "3"])
    >>> args.handler is compare_command, args.rules, args.worlds, args.seed
    (True, 'dempster,yager,dubois_prade,pcr6,murphy,bayes', 3, 0)
    """
    compare = subparsers.add_parser(
        "compare",
        help="compare combination rules on generated worlds with ground truth",
        description="Run every rule on every generated world with the same scans; "
        "write tables, per-world rows and plots.",
    )
    compare.add_argument(
        "--rules", default=",".join(DEFAULT_RULES), help="comma-separated rule names (default: %(default)s)"
    )
    compare.add_argument("--worlds", type=int, default=20, help="number of generated worlds (default: %(default)s)")
    compare.add_argument("--seed", type=int, default=0, help="seed of the experiment (default: %(default)s)")
    compare.add_argument("--out", required=True, help="output directory: must not exist or be empty (see --force)")
    compare.add_argument("--force", action="store_true", help="replace --out if it exists")
    compare.add_argument("--config", help="config file (default: the packaged configs/paper.yaml)")
    compare.add_argument(
        "--scheduler", help="address of a Dask scheduler, or synchronous|threads|processes (default: a local cluster)"
    )
    compare.add_argument("--workers", type=int, help="processes of the local cluster (default: one per CPU)")
    compare.add_argument("--quiet", action="store_true", help="no progress bar")
    compare.set_defaults(handler=compare_command)
    return compare


def compare_command(args: argparse.Namespace) -> int:
    """``evmap compare``: run the comparison, write its files into ``--out`` at the end, print the table.

    The files are written to a temporary directory beside ``--out`` and moved
    into place only when everything is done, so a failed run leaves no ``--out``.
    """
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out: {out} exists and is not a directory")
    if out.is_dir() and any(out.iterdir()) and not args.force:
        raise ValueError(f"--out: {out} is not empty (use --force to replace it)")
    if args.config is not None and not Path(args.config).is_file():
        raise ValueError(f"--config: no such file {args.config}")
    comparison = run_comparison(
        check_rules(args.rules),
        args.worlds,
        args.seed,
        config_path=args.config,
        scheduler=args.scheduler,
        workers=args.workers,
        progress=not args.quiet,
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    try:
        write_comparison(comparison, tmp)
        if out.exists():
            shutil.rmtree(out)
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    print(summary_markdown(comparison), end="")
    print(f"written to {out}", file=sys.stderr)
    return 0
