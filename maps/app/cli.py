"""The ``evmap`` command: one function per subcommand.

``evmap run [SCENARIO] [--config FILE] [--rule NAME] [--out DIR] [--force] [--json]``
    run the paper's experiment on a scenario (default: the embedded corridor)
    and write ``report.json``, ``segments.json``, ``map.json`` and the figures
    into DIR (``docs/SCENARIO.md``); ``--json`` also prints the report on
    standard output, and nothing else goes there.
``evmap compare --rules dempster,yager,... --worlds N --seed S --out DIR [--scheduler ADDRESS]``
    every rule on the same scans of N generated worlds: per-rule and per-world
    tables (CSV, Markdown) and plots (see :mod:`evmap.maps.app.compare`).
``evmap config check [FILE]``
    validate a config file and print every frame, source, table and stage
    parameter as it was understood.
``evmap config explain [FILE] --source NAME --value V``
    print what a source gives for one feature value, and what that combines to
    with each row of the other sources of its stages, under the config's rule.

``FILE`` defaults to the packaged ``configs/paper.yaml``. Normal output goes to
standard output. A mistake in the input (a bad file, an unknown source, a value
a source cannot judge) prints ``evmap: error: <message>`` on standard error and
exits with status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel

from evidential import Frame, TotalConflictError, combine_batch
from evmap.maps.app.artefacts import prepare_out, write_staged
from evmap.maps.app.compare import add_compare_parser
from evmap.maps.app.run import run_scenario
from evmap.sources.config import PARAMETER_SECTIONS, Config, SensorsParams, load_config
from evmap.sources.sim.scenario import default_scenario, load_scenario

__all__ = ["build_parser", "config_check", "config_explain", "main", "run_command"]

Handler = Callable[[argparse.Namespace], int]

MAX_EXPLAIN_ROWS = 1000
"""Most combinations ``evmap config explain`` prints for one stage."""


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``evmap`` command with ``argv`` (default: ``sys.argv[1:]``); return the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse printed the usage error (2) or the help (0)
        return exc.code if isinstance(exc.code, int) else 2
    handler: Handler = args.handler
    try:
        return handler(args)
    except ValueError as exc:  # InputError and every other complaint about user input
        print(f"evmap: error: {exc}", file=sys.stderr)
        return 2


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``evmap``; each leaf subcommand sets ``handler``."""
    parser = argparse.ArgumentParser(
        prog="evmap", description="Evidential sonar and laser structured-light fusion into a belief map."
    )
    parser.set_defaults(handler=lambda args: _usage(parser))
    commands = parser.add_subparsers(title="commands", metavar="COMMAND")

    run = commands.add_parser("run", help="run the paper's experiment on a scenario and write its artefacts")
    run.add_argument("scenario", nargs="?", help="scenario file (default: the embedded corridor of the paper)")
    run.add_argument("--config", help="config file (default: the packaged configs/paper.yaml)")
    run.add_argument("--rule", help="combination rule, overriding the config's (a name in evidential.RULES)")
    run.add_argument("--out", default="out", help="directory for the artefacts (default: out)")
    run.add_argument("--force", action="store_true", help="replace the directory if it is not empty")
    run.add_argument("--json", action="store_true", help="print report.json on standard output")
    run.set_defaults(handler=run_command)

    add_compare_parser(commands)

    config = commands.add_parser("config", help="check a config file, explain its evidence sources")
    config.set_defaults(handler=lambda args: _usage(config))
    actions = config.add_subparsers(title="actions", metavar="ACTION")

    check = actions.add_parser("check", help="validate a config and print it as understood")
    check.add_argument("file", nargs="?", help="config file (default: the packaged configs/paper.yaml)")
    check.set_defaults(handler=config_check)

    explain = actions.add_parser(
        "explain", help="show what a source gives for a value and what it combines to in its stages"
    )
    explain.add_argument("file", nargs="?", help="config file (default: the packaged configs/paper.yaml)")
    explain.add_argument("--source", required=True, help="name of a source of the config")
    explain.add_argument(
        "--value", required=True, help="the feature value: a number for a ramp, a category for a table"
    )
    explain.set_defaults(handler=config_explain)
    return parser


def run_command(args: argparse.Namespace) -> int:
    """``evmap run``: the paper's experiment on a scenario, its artefacts written all or nothing."""
    cfg = load_config(args.config)
    if args.rule:
        cfg = cfg.with_rule(args.rule)
    scenario = load_scenario(args.scenario) if args.scenario else default_scenario()
    with prepare_out(args.out, args.force) as staging:  # --out checked and claimed before the work
        print(f"evmap: running scenario {scenario.name!r} with rule {cfg.rule!r}", file=sys.stderr)
        summary = write_staged(run_scenario(scenario, cfg), staging)
    kept = summary["noise_segments"] - summary["noise_eliminated"]
    print(
        f"evmap: {summary['noise_eliminated']} of {summary['noise_segments']} phantom lines eliminated "
        f"({kept} kept), {summary['real_eliminated']} real lost; {summary['lines_before_merge']} -> "
        f"{summary['lines_after_merge']} lines, {summary['corners']} corners; {summary['rcds_matched']} of "
        f"{summary['rcds_actual']} RCDs matched, {summary['unidentified']} unidentified objects; "
        f"{summary['seconds']['total']:.3f} s; written to {args.out}",
        file=sys.stderr,
    )
    if args.json:
        print(json.dumps(summary, indent=2))
    return 0


def config_check(args: argparse.Namespace) -> int:
    """``evmap config check [FILE]``: validate and print the config as understood."""
    cfg = load_config(args.file)
    out = [f"{cfg.name}: valid", f"rule: {cfg.rule}", ""]
    for name, frame in cfg.frames.items():
        role = " (the map's frame)" if name == cfg.frame_name else ""
        out.append(f"frame {name}{role}: {', '.join(frame.elements)}")
        for alias, written in cfg.aliases[name].items():
            out.append(f"  alias {alias} = {_label(frame, frame.mask(written))}")
    for name in cfg.sources:
        out += ["", *_describe_source(cfg, name)]
    out += ["", f"stages (combined by {cfg.rule}):"]
    out += [f"  {stage}: {', '.join(names)}" for stage, names in cfg.stages.items()]
    out += ["", "parameters:"]
    for section in PARAMETER_SECTIONS:
        model = getattr(cfg, section)
        if isinstance(model, SensorsParams):
            out += [f"  {section}.{sensor}: {_fields(params)}" for sensor, params in model]
        else:
            out.append(f"  {section}: {_fields(model)}")
    print("\n".join(out))
    return 0


def config_explain(args: argparse.Namespace) -> int:
    """``evmap config explain [FILE] --source NAME --value V``: one value through its source and stages."""
    cfg = load_config(args.file)
    if args.source not in cfg.sources:
        raise ValueError(f"unknown source {args.source!r}; sources are: {', '.join(cfg.sources)}")
    source = cfg.sources[args.source]
    m = source.masses({source.feature: [args.value]})
    out = [
        (
            f"{source.name} ({getattr(source, 'kind', type(source).__name__)} on {source.feature!r}), "
            f"{source.feature} = {args.value}:"
        ),
        f"  {_masses(source.frame, m[0])}",
    ]
    stages = [stage for stage, names in cfg.stages.items() if source.name in names]
    if not stages:
        out.append(f"  (no stage combines {source.name})")
    for stage in stages:
        out += ["", *_explain_stage(cfg, stage, source.name, m)]
    print("\n".join(out))
    return 0


def _explain_stage(cfg: Config, stage: str, name: str, m: NDArray[np.float64]) -> list[str]:
    """The source's masses ``m`` (one row) combined with every row of the stage's other sources."""
    others = [s for s in cfg.stage_sources(stage) if s.name != name]
    if not others:
        return [f"stage {stage}: {name} is its only source; its masses are combined into each object's stored belief"]
    total = math.prod(len(getattr(s, "examples", ())) for s in others)
    if not total:
        return [f"stage {stage}: its other sources show no example rows"]
    rows = list(itertools.islice(itertools.product(*(s.examples for s in others)), MAX_EXPLAIN_ROWS))
    # one batch: every combination of the other sources' rows, with the explained source
    columns = [np.array([row[i] for row in rows]) for i in range(len(others))]
    masses = [s.masses({s.feature: col}) for s, col in zip(others, columns)]
    batch = [np.repeat(m, len(rows), axis=0), *masses]
    fused = _combine_rows(batch, cfg.rule)
    k = combine_batch(*batch, rule="conjunctive")[:, 0]  # K: the conjunctive mass on the empty set
    frame = cfg.frame
    decide = stage == "noise_elimination" and "noise" in frame.elements
    out = [f"stage {stage}, combined by {cfg.rule} with each row of {', '.join(s.name for s in others)}:"]
    for i, row in enumerate(rows):
        given = "; ".join(
            f"{s.name} ({s.feature} = {value}): {_masses(frame, mass[i])}"
            for s, value, mass in zip(others, row, masses)
        )
        if fused[i] is None:
            out += [f"  with {given}", f"    -> total conflict (K = {k[i]:.6g}): {cfg.rule} is undefined"]
            continue
        line = f"    -> {_masses(frame, fused[i])}; K = {k[i]:.6g}"
        if decide:
            noise = fused[i][frame.mask("noise")]
            verdict = "removed" if noise > cfg.noise.threshold else "kept"
            relation = ">" if noise > cfg.noise.threshold else "<="
            line += f"; m(noise) = {noise:.6g} {relation} {cfg.noise.threshold:g}: {verdict}"
        out += [f"  with {given}", line]
    if total > len(rows):
        out.append(f"  (the first {len(rows)} of {total} rows)")
    return out


def _combine_rows(batch: list[NDArray[np.float64]], rule: str) -> list[NDArray[np.float64] | None]:
    """Combine a batch row by row under ``rule``; ``None`` for a row in total conflict."""
    try:
        return list(combine_batch(*batch, rule=rule))
    except TotalConflictError:  # find which rows: combine them one at a time
        rows: list[NDArray[np.float64] | None] = []
        for i in range(len(batch[0])):
            try:
                rows.append(combine_batch(*(m[i : i + 1] for m in batch), rule=rule)[0])
            except TotalConflictError:
                rows.append(None)
        return rows


def _describe_source(cfg: Config, name: str) -> list[str]:
    """A source as understood: its kind, frame, feature, and its masses at its example values."""
    source = cfg.sources[name]
    frame_name = next(k for k, f in cfg.frames.items() if f == source.frame)
    out = [f"source {name} (frame {frame_name}): {getattr(source, 'summary', type(source).__name__)}"]
    examples = list(getattr(source, "examples", ()))
    if examples:
        masses = source.masses({source.feature: np.array(examples)})
        width = max(len(str(e)) for e in examples)
        out += [
            f"  {source.feature} = {e!s:<{width}}  {_masses(source.frame, row)}" for e, row in zip(examples, masses)
        ]
    return out


def _masses(frame: Frame, row: NDArray[np.float64]) -> str:
    """Non-zero masses of one mass function, e.g. ``real 0.3, real|noise 0.7``."""
    return ", ".join(f"{_label(frame, b)} {row[b]:.6g}" for b in np.flatnonzero(row)) or "(no mass)"


def _label(frame: Frame, mask: int) -> str:
    """A focal set as written in YAML: names in frame order joined by ``|``; ``""`` the empty set."""
    return frame.label(mask) or '""'


def _fields(model: BaseModel) -> str:
    """A parameter model as ``key=value`` pairs."""
    return " ".join(f"{k}={v}" for k, v in model)


def _usage(parser: argparse.ArgumentParser) -> int:
    """A command without its subcommand: print the usage to stderr, exit 2."""
    parser.print_usage(sys.stderr)
    print(f"{parser.prog}: error: a subcommand is required", file=sys.stderr)
    return 2
