"""Loading time of a valid scenario at the file size limit (libyaml where installed).

Writes a scenario of long walls (about ``MAX_FILE_BYTES`` bytes) and times
:func:`evmap.sources.sim.scenario.load_scenario` on it, then an alias bomb and a deep file.

    python benchmarks/bench_loading.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from evmap.sources.loading import MAX_FILE_BYTES, InputError, parse_document
from evmap.sources.sim.scenario import load_scenario


def big_scenario(target: int) -> str:
    """A valid scenario text of walls of 200 points each, just under ``target`` bytes."""
    rng = np.random.default_rng(0)
    lines = ["version: 1", "name: big", "world:", "  walls:"]
    size, tail = sum(len(x) + 1 for x in lines), "robot:\n  poses: [[0.5, 0.2, 0]]\n"
    w = 0
    while True:
        x = 100 + np.cumsum(rng.uniform(0.1, 1, 200))
        points = ", ".join(f"[{a:.3f}, {w + 0.5 + (k % 2) * 0.2:.3f}]" for k, a in enumerate(x))
        line = f"    - {{id: w{w}, points: [{points}]}}"
        if size + len(line) + 1 + len(tail) > target:
            break
        lines.append(line)
        size += len(line) + 1
        w += 1
    return "\n".join(lines) + "\n" + tail


def main() -> None:
    """Print the timings."""
    print(f"yaml loader: {'CSafeLoader (libyaml)' if hasattr(yaml, 'CSafeLoader') else 'SafeLoader'}")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.yaml"
        path.write_text(big_scenario(MAX_FILE_BYTES))
        start = time.perf_counter()
        scenario = load_scenario(path)
        seconds = time.perf_counter() - start
        segments = sum(len(w.points) - 1 for w in scenario.world.walls)
        print(f"scenario of {path.stat().st_size:,} bytes ({segments:,} wall segments): loaded in {seconds:.2f} s")
    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{k}: &{k} [{', '.join([f'*{p}'] * 9)}]\n" for p, k in zip("abcdefgh", "bcdefghi")
    )
    for label, text in (("alias bomb", bomb), ("100,000-deep nesting", "[" * 100_000 + "]" * 100_000)):
        start = time.perf_counter()
        try:
            parse_document(text, label)
        except InputError as exc:
            print(f"{label}: refused in {time.perf_counter() - start:.3f} s: {exc}")


if __name__ == "__main__":
    main()
