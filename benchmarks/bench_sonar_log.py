"""A long robot log with sonar: does an update cost more as the map holds more objects the sonar heard?

No public log here has sonar, so this one is made: an office floor (a corridor between two rows of rooms
with doors, pillars and boxes; ``--tiles`` floors of 24 x 14 m side by side, the corridor running through
them), a robot driving down the corridor, each scan a CARMEN ``FLASER`` line (181 beams over 180 deg, 1 cm
of range noise, ray-cast on the walls) and a ``SONAR`` ring of 16 sensors (15 deg beams, 5 m, the nearest of
three rays over each beam, 2 cm of noise). The log is folded into one map by
:func:`evmap.maps.app.log_run.run_log` (the computation of ``evmap log``, default config). Printed: the
median time between scans (extraction and update) in each sixth of the log, the ratio of the last sixth's
to the first's, the unidentified objects the map holds at the end and the total. Timings are this
machine's; compare runs side by side.

    .venv/bin/python benchmarks/bench_sonar_log.py [--tiles 4] [--scans 600]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TypeVar

import numpy as np

from evmap.maps.app.log_run import run_log
from evmap.sources.config import load_config

T = TypeVar("T")
RNG = np.random.default_rng(7)


def floor(tiles: int) -> np.ndarray:
    """The walls (W, 2, 2) of ``tiles`` office floors of 24 x 14 m side by side; the corridor y in [5, 9]."""
    walls = [((0, 0), (0, 14))]
    for k in range(tiles):
        x0 = 24.0 * k
        walls += [((x0, 0), (x0 + 24, 0)), ((x0, 14), (x0 + 24, 14))]
        for y in (5.0, 9.0):  # the corridor's walls, a door in each room
            xs = [0, 4, 5, 10, 11, 16, 17, 24]
            walls += [((x0 + a, y), (x0 + b, y)) for a, b in zip(xs[0::2], xs[1::2], strict=True)]
        walls += [((x0 + x, 0), (x0 + x, 5)) for x in (8.0, 16.0)] + [((x0 + x, 9), (x0 + x, 14)) for x in (8, 16)]
        for bx, by, w, h in ((2.0, 1.5, 0.6, 0.6), (12.0, 11.0, 1.5, 0.6), (20.0, 2.0, 0.4, 0.4)):  # boxes, pillars
            c = [(x0 + bx, by), (x0 + bx + w, by), (x0 + bx + w, by + h), (x0 + bx, by + h)]
            walls += list(zip(c, c[1:] + c[:1], strict=True))
        walls.append(((x0 + 18.5, 10.5), (x0 + 21.0, 12.5)))  # a cabinet at an angle
    walls.append(((24.0 * tiles, 0), (24.0 * tiles, 14)))
    return np.array(walls, dtype=float)


def cast(walls: np.ndarray, x: float, y: float, bearings: np.ndarray, noise: float) -> np.ndarray:
    """The range along each bearing from (x, y) to the nearest wall, with Gaussian noise; inf where none."""
    dx, dy = np.cos(bearings)[:, None], np.sin(bearings)[:, None]
    p, e = walls[:, 0], walls[:, 1] - walls[:, 0]
    den = dx * e[:, 1] - dy * e[:, 0]
    wx, wy = p[:, 0] - x, p[:, 1] - y
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (wx * e[:, 1] - wy * e[:, 0]) / den
        u = (wx * dy - wy * dx) / den
    r = np.where((np.abs(den) > 1e-12) & (r > 1e-6) & (u >= 0) & (u <= 1), r, np.inf).min(axis=1)
    return r + RNG.normal(0.0, noise, r.shape)


def write_log(path: Path, tiles: int, scans: int) -> None:
    """The log (module doc): the robot at y = 7 heading +x, from x = 1.5 to the far end of the corridor."""
    walls = floor(tiles)
    laser = np.radians(np.linspace(-90.0, 90.0, 181))
    axes = np.linspace(-np.pi, np.pi, 16, endpoint=False) + np.pi / 16
    cone = np.radians([-7.5, 0.0, 7.5])
    lines = []
    for i, x in enumerate(np.linspace(1.5, 24.0 * tiles - 1.5, scans)):
        stamp = 1000.0 + 0.1 * i
        sx, sy = x + 0.25 * np.cos(axes), 7.0 + 0.25 * np.sin(axes)
        sonar = [min(cast(walls, a, b, c + cone, 0.02).min(), 5.0) for a, b, c in zip(sx, sy, axes, strict=True)]
        offsets = " ".join(f"{0.25 * np.cos(a):.4f} {0.25 * np.sin(a):.4f} {a:.4f}" for a in axes)
        ranges = " ".join(f"{v:.3f}" for v in sonar)
        lines.append(f"SONAR {np.radians(15):.5f} 16 {ranges} {offsets} {stamp - 0.01:.6f} bench {stamp - 0.01:.6f}")
        r = cast(walls, x, 7.0, laser, 0.01)
        r = np.where(np.isfinite(r) & (r < 80.0), r, 81.91)
        pose = f"{x:.4f} 7.0000 0.00000"
        scan = " ".join(f"{v:.3f}" for v in r)
        lines.append(f"FLASER 181 {scan} {pose} {pose} {stamp:.6f} bench {stamp:.6f}")
    path.write_text("\n".join(lines) + "\n")


def _timed(records: Iterable[T], times: list[float]) -> Iterator[T]:
    for record in records:
        times.append(time.perf_counter())
        yield record
    times.append(time.perf_counter())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tiles", type=int, default=4, help="office floors along the corridor (24 m each)")
    parser.add_argument("--scans", type=int, default=600)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "sonar.log"
        write_log(path, args.tiles, args.scans)
        times: list[float] = []
        start = time.perf_counter()
        run = run_log(path, load_config("default"), progress=lambda records: _timed(records, times))
        total = time.perf_counter() - start
    gaps = np.diff(times)[1:]  # between scans
    sixth = len(gaps) // 6
    medians = [1000 * float(np.median(gaps[k * sixth : (k + 1) * sixth])) for k in range(6)]
    print(f"{args.tiles * 24} m corridor, {run.log.scans} scans, sonar: {run.log.sonar}")
    print("median ms a scan, by sixth of the log:", " ".join(f"{m:.1f}" for m in medians))
    print(
        f"last sixth / first: {medians[-1] / medians[0]:.2f}; unidentified objects at the end: "
        f"{len(run.map.unidentified(min_belief=0))}; total {total:.1f} s"
    )


if __name__ == "__main__":
    main()
