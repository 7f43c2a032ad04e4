"""Memory of ``evmap compare`` as the worlds grow: bounded whatever ``--worlds`` (target), on the local Dask cluster.

For each number of worlds, ``evmap compare --quiet`` runs in a fresh process and
this script samples, every quarter second, the resident memory of that process
(the scheduler, the tallies and the files) and of each of its worker processes
(Linux: ``/proc``). Printed per size: wall seconds; the peak of the command's
process and of its largest worker (``VmHWM``); and each worker's *floor*, the
least it held in the second and in the last tenth of the run (a worker falls back
to it between worlds, after its periodic garbage collection: a leak raises it; the
first tenth holds the worker's start, before its imports).
Then how each peak grows with the worlds (the exponent of a power law through the
smallest and largest size: 0 is flat). A worker's peak is its floor plus the
largest world it happened to compute, so it may rise a little with the worlds as
rarer, bigger worlds come up; the floor must not.

    .venv/bin/python benchmarks/bench_memory.py [--worlds 100 1000] [--rules dempster] [--seed 1]
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

EVMAP = str(Path(sys.executable).with_name("evmap"))
SAMPLE_EVERY = 0.25
"""Seconds between two samples of the processes' memory."""


def status(pid: int) -> dict[str, int]:
    """``VmRSS`` and ``VmHWM`` (MB) of a process; empty once it is gone."""
    try:
        with open(f"/proc/{pid}/status") as f:
            lines = f.readlines()
    except OSError:
        return {}
    return {k: int(v.split()[0]) // 1024 for k, v in (ln.split(":", 1) for ln in lines) if k in ("VmRSS", "VmHWM")}


def children(pid: int) -> list[int]:
    """The processes whose parent is ``pid``."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    stat = f.read()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry))
    return found


def run(worlds: int, rules: str, seed: int) -> tuple[float, int, int, list[tuple[int, int]]]:
    """One ``evmap compare``: wall seconds, peak MB of its process and of its largest worker, and each worker's
    floor (MB) in the second and the last tenth of the run."""
    with tempfile.TemporaryDirectory() as tmp:
        command = [EVMAP, "compare", "--configs", "default", "--rules", rules, "--worlds", str(worlds)]
        command += ["--seed", str(seed), "--out", str(Path(tmp) / "out"), "--quiet"]
        start = time.perf_counter()
        proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        samples: dict[int, list[tuple[float, int]]] = {}
        peaks: dict[int, int] = {}
        stop = threading.Event()

        def sample() -> None:
            while not stop.is_set():
                now = time.perf_counter() - start
                for pid in [proc.pid, *children(proc.pid)]:
                    s = status(pid)
                    if s:
                        samples.setdefault(pid, []).append((now, s["VmRSS"]))
                        peaks[pid] = max(peaks.get(pid, 0), s["VmHWM"])
                stop.wait(SAMPLE_EVERY)

        sampler = threading.Thread(target=sample)
        sampler.start()
        _, err = proc.communicate()
        wall = time.perf_counter() - start
        stop.set()
        sampler.join()
        if proc.returncode:
            raise SystemExit(f"evmap compare failed ({proc.returncode}): {' '.join(command)}\n{err}")
    workers = [pid for pid in samples if pid != proc.pid and peaks[pid] > 0]  # not a child gone before it ran
    floors = []
    for pid in workers:
        t0, t1 = samples[pid][0][0], samples[pid][-1][0]
        tenth = (t1 - t0) / 10
        second = [rss for when, rss in samples[pid] if t0 + tenth <= when <= t0 + 2 * tenth]
        last = [rss for when, rss in samples[pid] if when >= t1 - tenth]
        floors.append((min(second or last), min(last)))  # a run too short to sample its second tenth: the last
    return wall, peaks[proc.pid], max((peaks[pid] for pid in workers), default=0), floors


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, nargs="+", default=[100, 1000])
    parser.add_argument("--rules", default="dempster", help="as evmap compare --rules")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    print(f"evmap compare --configs default --rules {args.rules} --seed {args.seed}, local cluster")
    print(f"{'worlds':>7} {'wall s':>7} {'command MB':>10} {'worker MB':>9}  worker floors, second -> last tenth (MB)")
    done = []
    for worlds in args.worlds:
        wall, own, worker, floors = run(worlds, args.rules, args.seed)
        done.append((worlds, own, worker))
        shown = ", ".join(f"{a} -> {b}" for a, b in floors)
        print(f"{worlds:>7} {wall:>7.0f} {own:>10} {worker:>9}  {shown}", flush=True)
    if len(done) > 1:
        (n0, own0, w0), (n1, own1, w1) = done[0], done[-1]
        grow = math.log(n1 / n0)
        print(f"peak growth with the worlds: command ^{math.log(own1 / own0) / grow:.2f}, largest worker "
              f"^{math.log(w1 / w0) / grow:.2f} (0: flat)")  # fmt: skip


if __name__ == "__main__":
    main()
