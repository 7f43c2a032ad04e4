"""Wall time of the command line as a user meets it: ``evmap --help`` and a small ``evmap run --no-figures``.

Each command runs in a fresh process, several times; the medians of wall and CPU time
(user + system, of the process and its children) are printed with what a run spends
computing (``seconds.total`` of its report) and so what the rest (the interpreter,
imports, files) costs, beside the import of the libraries every run needs (the floor evmap cannot go below
without dropping one), and the load average, since the machine may be shared. Targets:
``--help`` well under a second, the small run under 0.5 s, an unreachable Dask
scheduler refused within a few seconds.

Python's bytecode is cached as an installed package has it: a warm-up run writes it
into a temporary cache (``PYTHONPYCACHEPREFIX``), whatever ``PYTHONDONTWRITEBYTECODE``
says. Where that variable is set and the checkout was never compiled (as in these
sessions), every ``evmap`` process compiles its ~100 modules from source again: about
0.2 s more per run on this machine.

    .venv/bin/python benchmarks/bench_cli.py [--runs 7]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EVMAP = str(Path(sys.executable).with_name("evmap"))
LIBRARIES = "numpy, shapely, pydantic, yaml"
"""What every run imports besides evmap: the floor of its wall time that evmap's own code does not set."""


def timed(command: list[str], env: dict[str, str], check: bool = True) -> tuple[float, float, str, int]:
    """Seconds of wall and CPU time of one command, what it printed, its exit status."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, check=check, env=env)
    seconds = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return seconds, cpu, done.stdout, done.returncode


def medians(samples: list[tuple[float, float]]) -> str:
    wall, cpu = (statistics.median(s) for s in zip(*samples, strict=True))
    return f"{wall:6.3f} s  (CPU {cpu:.3f} s)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="evmap-bench-cli-"))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
    run = [EVMAP, "run", "--out", str(tmp / "out"), "--force", "--figures", "none", "--json"]
    timed(run, env)  # the warm-up: writes the bytecode cache
    load = os.getloadavg()[0]
    bare = [timed([sys.executable, "-c", "pass"], env)[:2] for _ in range(args.runs)]
    floor = [timed([sys.executable, "-c", f"import {LIBRARIES}"], env)[:2] for _ in range(args.runs)]
    helps = [timed([EVMAP, "--help"], env)[:2] for _ in range(args.runs)]
    runs, computes = [], []
    for _ in range(args.runs):
        seconds, cpu, out, _ = timed(run, env)
        runs.append((seconds, cpu))
        computes.append(json.loads(out)["seconds"]["total"])
    unreachable = [EVMAP, "compare", "--worlds", "1", "--out", str(tmp / "cmp"), "--scheduler", "tcp://127.0.0.1:9"]
    refused, _, _, status = timed(unreachable, env, check=False)
    shutil.rmtree(tmp)
    print(
        f"medians of {args.runs} runs, each in a fresh process, bytecode cached; "
        f"load average {load:.2f} on {os.cpu_count()} CPUs"
    )
    print(f"  python -c pass                      {medians(bare)}")
    print(f"  python -c 'import {LIBRARIES}'\n                                      {medians(floor)}")
    print(f"  evmap --help                        {medians(helps)}")
    compute = statistics.median(computes)
    wall = statistics.median(s for s, _ in runs)
    print(
        f"  evmap run --figures none (corridor) {medians(runs)}   computing {compute:.3f} s, the rest {wall - compute:.3f} s"
    )
    own = wall - compute - statistics.median(s for s, _ in floor)
    print(f"    beyond the libraries' imports and the computing: {own:.3f} s (evmap's own modules, files, exit)")
    print(f"  evmap compare, unreachable scheduler: exit {status} after {refused:.1f} s (one run)")
    print(f"load average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
