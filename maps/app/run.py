"""One run of the paper's experiment on a scenario: sense every pose, fold it into a map, report.

:func:`run_scenario` is what ``evmap run`` computes (``evmap log`` makes its
runs with :func:`evmap.maps.app.log_run.run_log`: no world, a :class:`LogSummary`);
:func:`report` and :func:`segment_records` give ``report.json`` and
``segments.json`` of ``docs/SCENARIO.md`` for both.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from evmap.maps import new_map
from evmap.maps.app.metrics import share
from evmap.maps.belief_map import BeliefMap
from evmap.maps.observation import Observation, observe, sensing_config
from evmap.maps.pipeline import PoseOutcome
from evmap.maps.segments import SegmentStore
from evmap.sources.config_model import Config
from evmap.sources.sim.scenario import Scenario
from evmap.sources.sim.world import World

if TYPE_CHECKING:
    from evmap.sources.line_fit import ScanFit

__all__ = ["LogSummary", "Run", "report", "run_scenario", "segment_records"]


@dataclass(frozen=True)
class LogSummary:
    """What a run over a robot log measured besides the map (``report.json``'s logs section).

    Attributes
    ----------
    source : the log read.
    scans : the scans used (after ``--every`` and ``--limit``).
    scans_skipped : the scans of the log, before the last one used, that the reader could not place
        (no pose known for them).
    sonar : ``"log"`` if the log's sonar readings were folded in, ``"none"`` if it had none
        (the sonar stages skipped).
    coverage_mean, rms_error_median : PLE's line-fit measures of the scans' laser segments
        (:func:`evmap.sources.line_fit.log_fit`); None (``null``) where undefined.
    per_scan_median : median seconds of one scan's computation (extraction and update).
    laser_noise : the laser's range noise std (m) the log's first scans show
        (:func:`evmap.sources.laser.range_noise`).
    fits : each scan's line fit: where its returned rays ended, and which its segments explain
        (drawn in ``fig9_line_fit``; not in the report).
    """

    source: str
    scans: int
    scans_skipped: int
    sonar: str
    coverage_mean: float | None
    rms_error_median: float | None
    per_scan_median: float
    laser_noise: float
    fits: tuple[ScanFit, ...]


@dataclass(frozen=True, eq=False)
class Run:
    """Everything one run computed.

    Attributes
    ----------
    world : the simulated world; None for a robot log. config : the config (its rule included).
    observations : one per pose; outcomes : what each update did.
    map : the final belief map; seconds : ``simulate``, ``fuse`` and ``total`` (computation only).
    log : for a robot log, what it measured besides (None for a simulation).
    """

    world: World | None
    config: Config
    observations: list[Observation]
    outcomes: list[PoseOutcome]
    map: BeliefMap
    seconds: dict[str, float]
    log: LogSummary | None = None


def run_scenario(scenario: Scenario, config: Config) -> Run:
    """Simulate the scenario's sensors at every pose and fold each pose into one belief map.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> run = run_scenario(default_scenario(), load_config())
    >>> run.map.rule, len(run.outcomes)
    ('dempster', 1)
    """
    world = World(scenario)
    config = sensing_config(world, config)
    start = time.perf_counter()
    observations = [observe(world, k, config) for k in range(len(world.poses))]
    sensed = time.perf_counter()
    bm = new_map(config)
    outcomes = [bm.update(obs) for obs in observations]
    done = time.perf_counter()
    seconds = {"simulate": sensed - start, "fuse": done - sensed, "total": done - start}
    return Run(world, config, observations, outcomes, bm, seconds)


def report(run: Run) -> dict[str, Any]:
    """The figures of ``report.json`` (``docs/SCENARIO.md``; its logs section for a run over a log)."""
    if run.log is not None:
        return _log_report(run, run.log)
    store: SegmentStore = run.map.segments
    noise = store.truth == "noise"
    real = store.truth == "real"
    raw = store.raw  # a line's consolidated support is no segment a sensor saw
    return {
        "scenario": run.world.name,
        "rule": run.config.rule,
        "poses": len(run.observations),
        "lsl_segments": int(raw.sum()),
        "noise_segments": int(noise.sum()),
        "noise_eliminated": int((store.eliminated & noise).sum()),
        "real_eliminated": int((store.eliminated & real).sum()),
        "lines_before_merge": int((~store.eliminated & raw).sum()),
        **_map_counts(run),
        "noise_recall": share(store.eliminated & noise, noise),
        "real_loss": share(store.eliminated & real, real),
        "seconds": dict(run.seconds),
    } | sensors_report(run)


def sensors_report(run: Run) -> dict[str, Any]:
    """``report.json``'s ``sensors``, if the config declares YAML sensors: per sensor its kind and per feature,
    how many of the run's raw segments took each category, or a number's min / median / max (``segments``),
    and where the truth is known, the same over the sunlight phantoms (``phantoms``).

    >>> from evmap import configs
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> report = sensors_report(run_scenario(default_scenario(), load_config(configs.path("examples/radar.yaml"))))
    >>> radar = report["sensors"]["radar"]
    >>> radar["kind"], radar["features"]["radar_detection"]["segments"], radar["features"]["radar_detection"]["phantoms"]
    ('detector', {'detected': 28, 'missed': 24, 'out_of_view': 14}, {'detected': 0, 'missed': 21, 'out_of_view': 7})
    """
    if not run.config.extra_sensors:
        return {}
    store: SegmentStore = run.map.segments
    raw = store.raw
    truth_known = bool(np.isin(store.truth[raw], ("real", "noise")).all())
    phantom = store.truth[raw] == "noise"

    def tally(values: NDArray[Any], categories: tuple[str, ...] | None) -> dict[str, Any]:
        if categories is None:
            numbers = values.astype(float)
            return {"min": float(numbers.min()), "median": float(np.median(numbers)), "max": float(numbers.max())}
        return {c: int((values == c).sum()) for c in categories}

    out: dict[str, Any] = {}
    for name, sensor in run.config.extra_sensors.items():
        features: dict[str, Any] = {}
        for feature, categories in sensor.declares().items():
            values = store.features[feature][raw] if feature in store.features else np.zeros(0, dtype=str)
            if not len(values):
                continue
            features[feature] = {"segments": tally(values, categories)}
            if truth_known and phantom.any():
                features[feature]["phantoms"] = tally(values[phantom], categories)
        out[name] = {"kind": sensor.kind.name, "features": features}
    return {"sensors": out}


def segment_records(run: Run) -> list[dict[str, Any]]:
    """``segments.json``: every LSL (or laser) segment before fusion, with its verdict.

    Ids are rows of the map's segment store; a line's consolidated support, standing or absorbed into a later
    one, is no segment a sensor saw and is left out (:attr:`~evmap.maps.segments.SegmentStore.raw`), and the
    segments it absorbed keep the verdict they last had. An unknown ground truth is written ``"unknown"``.
    """
    store: SegmentStore = run.map.segments
    frame = run.map.frame
    labels = [frame.label(mask) for mask in range(store.mass.shape[1])]
    features = store.features
    extra = [{name: column[i].item() for name, column in features.items()} for i in range(len(store))]
    return [
        {
            "id": i,
            "pose": int(store.pose[i]),
            "p": store.p[i].tolist(),
            "q": store.q[i].tolist(),
            "truth": str(store.truth[i]) or "unknown",
            "relation": str(store.relation[i]),
            "mass": {labels[m]: float(v) for m, v in enumerate(store.mass[i]) if v > 0 or labels[m] != ""},
            "eliminated": bool(store.eliminated[i]),
            **({"features": extra[i]} if features else {}),
        }
        for i in np.flatnonzero(store.raw).tolist()
    ]


def _map_counts(run: Run) -> dict[str, int]:
    """The final map's lines, corners and unidentified objects, and the RCDs of its updates (both reports)."""
    g = run.map.graph
    kinds = [d.get("kind") for d in g.nodes.values()]
    return {
        "lines_after_merge": g.number_of_edges(),
        "corners": kinds.count("corner"),
        "rcds_actual": sum(len(o.actual) for o in run.outcomes),
        "rcds_simulated": sum(len(o.predicted) for o in run.outcomes),
        "rcds_matched": sum(len(o.matched[0]) for o in run.outcomes),
        "unidentified": kinds.count("unidentified"),
    }


def _log_report(run: Run, log: LogSummary) -> dict[str, Any]:
    """``report.json`` of a run over a robot log: no ground truth, the line fit, the sonar's provenance."""
    store: SegmentStore = run.map.segments
    raw = store.raw
    return {
        "scenario": None,  # no simulated scenario: the contract's key, kept for the tools that read it
        "log": log.source,
        "rule": run.config.rule,
        "scans": log.scans,
        "scans_skipped": log.scans_skipped,
        "poses": len(run.observations),
        "sonar": log.sonar,
        "laser_noise": log.laser_noise,
        "lsl_segments": int(raw.sum()),
        "noise_segments": None,
        "noise_eliminated": None,
        "real_eliminated": None,
        "eliminated": int((store.eliminated & raw).sum()),
        "lines_before_merge": int((~store.eliminated & raw).sum()),
        **_map_counts(run),
        "noise_recall": None,
        "real_loss": None,
        "line_fit": {"coverage_mean": log.coverage_mean, "rms_error_median": log.rms_error_median},
        "seconds": {"total": run.seconds["total"], "per_scan_median": log.per_scan_median},
    } | sensors_report(run)
