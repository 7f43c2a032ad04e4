"""Running a rule comparison on many generated worlds: in this process or in parallel with Dask.

World ``i`` of the experiment ``seed`` is generated from ``world_seed(seed, i)``
inside the worker that computes it: tasks carry only indices, the seed, the
rule and config names and the generator's parameters; each worker builds each
config once (:func:`compare_batch`). Worlds go in batches, at most
:data:`MAX_IN_FLIGHT_PER_WORKER` batches per worker at a time, and come back in
world order (:func:`iter_results`): memory is bounded whatever the number of
worlds, and the numbers are the same whatever the scheduler.

Schedulers: ``None`` is a local Dask cluster of ``workers`` processes (default:
one per CPU), except below :data:`SYNCHRONOUS_BELOW` worlds with ``workers`` not
given, where starting it costs more than it saves and the worlds run in this process; ``synchronous``
runs them here; ``threads`` and ``processes`` use a local pool; anything else is
the address of a Dask scheduler.
"""

from __future__ import annotations

import gc
import itertools
import sys
from collections.abc import Iterator, Sequence
from typing import Any

from evidential import RULES
from evmap.maps.app.compare_args import SYNCHRONOUS_BELOW
from evmap.maps.app.compare_configs import config_names, resolve_config, sensing_key
from evmap.maps.app.compare_executors import executor, interrupts_between_waits
from evmap.maps.app.compare_hazards import stripe_seen, sunlight_seen_twice
from evmap.maps.app.compare_metrics import (
    WorldResult,
    belief_histograms,
    fuse_configs,
    heard_glass,
    visible_glass,
    world_metrics,
)
from evmap.maps.app.compare_tables import Comparison, Tally
from evmap.sources.config_model import check_rule
from evmap.sources.plugins import load_plugins
from evmap.sources.sim.worldgen import generate_world, scenario_yaml, world_seed
from evmap.sources.sim.worldgen_params import WorldGenParams

__all__ = [
    "MAX_BATCH",
    "MAX_IN_FLIGHT_PER_WORKER",
    "MAX_WORLDS",
    "batches",
    "check_rules",
    "compare_batch",
    "compare_world",
    "iter_results",
    "run_comparison",
]

MAX_WORLDS = 1_000_000
"""Most worlds one comparison runs."""


MAX_BATCH = 4
"""Most worlds per task (small generated worlds take a fraction of a second each; a default one several seconds
with the six default rules)."""

TASKS_PER_WORKER = 12
"""Batches are made small enough to give each worker at least this many (the last ones balance the load)."""

MAX_IN_FLIGHT_PER_WORKER = 2
"""Batches submitted per worker and not yet collected: what bounds the memory of a run."""

GC_EVERY = 16
"""Worlds between full garbage collections in a process. Each world leaves about 0.2 MB of reference cycles,
and the collector pauses of the map code (``gc.freeze``/``unfreeze``) keep the automatic full pass from running:
without this a process's memory grows with the worlds. A pass takes about 0.1 s."""

DEFAULT_CONFIGS = ("default",)
"""The configs a comparison runs unless told (``evmap compare --configs``)."""

_worlds_done = itertools.count(1)


def compare_world(
    index: int,
    seed: int,
    rules: Sequence[str],
    configs: Sequence[str] = DEFAULT_CONFIGS,
    params: WorldGenParams | None = None,
) -> WorldResult:
    """World ``index`` of the experiment ``seed``: generated, sensed once, fused by every config and rule.

    ``configs``: names of :func:`~evmap.maps.app.compare_configs.resolve_config`.

    >>> r = compare_world(0, 1, ["dempster", "bayes"], ["paper", "default"], WorldGenParams(single_pose_share=1))
    >>> r.world, [(row["config"], row["rule"]) for row in r.rows][:3], r.beliefs["paper", "bayes"].shape
    ('world-0000', [('paper', 'dempster'), ('paper', 'bayes'), ('default', 'dempster')], (2, 20))
    """
    if any(rule not in RULES for rule in rules):
        load_plugins()  # a worker process of its own: the rules of installed packages, registered on first use
    name = f"world-{index:04d}"
    scenario = generate_world(world_seed(seed, index), params, name=name)
    runs = fuse_configs(scenario, {c: resolve_config(c) for c in configs}, rules)
    by_sensing: dict[str, tuple[dict[str, Any], int]] = {}  # what the world offers a config's sensors
    offered = {}
    for c in configs:
        run = runs[c, rules[0]]  # every rule of a config fuses its scans
        key = sensing_key(run.config)
        if key not in by_sensing:
            judged = {
                "glass": visible_glass(run.world, run.config),
                "seen": stripe_seen(run.world, run.config),
                "heard": heard_glass(run.world, [obs.sonar for obs in run.observations]),
            }
            by_sensing[key] = judged, int(sunlight_seen_twice(run.world, run.config))
        offered[c] = by_sensing[key]
    rows = tuple(
        {
            "world": name,
            "config": c,
            "rule": rule,
            **world_metrics(run, **offered[c][0]),
            "sunlight_seen_twice": offered[c][1],
        }
        for (c, rule), run in runs.items()
    )
    beliefs = {variant: belief_histograms(run) for variant, run in runs.items()}
    if next(_worlds_done) % GC_EVERY == 0:
        gc.collect()
    return WorldResult(name, scenario_yaml(scenario), rows, beliefs)


def compare_batch(
    start: int,
    stop: int,
    seed: int,
    rules: Sequence[str],
    configs: Sequence[str] = DEFAULT_CONFIGS,
    params: WorldGenParams | None = None,
) -> list[WorldResult]:
    """Worlds ``start`` to ``stop - 1`` (:func:`compare_world`): the unit of work sent to a worker."""
    return [compare_world(i, seed, rules, configs, params) for i in range(start, stop)]


def batches(worlds: int, workers: int) -> Iterator[tuple[int, int]]:
    """The tasks' world ranges ``[start, stop)``, in order: each at most :data:`MAX_BATCH` worlds, and small enough
    to leave :data:`TASKS_PER_WORKER` tasks per worker of what remains, so the last tasks are single worlds and the
    workers finish together.

    >>> [stop - start for start, stop in batches(200, 2)][:3], [stop - start for start, stop in batches(200, 2)][-3:]
    ([4, 4, 4], [1, 1, 1])
    >>> list(batches(3, 2)), sum(1 for _ in batches(100_000, 64))
    ([(0, 1), (1, 2), (2, 3)], 26407)
    """
    start = 0
    while start < worlds:
        size = max(1, min(MAX_BATCH, (worlds - start) // (workers * TASKS_PER_WORKER)))
        yield start, min(start + size, worlds)
        start += size


def check_rules(rules: Sequence[str] | str) -> tuple[str, ...]:
    """Rule names from a sequence or a comma-separated string, checked against :data:`evidential.RULES`.

    >>> check_rules("dempster, yager")
    ('dempster', 'yager')
    >>> check_rules("dempster,nope")
    Traceback (most recent call last):
    ...
    ValueError: rules: unknown rule 'nope'; rules are: ...
    """
    names = [r.strip() for r in (rules.split(",") if isinstance(rules, str) else rules)]
    if not names or any(not n for n in names):
        raise ValueError(f"rules: need one or more comma-separated rule names, got {rules!r}")
    for n in names:
        try:
            check_rule(n)
        except ValueError as exc:
            raise ValueError(f"rules: {exc}") from None
    if len(set(names)) < len(names):
        raise ValueError(f"rules: a rule is named twice in {names}")
    return tuple(names)


def check_run(
    worlds: int, seed: int, workers: int | None, configs: Sequence[str] | str, scheduler: str | None = None
) -> tuple[str, ...]:
    """Check the numbers of a comparison and build its configs (a bad one fails here, before any work).

    ``configs``: names, or the text of ``--configs`` (:func:`~evmap.maps.app.compare_configs.config_names`).
    ``workers`` is refused with a scheduler it has no say in (``synchronous``, a scheduler's address).
    Returns the config names.
    """
    if not isinstance(worlds, int) or not 1 <= worlds <= MAX_WORLDS:
        raise ValueError(f"worlds must be an integer from 1 to {MAX_WORLDS}, got {worlds!r}")
    if not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise ValueError(f"seed must be an integer with 0 <= seed < 2**63, got {seed!r}")
    if workers is not None and (not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if workers is not None and scheduler not in (None, "threads", "processes"):
        where = "the worlds run in this process" if scheduler == "synchronous" else "the cluster has its own workers"
        raise ValueError(f"workers {workers} has no effect with scheduler {scheduler}: {where}")
    return config_names(configs if isinstance(configs, str) else ",".join(map(str, configs)))


def iter_results(
    rules: Sequence[str],
    worlds: int,
    seed: int,
    *,
    configs: Sequence[str] | str = DEFAULT_CONFIGS,
    params: WorldGenParams | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
) -> Iterator[WorldResult]:
    """Every config and rule on ``worlds`` generated worlds with the same scans, yielded in world order.

    Parameters
    ----------
    rules : names in :data:`evidential.RULES`.
    worlds : how many worlds (1 to :data:`MAX_WORLDS`); world ``i`` has seed ``world_seed(seed, i)``.
    seed : the experiment's seed, 0 <= seed < 2**63.
    configs : config names (:mod:`~evmap.maps.app.compare_configs`; default: the packaged default config);
        a cluster's workers must be able to read the files.
    params : the world generator's parameters.
    scheduler : see the module doc.
    workers : processes of the local cluster or pool (default: one per CPU).
    progress : show a progress bar on standard error from the start.

    Raises
    ------
    ValueError
        On a bad argument or config, or a scheduler that cannot be reached
        within :data:`~evmap.maps.app.compare_executors.CONNECT_TIMEOUT` seconds, before any world is computed.
    """
    rules = check_rules(rules)
    names = check_run(worlds, seed, workers, configs, scheduler)
    from tqdm import tqdm

    bar = tqdm(total=worlds, desc="compare", unit="world", file=sys.stderr, disable=not progress, mininterval=0.5)
    with bar:
        if scheduler == "synchronous" or (scheduler is None and workers is None and worlds < SYNCHRONOUS_BELOW):
            for i in range(worlds):
                yield compare_world(i, seed, rules, names, params)
                bar.update(1)
            return
        bar.set_postfix_str("starting workers", refresh=True)
        with interrupts_between_waits() as interrupted, executor(scheduler, workers) as (pool, wait, slots):
            tasks = batches(worlds, slots)
            pending: dict[Any, int] = {}
            done: dict[int, list[WorldResult]] = {}
            following = 0
            while True:
                interrupted()
                while len(pending) < slots * MAX_IN_FLIGHT_PER_WORKER and (task := next(tasks, None)) is not None:
                    start, stop = task
                    pending[pool.submit(compare_batch, start, stop, seed, rules, names, params)] = start
                if not pending:
                    return
                for future in wait(list(pending)):
                    done[pending.pop(future)] = future.result()
                interrupted()
                while following in done:
                    bar.set_postfix_str("", refresh=False)
                    batch = done.pop(following)
                    yield from batch
                    bar.update(len(batch))
                    following += len(batch)
                bar.refresh()


def run_comparison(rules: Sequence[str], worlds: int, seed: int, **options: Any) -> Comparison:
    """:func:`iter_results` gathered into a :class:`Comparison`, with every row and scenario kept in memory.

    ``options`` are those of :func:`iter_results`. For big runs stream instead (``evmap compare`` does).

    >>> one_pose = WorldGenParams(single_pose_share=1)
    >>> c = run_comparison(["dempster", "yager"], 2, 1, params=one_pose, scheduler="synchronous", progress=False)
    >>> [(row["config"], row["rule"]) for row in c.summary], len(c.rows), sorted(c.scenarios)
    ([('default', 'dempster'), ('default', 'yager')], 4, ['world-0000', 'world-0001'])
    """
    rules = check_rules(rules)
    configs = check_run(
        worlds, seed, options.get("workers"), options.pop("configs", DEFAULT_CONFIGS), options.get("scheduler")
    )
    tally, rows, scenarios = Tally(configs, rules), [], {}
    for result in iter_results(rules, worlds, seed, configs=configs, **options):
        tally.add(result)
        rows += result.rows
        scenarios[result.world] = result.yaml
    return tally.comparison(seed, rows, scenarios)
