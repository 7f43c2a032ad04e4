"""The ``evmap`` command: one function per subcommand.

``evmap run [SCENARIO] [--config FILE] [--rule NAME] [--out DIR] [--force] [--json] [--figures FORMAT]``
    run the paper's experiment on a scenario (default: the embedded corridor) and write ``report.json``,
    ``segments.json``, ``map.json`` and the figures (``--figures png|svg|pdf|none``, default png;
    ``--no-figures`` is ``none``) into DIR (``docs/SCENARIO.md``); ``--json`` also prints the report on
    standard output, and nothing else goes there.
``evmap log FILE [--out DIR] [--every N] [--limit N] [--unit U] [--readings DIR] [--config FILE] [--rule NAME] [--json] [--figures FORMAT] [--force] [--scan-topic T] [--odom-topic T] [--range-topics T,...] [--world-frame F] [--base-frame F]``
    a belief map from a robot log (CARMEN, g2o, ROS bag; poses from the log, the laser as the contour sensor)
    with a progress bar on standard error: the same artefacts as ``run``, and the ROS map pair
    ``map.pgm``/``map.yaml`` (``docs/SCENARIO.md``, logs section); ``--readings DIR`` gives the readings of the
    config's declared (YAML) sensors, ``DIR/scan-N.npz`` per scan used. The topic and frame flags choose what a
    ROS bag is read from (:class:`~evmap.sources.logs.rosbag.RosbagOptions`); another log refuses them.
``evmap compare --rules dempster,yager,... --worlds N --seed S --out DIR [--scheduler ADDRESS]``
    every rule on the same scans of N generated worlds: per-rule and per-world
    tables (CSV, Markdown) and plots (see :mod:`evmap.maps.app.compare`).
``evmap config check [FILE]``
    validate a config file and print every frame, source, table and stage parameter as it was understood.
``evmap config explain [FILE] --source NAME --value V``
    print what a source gives for one feature value (``-1e3`` too, which argparse alone would take for an
    option), and what that combines to with each row of the other sources of its stages, under the config's rule.
``evmap rules``, ``evmap sources``
    list the combination rules, or the kinds of evidence sources and of sensors, built in or from installed
    plugins, with where each comes from, and the plugins' ones that were refused and why.

``--config`` takes a file or a packaged config by name: ``default`` (what run, log and compare use when not
told) or ``paper`` (the paper's method; a file named so is ``./paper``); ``config check`` and ``config explain``
read ``paper`` when given no ``FILE``. Normal output goes to standard output. A mistake in the input (a bad file,
an unknown source, a value a source cannot judge) prints ``evmap: error: <message>`` on standard error and exits
with status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import re
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import partial
from typing import Any

from evmap.maps.app.compare_args import add_compare_parser
from evmap.maps.app.listings import list_rules, list_sources
from evmap.maps.app.termination import Terminated, terminate

__all__ = [
    "build_parser",
    "config_check",
    "config_explain",
    "log_command",
    "main",
    "run_command",
]

Handler = Callable[[argparse.Namespace], int]

RULE_HELP = "combination rule, overriding the config's (a name in evidential.RULES that combines any mass functions)"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``evmap`` command with ``argv`` (default: ``sys.argv[1:]``); return the exit status.

    As the process's command (``argv`` None), what a command imported stays out of the garbage collector's
    passes for the rest of the process (:func:`_imports`), and OpenBLAS (numpy's linear algebra) runs on one
    thread unless ``OPENBLAS_NUM_THREADS`` says otherwise: evmap's matrices are small, and starting the threads
    it would use costs more than they give (Dask's workers inherit the setting: one thread per worker process).
    Called from Python with ``argv``, the collector gets it back when the command returns and the environment
    is left alone. Ctrl-C or SIGTERM ends the command with one line and status 130 / 143, whenever it comes:
    during the command, or while the tool tidies up after it.
    """
    try:
        return _command(argv)
    except KeyboardInterrupt:
        print("evmap: interrupted", file=sys.stderr)
        return 130
    except Terminated:
        print("evmap: terminated", file=sys.stderr)
        return 143


def _command(argv: Sequence[str] | None) -> int:
    """:func:`main`, the signals aside."""
    if argv is None:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    frozen = gc.get_freeze_count()
    parser = build_parser()
    try:
        args = parser.parse_args(_negative_values(sys.argv[1:] if argv is None else argv))
        for name, value in vars(args).items():  # "" is no path, rule or topic but these two: tf, no range topic
            flag = name if name in ("scenario", "file") else "--" + name.replace("_", "-")
            if value == "" and name not in ("odom_topic", "range_topics"):
                parser.error(f"argument {flag}: empty")
    except SystemExit as exc:  # argparse printed the usage error (2) or the help (0)
        return exc.code if isinstance(exc.code, int) else 2
    handler: Handler = args.handler
    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        return handler(args)
    except (ValueError, OSError) as exc:  # InputError, every other complaint about input, and output problems
        if isinstance(exc, BrokenPipeError):
            return _closed_pipe()
        print(f"evmap: error: {exc}", file=sys.stderr)
        return 2
    finally:
        signal.signal(signal.SIGTERM, previous)
        if argv is not None and not frozen:
            gc.unfreeze()


def _negative_values(argv: Sequence[str]) -> list[str]:
    """``--value -1e3`` as ``--value=-1e3``: argparse reads a word starting with ``-`` as an option unless it is a
    plain negative number (``-0.5``), which ``-1e3`` and ``-inf`` are not."""
    out = list(argv)
    for i in reversed(range(1, len(out))):
        if out[i - 1] == "--value" and _NEGATIVE.fullmatch(out[i]):
            out[i - 1 : i + 1] = [f"--value={out[i]}"]
    return out


_NEGATIVE = re.compile(r"-(inf(inity)?|nan|(\d+\.?\d*|\.\d+)(e[-+]?\d+)?)", re.IGNORECASE)


@contextmanager
def _imports() -> Iterator[None]:
    """Import a command's modules with the cyclic garbage collector paused, then freeze what they made.

    The imports of ``evmap run`` make about 100,000 objects the collector tracks, and no garbage: its passes
    over them, during the imports and at exit, were about 9 % of a small run. ``gc.freeze`` moves them to the
    permanent generation, which no later pass scans; what the command makes afterwards is collected as
    usual. A collector that is already paused or frozen (by a program calling :func:`main`) is left alone.
    """
    if not gc.isenabled() or gc.get_freeze_count():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        gc.enable()


def _closed_pipe() -> int:
    """Standard output's reader went away (``evmap config check | head``): stop quietly, as SIGPIPE would."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())  # so that the interpreter's final flush does not fail again
    return 141


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``evmap``; each leaf subcommand sets ``handler``."""
    parser = argparse.ArgumentParser(
        prog="evmap", description="Evidential sonar and laser structured-light fusion into a belief map."
    )
    parser.add_argument("--version", action=_Version, help="show program's version number and exit")
    parser.set_defaults(handler=lambda args: _usage(parser))
    commands = parser.add_subparsers(title="commands", metavar="COMMAND")

    run = commands.add_parser("run", help="run the paper's experiment on a scenario and write its artefacts")
    run.add_argument("scenario", nargs="?", help="scenario file (default: the embedded corridor of the paper)")
    run.add_argument(
        "--config",
        default="default",
        help="config file, or a packaged config by name: default (the default: the evidence beyond the paper), paper (the paper's method)",
    )
    run.add_argument("--rule", help=RULE_HELP)
    run.add_argument("--out", default="out", help="directory for the artefacts (default: out)")
    run.add_argument("--force", action="store_true", help="replace --out if evmap wrote it")
    run.add_argument("--json", action="store_true", help="print report.json on standard output")
    run.add_argument(
        "--figures", choices=["png", "svg", "pdf", "none"], default="png", help="figure format (default: png)"
    )
    run.add_argument("--no-figures", dest="figures", action="store_const", const="none", help="same as --figures none")
    run.set_defaults(handler=run_command)

    log = commands.add_parser("log", help="map a robot log (CARMEN, g2o, ROS bag) and write the run's artefacts")
    log.add_argument("file", help="the log: *.log, *.clf (gzipped or not), *.g2o, *.bag or a ROS 2 bag directory")
    log.add_argument(
        "--config",
        default="default",
        help="config file, or a packaged config by name: default (the default: the evidence beyond the paper), paper (the paper's method)",
    )
    log.add_argument("--rule", help=RULE_HELP)
    log.add_argument("--out", default="out", help="directory for the artefacts (default: out)")
    log.add_argument("--every", type=int, default=1, help="use every N-th laser scan (default: 1, all)")
    log.add_argument("--limit", type=int, help="use at most N scans")
    log.add_argument("--unit", choices=["m", "cm", "mm"], default="m", help="unit of the log's ranges (default: m)")
    log.add_argument(
        "--readings",
        metavar="DIR",
        help="readings of the config's declared sensors: DIR/scan-N.npz per scan used (N its number in the log)",
    )
    log.add_argument("--force", action="store_true", help="replace --out if evmap wrote it")
    log.add_argument("--json", action="store_true", help="print report.json on standard output")
    bag = log.add_argument_group("ROS bags", "what a ROS bag is read from (default: found in the bag)")
    bag.add_argument("--scan-topic", metavar="TOPIC", help="the LaserScan topic (default: the bag's only one)")
    bag.add_argument(
        "--odom-topic", metavar="TOPIC", help="Odometry topic, '' for poses from tf (default: its only one)"
    )
    bag.add_argument(
        "--range-topics", metavar="TOPICS", help="Range topics, comma-separated; '' for none (default: all)"
    )
    bag.add_argument("--world-frame", metavar="FRAME", help="the world's tf frame, poses from tf (default: odom)")
    bag.add_argument("--base-frame", metavar="FRAME", help="the robot's tf frame, poses from tf (default: base_link)")
    log.add_argument(
        "--figures", choices=["png", "svg", "pdf", "none"], default="png", help="figure format (default: png)"
    )
    log.add_argument("--no-figures", dest="figures", action="store_const", const="none", help="same as --figures none")
    log.set_defaults(handler=log_command)

    add_compare_parser(commands, compare_command)

    config = commands.add_parser("config", help="check a config file, explain its evidence sources")
    config.set_defaults(handler=lambda args: _usage(config))
    actions = config.add_subparsers(title="actions", metavar="ACTION")

    check = actions.add_parser("check", help="validate a config and print it as understood")
    check.add_argument(
        "file", nargs="?", help="config file, or a packaged config by name: paper, default (default: paper)"
    )
    check.set_defaults(handler=config_check)

    explain = actions.add_parser(
        "explain", help="show what a source gives for a value and what it combines to in its stages"
    )
    explain.add_argument(
        "file", nargs="?", help="config file, or a packaged config by name: paper, default (default: paper)"
    )
    explain.add_argument("--source", required=True, help="name of a source of the config")
    explain.add_argument(
        "--value",
        required=True,
        help="the feature value: a number for a ramp, a category for a table",
    )
    explain.set_defaults(handler=config_explain)

    rules = commands.add_parser("rules", help="list the combination rules, built in or from plugins")
    rules.set_defaults(handler=list_rules)
    kinds = commands.add_parser("sources", help="list the kinds of evidence sources and sensors, built in or plugins")
    kinds.set_defaults(handler=list_sources)
    return parser


def compare_command(args: argparse.Namespace) -> int:
    """``evmap compare`` (:func:`evmap.maps.app.compare.compare_command`)."""
    with _imports():
        from evmap.maps.app.compare import compare_command

    return compare_command(args)


def run_command(args: argparse.Namespace) -> int:
    """``evmap run``: the paper's experiment on a scenario, its artefacts written all or nothing."""
    with _imports():
        from evmap.maps.app.artefacts import prepare_out, write_staged
        from evmap.maps.app.run import run_scenario
        from evmap.sources.config import check_simulated_run, load_config
        from evmap.sources.sim.scenario import default_scenario, load_scenario

    cfg = load_config(args.config)
    check_simulated_run(cfg)
    if args.rule:
        cfg = cfg.with_rule(args.rule)
    scenario = load_scenario(args.scenario) if args.scenario else default_scenario()
    with prepare_out(args.out, args.force) as staging:  # --out checked and claimed before the work
        print(f"evmap: running scenario {scenario.name!r} with rule {cfg.rule!r}", file=sys.stderr)
        summary = write_staged(
            run_scenario(scenario, cfg), staging, figures=args.figures != "none", figure_format=args.figures
        )
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


def log_command(args: argparse.Namespace) -> int:
    """``evmap log FILE``: a belief map from a robot log, its artefacts written all or nothing."""
    with _imports():
        from tqdm import tqdm

        from evmap.maps.app.artefacts import prepare_out, write_staged
        from evmap.maps.app.log_run import run_log
        from evmap.sources.config import load_config

    cfg = load_config(args.config)
    if args.rule:
        cfg = cfg.with_rule(args.rule)
    bar = partial(tqdm, desc="scans", unit="scan", file=sys.stderr, total=args.limit, leave=False)
    rosbag = _rosbag_options(args)
    with prepare_out(args.out, args.force) as staging:  # --out checked and claimed before the work
        print(f"evmap: mapping log {args.file} with rule {cfg.rule!r}", file=sys.stderr)
        run = run_log(
            args.file,
            cfg,
            every=args.every,
            limit=args.limit,
            progress=bar,
            readings=args.readings,
            rosbag=rosbag,
            unit=args.unit,
        )
        print(f"evmap: {run.log.scans} scans mapped; writing the artefacts", file=sys.stderr)
        summary = write_staged(run, staging, figures=args.figures != "none", figure_format=args.figures)
    fit = summary["line_fit"]
    coverage = "n/a" if fit["coverage_mean"] is None else f"{fit['coverage_mean']:.3f}"
    error = "n/a" if fit["rms_error_median"] is None else f"{100 * fit['rms_error_median']:.2f} cm"
    print(
        f"evmap: {summary['scans']} scans (sonar: {summary['sonar']}; laser noise "
        f"{100 * summary['laser_noise']:.1f} cm), {summary['lsl_segments']} segments, "
        f"{summary['lines_after_merge']} lines, {summary['corners']} corners; line fit coverage {coverage}, "
        f"error {error}; {summary['seconds']['total']:.1f} s "
        f"({1000 * summary['seconds']['per_scan_median']:.1f} ms per scan); written to {args.out}",
        file=sys.stderr,
    )
    if args.json:
        print(json.dumps(summary, indent=2))
    return 0


def _rosbag_options(args: argparse.Namespace) -> Any:
    """The ROS bag flags of ``evmap log`` (:meth:`~evmap.sources.logs.rosbag.RosbagOptions.from_flags`)."""
    from evmap.sources.logs.rosbag import RosbagOptions

    names = ("scan_topic", "odom_topic", "range_topics", "world_frame", "base_frame")
    return RosbagOptions.from_flags(**{name: getattr(args, name) for name in names})


def config_check(args: argparse.Namespace) -> int:
    """``evmap config check [FILE]``: validate and print the config as understood."""
    from evmap.maps.app.config_report import describe_config
    from evmap.sources.config import load_config

    print(describe_config(load_config(args.file)))
    return 0


def config_explain(args: argparse.Namespace) -> int:
    """``evmap config explain [FILE] --source NAME --value V``: one value through its source and stages."""
    from evmap.maps.app.config_report import explain_value
    from evmap.sources.config import load_config

    print(explain_value(load_config(args.file), args.source, args.value))
    return 0


def _usage(parser: argparse.ArgumentParser) -> int:
    """A command without its subcommand: print the usage to stderr, exit 2."""
    parser.print_usage(sys.stderr)
    print(f"{parser.prog}: error: a subcommand is required", file=sys.stderr)
    return 2


class _Version(argparse.Action):
    """``--version``: the installed evmap's version, looked up when asked (``importlib.metadata`` is slow to import)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser: argparse.ArgumentParser, *args: object) -> None:
        from importlib.metadata import PackageNotFoundError, version

        try:
            found = version("evmap")
        except PackageNotFoundError:  # run from a checkout that was never installed
            found = "unknown (not installed)"
        print(f"{parser.prog} {found}")
        parser.exit()


if __name__ == "__main__":
    sys.exit(main())
