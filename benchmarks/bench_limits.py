"""Cost of ``evmap run`` on the worst valid inputs at the documented limits (``docs/SCENARIO.md``, *Limits*).

For each limit that drives the cost, a scenario (or config) at the limit is written and
``evmap run`` runs on it in a fresh process, under the paper's config and the default
config (``--figures none``; the biggest case also with png figures). The wall segments at their
limit come in the arrangements that cost the most found: a ring all in sight, a zigzag ring (facets
nearly edge-on, few first-order echoes, so the sonar model tries every second-order path), a dense
clutter of crossing walls; the zigzag also under the densest sensors and a detector at its patch limit. Printed per case:
the limit, its value, wall seconds and peak resident memory of the process, and whether
it holds the budget of 60 s and 4 GB. The machine these numbers come from is shared (2
cores, loaded): times may be up to about twice the quiet value, so a case over half the
budget is rerun (``--repeat``) and the median printed.

    .venv/bin/python benchmarks/bench_limits.py [--cases poses-cluster walls-ring] [--configs paper default]
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import yaml
from limit_scenes import (
    cylinders,
    everything,
    phantoms,
    poses_cluster,
    poses_corridor,
    sensors,
    sensors_zigzag,
    sunlight_regions,
    walls_ring,
    walls_scattered,
    walls_zigzag,
)

from evmap import configs
from evmap.sources.config_model import MAX_FRAME_ELEMENTS, MAX_FRAMES, MAX_SOURCES, MAX_STAGE_SOURCES
from evmap.sources.detector import MAX_PATCHES
from evmap.sources.params import MAX_STRIPE_POINTS
from evmap.sources.range_sensor import MAX_RANGE_RAYS
from evmap.sources.sensor_kinds import MAX_SENSORS
from evmap.sources.sim.spec import (
    MAX_CYLINDERS,
    MAX_PHANTOMS_PER_RUN,
    MAX_POLYGON_VERTICES,
    MAX_POSES,
    MAX_SUNLIGHT_LINES,
    MAX_SUNLIGHT_LINES_PER_REGION,
    MAX_SUNLIGHT_REGIONS,
    MAX_WALL_SEGMENTS,
)

EVMAP = str(Path(sys.executable).with_name("evmap"))
BUDGET_SECONDS = 60.0
BUDGET_MB = 4096.0
TIMEOUT = 150.0
"""A run still going after this many seconds is stopped and reported as over the budget."""
MEMORY_CAP = 8 << 30
"""Address space of a run (bytes), so that a runaway case cannot take the shared machine's memory."""


@dataclass(frozen=True)
class Case:
    """A worst valid input at one limit: the scenario text and, optionally, a config replacing ``--config``."""

    name: str
    limit: str
    value: str
    scenario: Callable[[], str]
    config: Callable[[], str] | None = None


def config_limits() -> str:
    """The default config widened to the config limits: MAX_FRAMES frames of MAX_FRAME_ELEMENTS elements,
    MAX_SOURCES sources, every table spreading its mass over every focal set of the map's frame."""
    data = yaml.safe_load(configs.path("default.yaml").read_text())
    elements = ["real", "noise", *(f"e{k}" for k in range(2, MAX_FRAME_ELEMENTS))]
    focal = ["|".join(e for i, e in enumerate(elements) if mask >> i & 1) for mask in range(1, 1 << len(elements))]
    frames = {"existence": {"elements": elements, "aliases": {"unknown": "|".join(elements)}}}
    frames |= {f"f{k}": {"elements": [f"x{i}" for i in range(MAX_FRAME_ELEMENTS)]} for k in range(1, MAX_FRAMES)}

    def dense(categories: list[str]) -> dict[str, dict[str, float]]:
        """A table giving every category mass on every focal set (most on Θ, so the combination stays defined)."""
        row = {f: 0.2 / len(focal) for f in focal[:-1]} | {focal[-1]: 0.8 + 0.2 / len(focal)}
        return {c: row for c in categories}

    features = {
        "noise_elimination": [
            ("relation", ["outside", "partly_inside", "inside"]),
            ("contour_free", ["contradicted", "clear"]),
            ("lsl_persistence", ["missed", "seen", "unobserved"]),
            ("sonar_forward", ["contradicted", "confirmed", "silent"]),
        ],
        "reinforcement": [("sonar_match", ["matched", "missed", "unobserved"])],
        "unidentified": [("rcd_type", ["I", "II", "III", "IV"])],
    }
    shares = {"noise_elimination": MAX_SOURCES - 8, "reinforcement": 4, "unidentified": 4}
    sources, stages = {}, {}
    for stage, count in shares.items():
        names = [f"{stage}_{k}" for k in range(min(count, MAX_STAGE_SOURCES))]
        for k, name in enumerate(names):
            feature, categories = features[stage][k % len(features[stage])]
            sources[name] = {
                "kind": "table",
                "frame": "existence",
                "feature": feature,
                "categories": categories,
                "table": dense(categories),
            }
        stages[stage] = names
    stages["repeated_observation"] = []
    data |= {"frames": frames, "sources": sources, "stages": stages}
    return yaml.safe_dump(data, sort_keys=False)


def config_sensors() -> str:
    """The default config with MAX_SENSORS range sensors of MAX_RANGE_RAYS rays each, every one read by a source."""
    data = yaml.safe_load(configs.path("default.yaml").read_text())
    rays = 5
    sensors = {
        f"r{k}": {"kind": "range", "beams": MAX_RANGE_RAYS // rays, "rays": rays, "cone_deg": 30, "max_range": 100.0}
        for k in range(MAX_SENSORS)
    }
    table = {
        "echo": {"real": 0.6, "unknown": 0.4},
        "beyond": {"noise": 0.6, "unknown": 0.4},
        "no_return": {"unknown": 1},
    }
    for name in sensors:
        data["sources"][name] = {
            "kind": "table",
            "frame": "existence",
            "feature": f"{name}_return",
            "categories": list(table),
            "table": table,
        }
    data["extra_sensors"] = sensors
    data["stages"]["noise_elimination"] += list(sensors)
    return yaml.safe_dump(data, sort_keys=False)


def config_detector() -> str:
    """The default config with a detector that reports every wall in patches small enough that the zigzag ring of
    :func:`walls_zigzag` makes nearly MAX_PATCHES of them, all within its range, each detected; read by a source."""
    data = yaml.safe_load(configs.path("default.yaml").read_text())
    radii = [6 - 0.2 * (k % 2) for k in range(MAX_WALL_SEGMENTS)]
    corners = [
        (r * math.cos(2 * math.pi * k / len(radii)), r * math.sin(2 * math.pi * k / len(radii)))
        for k, r in enumerate(radii)
    ]
    longest = max(math.dist(a, b) for a, b in zip(corners, corners[1:] + corners[:1], strict=True))
    patch = max(0.01, math.ceil(longest / (MAX_PATCHES // MAX_WALL_SEGMENTS) * 1e4) / 1e4)  # no segment cut more
    data["extra_sensors"] = {
        "radar": {
            "kind": "detector",
            "materials": ["wall"],
            "max_range": 100.0,
            "detection": [[0.0, 1.0], [100.0, 1.0]],
            "false_alarms": [[0.0, 0.0], [100.0, 0.0]],
            "patch": patch,
        }
    }
    data["sources"]["radar"] = {
        "kind": "table",
        "frame": "existence",
        "feature": "radar_detection",
        "categories": ["detected", "missed", "out_of_view"],
        "table": {
            "detected": {"real": 0.6, "unknown": 0.4},
            "missed": {"noise": 0.5, "unknown": 0.5},
            "out_of_view": {"unknown": 1},
        },
    }
    data["stages"]["noise_elimination"].append("radar")
    return yaml.safe_dump(data, sort_keys=False)


CASES = (
    Case("poses-cluster", "MAX_POSES; MAX_PHANTOMS_PER_RUN", f"{MAX_POSES}; {MAX_PHANTOMS_PER_RUN}", poses_cluster),
    Case("poses-corridor", "MAX_POSES; MAX_PHANTOMS_PER_RUN", f"{MAX_POSES}; {MAX_PHANTOMS_PER_RUN}", poses_corridor),
    Case(
        "phantoms-2-poses",
        "MAX_PHANTOMS_PER_RUN; MAX_SUNLIGHT_LINES_PER_REGION",
        f"{MAX_PHANTOMS_PER_RUN}; {MAX_SUNLIGHT_LINES_PER_REGION}",
        phantoms(2),
    ),
    Case("phantoms-1-pose", "MAX_SUNLIGHT_LINES (per pose)", f"{MAX_SUNLIGHT_LINES}", phantoms(1)),
    Case("walls-ring", "MAX_WALL_SEGMENTS (in sight)", f"{MAX_WALL_SEGMENTS}", walls_ring(1)),
    Case(
        "walls-ring-poses", "MAX_WALL_SEGMENTS; MAX_POSES", f"{MAX_WALL_SEGMENTS}; {MAX_POSES}", walls_ring(MAX_POSES)
    ),
    Case("walls-zigzag", "MAX_WALL_SEGMENTS; MAX_POSES", f"{MAX_WALL_SEGMENTS}; {MAX_POSES}", walls_zigzag),
    Case("walls-scattered", "MAX_WALL_SEGMENTS; MAX_POSES", f"{MAX_WALL_SEGMENTS}; {MAX_POSES}", walls_scattered),
    Case("cylinders", "MAX_CYLINDERS; MAX_POSES", f"{MAX_CYLINDERS}; {MAX_POSES}", cylinders),
    Case(
        "sunlight-regions",
        "MAX_SUNLIGHT_REGIONS; MAX_POLYGON_VERTICES; MAX_POSES",
        f"{MAX_SUNLIGHT_REGIONS}; {MAX_POLYGON_VERTICES}; {MAX_POSES}",
        sunlight_regions,
    ),
    Case("everything", "all counts above at once", "", everything),
    Case(
        "sensors",
        "MAX_STRIPE_POINTS; MAX_WALL_SEGMENTS; MAX_POSES",
        f"{MAX_STRIPE_POINTS}; sonar step 0.1 deg",
        sensors,
    ),
    Case(
        "sensors-zigzag",
        "MAX_STRIPE_POINTS; MAX_WALL_SEGMENTS; MAX_POSES",
        f"{MAX_STRIPE_POINTS}; {MAX_WALL_SEGMENTS} zigzag; sonar step 0.1 deg",
        sensors_zigzag,
    ),
    Case(
        "config-limits",
        "MAX_FRAMES; MAX_FRAME_ELEMENTS; MAX_SOURCES",
        f"{MAX_FRAMES}; {MAX_FRAME_ELEMENTS}; {MAX_SOURCES}",
        poses_cluster,
        config_limits,
    ),
    Case(
        "config-sensors",
        "MAX_SENSORS; MAX_RANGE_RAYS; MAX_WALL_SEGMENTS; MAX_POSES",
        f"{MAX_SENSORS}; {MAX_RANGE_RAYS}; {MAX_WALL_SEGMENTS}; {MAX_POSES}",
        walls_ring(MAX_POSES),
        config_sensors,
    ),
    Case(
        "config-detector",
        "MAX_PATCHES; MAX_WALL_SEGMENTS; MAX_POSES",
        f"{MAX_PATCHES}; {MAX_WALL_SEGMENTS} zigzag; {MAX_POSES}",
        walls_zigzag,
        config_detector,
    ),
)


@dataclass(frozen=True)
class Measure:
    """One run: wall seconds, peak resident memory (MB) and how it ended."""

    seconds: float
    peak_mb: float
    status: str


def measure(command: list[str]) -> Measure:
    """Run ``command`` in a fresh process (address space capped): its wall time and peak RSS (``wait4``)."""
    with tempfile.TemporaryFile() as errors:
        start = time.perf_counter()
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=errors)
        resource.prlimit(process.pid, resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
        status = "ok"
        pid, code, usage = os.wait4(process.pid, os.WNOHANG)
        while not pid:
            if time.perf_counter() - start > TIMEOUT:
                process.kill()
                pid, code, usage = os.wait4(process.pid, 0)
                status = f"stopped after {TIMEOUT:.0f} s"
                break
            time.sleep(0.05)
            pid, code, usage = os.wait4(process.pid, os.WNOHANG)
        seconds = time.perf_counter() - start
        process.returncode = os.waitstatus_to_exitcode(code)
        errors.seek(0)
        last = (errors.read().decode(errors="replace").strip().splitlines() or [""])[-1]
    if status == "ok" and process.returncode:
        status = f"exit {process.returncode}: {last[:100]}"
    return Measure(seconds, usage.ru_maxrss / 1024, status)


def row(case: Case, config: str, figures: str, runs: list[Measure]) -> str:
    """One table row; the median of the runs (a single run unless it was borderline)."""
    seconds = statistics.median(m.seconds for m in runs)
    peak = max(m.peak_mb for m in runs)
    failed = [m.status for m in runs if m.status != "ok"]
    within = "yes" if not failed and seconds <= BUDGET_SECONDS and peak <= BUDGET_MB else "NO"
    note = f" ({failed[0]})" if failed else ""
    label = f"{case.name} [{config}{'' if figures == 'none' else ', ' + figures}]"
    return f"| {label} | {case.limit} | {case.value} | {seconds:.1f} | {peak:.0f} | {within}{note} |"


def run_case(case: Case, config: str, figures: str, repeat: int, tmp: Path) -> list[Measure]:
    """Run one case under one config; rerun it ``repeat`` times in all when it takes over half the budget."""
    scenario = tmp / f"{case.name}.yaml"
    scenario.write_text(case.scenario())
    if case.config is not None:
        config_file = tmp / f"{case.name}-config.yaml"
        config_file.write_text(case.config())
        config = str(config_file)
    command = [
        EVMAP,
        "run",
        str(scenario),
        "--config",
        config,
        "--figures",
        figures,
        "--out",
        str(tmp / "out"),
        "--force",
    ]
    runs = [measure(command)]
    while len(runs) < repeat and runs[0].status == "ok" and runs[0].seconds > BUDGET_SECONDS / 2:
        runs.append(measure(command))
    return runs


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=[c.name for c in CASES], choices=[c.name for c in CASES])
    parser.add_argument("--configs", nargs="*", default=["paper", "default"])
    parser.add_argument("--repeat", type=int, default=3, help="runs of a case over half the budget (median)")
    parser.add_argument("--figures-case", default="everything", help="the case also run with png figures")
    args = parser.parse_args()
    print(
        f"budget {BUDGET_SECONDS:.0f} s and {BUDGET_MB / 1024:.0f} GB per run; load average now "
        f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores: on a shared, loaded machine times may be up to "
        "about twice the quiet value (a case over half the budget is rerun, the median shown)"
    )
    print("| case [config] | limit | value | seconds | peak MB | within 60 s / 4 GB |")
    print("| --- | --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory(prefix="evmap-bench-limits-") as tmp:
        for case in (c for c in CASES if c.name in args.cases):
            configs_run = args.configs if case.config is None else ["limits"]
            for config in configs_run:
                print(row(case, config, "none", run_case(case, config, "none", args.repeat, Path(tmp))), flush=True)
            if case.name == args.figures_case:
                print(row(case, "default", "png", run_case(case, "default", "png", args.repeat, Path(tmp))), flush=True)


if __name__ == "__main__":
    main()
