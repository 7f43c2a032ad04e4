"""Loading time of scenarios at the file size limit (libyaml where installed).

Times :func:`evmap.sources.sim.scenario.load_scenario` on a file of long walls of about
``MAX_FILE_BYTES`` bytes (refused: more wall segments than the limit, after the whole file
is read), on a valid scenario with every count at its limit, padded with comments to the
file size limit, then an alias bomb and a deep file.

    python benchmarks/bench_loading.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from evmap.sources.loading import MAX_FILE_BYTES, InputError, parse_document
from evmap.sources.sim.scenario import (
    MAX_CYLINDERS,
    MAX_POLYGON_VERTICES,
    MAX_POSES,
    MAX_SUNLIGHT_REGIONS,
    MAX_WALL_SEGMENTS,
    load_scenario,
)


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


def full_scenario(target: int) -> str:
    """A valid scenario with every count at its limit, padded with comment lines to about ``target`` bytes."""
    angles = np.linspace(0, 2 * np.pi, MAX_WALL_SEGMENTS, endpoint=False)
    ring = ", ".join(f"[{50 * np.cos(a):.4f}, {50 * np.sin(a):.4f}]" for a in angles)
    star = np.linspace(0, 2 * np.pi, MAX_POLYGON_VERTICES, endpoint=False)
    radius = np.where(np.arange(MAX_POLYGON_VERTICES) % 2, 0.25, 0.5)
    lines = ["version: 1", "name: full", "world:", "  walls:", f"    - {{id: ring, points: [{ring}, [50.0, 0.0]]}}"]
    lines.append("  cylinders:")
    lines += [
        f"    - {{id: c{k}, center: [{k % 40 - 20}.5, {k // 40 - 30}.5], radius: 0.1}}" for k in range(MAX_CYLINDERS)
    ]
    lines.append("  sunlight:")
    for k in range(MAX_SUNLIGHT_REGIONS):
        x, y = 30 + k % 10, k // 10 - 5
        polygon = ", ".join(f"[{x + r * np.cos(a):.4f}, {y + r * np.sin(a):.4f}]" for a, r in zip(star, radius))
        lines.append(f"    - {{polygon: [{polygon}], lines: {int(k == 0)}, length: [0.02, 0.2]}}")
    lines += ["robot:", "  poses:", *(f"    - [{-19 + k}, -31, 0]" for k in range(MAX_POSES))]
    text = "\n".join(lines) + "\n"
    comment = "# " + "x" * 97 + "\n"
    return text + comment * ((target - len(text)) // len(comment))


def main() -> None:
    """Print the timings."""
    print(f"yaml loader: {'CSafeLoader (libyaml)' if hasattr(yaml, 'CSafeLoader') else 'SafeLoader'}")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.yaml"
        path.write_text(big_scenario(MAX_FILE_BYTES))
        start = time.perf_counter()
        try:
            load_scenario(path)
        except InputError as exc:
            seconds = time.perf_counter() - start
            print(f"walls file of {path.stat().st_size:,} bytes: refused in {seconds:.2f} s: {str(exc)[:120]}")
        path.write_text(full_scenario(MAX_FILE_BYTES))
        start = time.perf_counter()
        scenario = load_scenario(path)
        seconds = time.perf_counter() - start
        print(
            f"valid scenario of {path.stat().st_size:,} bytes, every count at its limit "
            f"({len(scenario.world.sunlight)} sunlight regions, {len(scenario.world.cylinders)} cylinders): "
            f"loaded in {seconds:.2f} s"
        )
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
