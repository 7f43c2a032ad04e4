"""Wall time of the command line as a user meets it: ``evmap --help`` and a small ``evmap run --no-figures``.

Each command runs in a fresh process, several times; the medians are printed with
what a run spends computing (``seconds.total`` of its report) and so what the
rest (the interpreter, imports, files) costs. Targets: ``--help`` well under a
second, the small run under 0.5 s, an unreachable Dask scheduler refused within a few seconds.

    .venv/bin/python benchmarks/bench_cli.py [--runs 7]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EVMAP = str(Path(sys.executable).with_name("evmap"))


def wall(command: list[str]) -> tuple[float, str]:
    """Seconds of wall time of one command, and what it printed."""
    t = time.perf_counter()
    out = subprocess.run(command, capture_output=True, text=True, check=True).stdout
    return time.perf_counter() - t, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    runs = parser.parse_args().runs
    bare = [wall([sys.executable, "-c", "pass"])[0] for _ in range(runs)]
    helps = [wall([EVMAP, "--help"])[0] for _ in range(runs)]
    tmp = Path(tempfile.mkdtemp(prefix="evmap-bench-cli-"))
    walls, computes = [], []
    for _ in range(runs):
        seconds, out = wall([EVMAP, "run", "--out", str(tmp / "out"), "--force", "--figures", "none", "--json"])
        walls.append(seconds)
        computes.append(json.loads(out)["seconds"]["total"])
    t = time.perf_counter()
    unreachable = subprocess.run(
        [EVMAP, "compare", "--worlds", "1", "--out", str(tmp / "cmp"), "--scheduler", "tcp://127.0.0.1:9"],
        capture_output=True,
        text=True,
        check=False,
    )
    refused = time.perf_counter() - t
    shutil.rmtree(tmp)
    print(f"medians of {runs} runs, each in a fresh process")
    print(f"  python -c pass                      {statistics.median(bare):6.3f} s")
    print(f"  evmap --help                        {statistics.median(helps):6.3f} s")
    run, compute = statistics.median(walls), statistics.median(computes)
    print(
        f"  evmap run --figures none (corridor) {run:6.3f} s   computing {compute:.3f} s, the rest {run - compute:.3f} s"
    )
    print(f"  evmap compare, unreachable scheduler: exit {unreachable.returncode} after {refused:.1f} s (one run)")


if __name__ == "__main__":
    main()
