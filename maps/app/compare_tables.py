"""A rule comparison's tables: the running summary over worlds, ``worlds.csv``, ``summary.csv`` and ``summary.md``.

The summary is built world by world (:class:`Tally`), in world order, so its
memory does not grow with the number of worlds and its numbers do not depend
on the parallelism: per rule and column, the mean over the worlds where the
value is defined (empty ratios excluded) and, for each of the :data:`METRICS`,
a 95% Student t interval of that mean (``<metric>_lo``, ``<metric>_hi``).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self, TextIO

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from evmap.maps.app.compare_metrics import BELIEF_BINS, COLUMNS, DEFINITIONS, METRICS, WorldResult

__all__ = [
    "CONFIDENCE",
    "INTERVAL_COLUMNS",
    "PLOT_WORLDS",
    "SUMMARY_COLUMNS",
    "WORLD_COLUMNS",
    "Comparison",
    "Tally",
    "WorldsWriter",
    "summary_markdown",
    "write_csv",
    "write_summary",
]

CONFIDENCE = 0.95
"""Coverage of the interval of each metric's mean over the worlds (Student t)."""

INTERVAL_COLUMNS = tuple(f"{m}_{end}" for m in METRICS for end in ("lo", "hi"))
"""The interval columns of ``summary.csv``, after the older ones."""

SUMMARY_COLUMNS = (*COLUMNS, "worlds", *INTERVAL_COLUMNS)
"""The columns of ``summary.csv``: those other tools read first, new ones appended."""

WORLD_COLUMNS = ("world", *COLUMNS)
"""The columns of ``worlds.csv``."""

PLOT_WORLDS = 2000
"""The per-world points of the first this many worlds are kept for the plots (memory stays bounded)."""

_VALUES = COLUMNS[1:]


@dataclass(frozen=True)
class Comparison:
    """The outcome of a comparison.

    Attributes
    ----------
    rules, worlds, seed : what was run.
    summary : one dict per rule (the ``summary.csv`` rows): means and intervals over the worlds.
    beliefs : rule -> (2, bins) segment counts per line-belief bin, real then noise.
    points : rule -> (n, 2) (real_loss, noise_recall) of the first :data:`PLOT_WORLDS` worlds where both are defined.
    rows : one dict per world and rule (the ``worlds.csv`` rows), in world order; empty when streamed to files.
    scenarios : world name -> its scenario YAML; empty when streamed to files.
    """

    rules: tuple[str, ...]
    worlds: int
    seed: int
    summary: tuple[dict[str, Any], ...]
    beliefs: dict[str, NDArray[np.int64]]
    points: dict[str, NDArray[np.float64]]
    rows: tuple[dict[str, Any], ...] = ()
    scenarios: dict[str, str] = field(default_factory=dict)


@dataclass
class Tally:
    """Running per-rule statistics of the :data:`COLUMNS` over the worlds added so far (Welford's algorithm).

    ``count``, ``mean``, ``m2``: rule -> one float per column after ``rule``; a
    ``None`` value is not counted.

    >>> t = Tally(("dempster",))
    >>> for x in (0.1, 0.2, None, 0.6):
    ...     t.add_row({"rule": "dempster", **dict.fromkeys(COLUMNS[1:], x)})
    >>> row = t.summary()[0]
    >>> round(row["noise_recall"], 6), round(row["noise_recall_lo"], 3), round(row["noise_recall_hi"], 3)
    (0.3, -0.357, 0.957)
    """

    rules: tuple[str, ...]
    worlds: int = 0
    count: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    mean: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    m2: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    rows_per_rule: dict[str, int] = field(default_factory=dict)
    beliefs: dict[str, NDArray[np.int64]] = field(default_factory=dict)
    points: dict[str, list[tuple[float, float]]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for rule in self.rules:
            self.count[rule], self.mean[rule], self.m2[rule] = (np.zeros(len(_VALUES)) for _ in range(3))
            self.rows_per_rule[rule] = 0
            self.beliefs[rule] = np.zeros((2, len(BELIEF_BINS) - 1), dtype=np.int64)
            self.points[rule] = []

    def add(self, result: WorldResult) -> None:
        """Fold in one world's rows, histograms and plot points (call in world order)."""
        for row in result.rows:
            self.add_row(row)
            rule = row["rule"]
            if self.worlds < PLOT_WORLDS and row["noise_recall"] is not None and row["real_loss"] is not None:
                self.points[rule].append((row["real_loss"], row["noise_recall"]))
        for rule, counts in result.beliefs.items():
            self.beliefs[rule] += counts
        self.worlds += 1

    def add_row(self, row: dict[str, Any]) -> None:
        """Fold in one row of ``worlds.csv``."""
        rule = row["rule"]
        values = np.array([np.nan if row[c] is None else row[c] for c in _VALUES], dtype=float)
        seen = ~np.isnan(values)
        count, mean, m2 = self.count[rule], self.mean[rule], self.m2[rule]
        count[seen] += 1
        delta = values[seen] - mean[seen]
        mean[seen] += delta / count[seen]
        m2[seen] += delta * (values[seen] - mean[seen])
        self.rows_per_rule[rule] += 1

    def summary(self) -> tuple[dict[str, Any], ...]:
        """One ``summary.csv`` row per rule."""
        out = []
        for rule in self.rules:
            count, mean, m2 = self.count[rule], self.mean[rule], self.m2[rule]
            row: dict[str, Any] = {"rule": rule}
            row.update({c: float(mean[k]) if count[k] else None for k, c in enumerate(_VALUES)})
            row["worlds"] = self.rows_per_rule[rule]
            for metric in METRICS:
                k = _VALUES.index(metric)
                lo, hi = _interval(count[k], mean[k], m2[k])
                row[f"{metric}_lo"], row[f"{metric}_hi"] = lo, hi
            out.append(row)
        return tuple(out)

    def comparison(
        self, seed: int, rows: Sequence[dict[str, Any]] = (), scenarios: dict[str, str] | None = None
    ) -> Comparison:
        """The :class:`Comparison` of the worlds added so far."""
        points = {r: np.array(p, dtype=float).reshape(-1, 2) for r, p in self.points.items()}
        beliefs = {r: b.copy() for r, b in self.beliefs.items()}
        return Comparison(
            self.rules, self.worlds, seed, self.summary(), beliefs, points, tuple(rows), dict(scenarios or {})
        )


def _interval(n: float, mean: float, m2: float) -> tuple[float | None, float | None]:
    """The Student t interval of a mean from n values with sum of squared deviations m2; None below 2 values."""
    if n < 2:
        return None, None
    half = float(stats.t.ppf(0.5 + CONFIDENCE / 2, n - 1)) * math.sqrt(m2 / (n - 1) / n)
    return float(mean - half), float(mean + half)


class WorldsWriter:
    """Streams ``worlds.csv`` and ``worlds/NAME.yaml`` into a directory as the worlds arrive.

    Use as a context manager; :meth:`add` writes one world (rows in world order when called in world order).
    """

    def __init__(self, directory: Path) -> None:
        self.directory = directory
        self.scenarios = directory / "worlds"
        self.scenarios.mkdir()
        self._file: TextIO = (directory / "worlds.csv").open("w", newline="")
        self._csv = csv.writer(self._file)
        self._csv.writerow(WORLD_COLUMNS)

    def add(self, result: WorldResult) -> None:
        """Append the world's rows and write its scenario."""
        for row in result.rows:
            self._csv.writerow([_cell(row[c]) for c in WORLD_COLUMNS])
        (self.scenarios / f"{result.world}.yaml").write_text(result.yaml)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self._file.close()


def write_csv(path: Path, columns: Sequence[str], rows: Sequence[dict[str, Any]]) -> None:
    """Write ``rows`` (dicts) with ``columns`` as CSV; ``None`` is an empty cell."""
    with path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row[c]) for c in columns])


def write_summary(comparison: Comparison, directory: Path) -> None:
    """Write ``summary.csv`` and ``summary.md`` into ``directory``."""
    write_csv(directory / "summary.csv", SUMMARY_COLUMNS, comparison.summary)
    (directory / "summary.md").write_text(summary_markdown(comparison))


def summary_markdown(comparison: Comparison) -> str:
    """The summary table in Markdown: what was run, what each metric is, means with their intervals."""
    shown = [*METRICS, "lines", "unidentified", "seconds_per_world"]
    out = [
        f"# Rule comparison: {comparison.worlds} worlds, seed {comparison.seed}",
        "",
        (
            "Every rule fused the same scans. Each cell is the mean over the worlds (a ratio with an empty "
            f"denominator is left out), with, for the metrics, its {CONFIDENCE:.0%} Student t interval over the "
            "worlds in brackets (`<metric>_lo`, `<metric>_hi` in summary.csv)."
        ),
        "",
        *[f"- `{m}`: {DEFINITIONS[m]}." for m in METRICS],
        (
            "- `lines`: map lines with belief at least 0.5; `unidentified`: unidentified objects; "
            "`seconds_per_world`: the rule's fusion time on a world."
        ),
        "",
        "| " + " | ".join(["rule", *shown]) + " |",
        "| " + " | ".join(["---", *["---:"] * len(shown)]) + " |",
    ]
    for row in comparison.summary:
        cells = []
        for c in shown:
            digits = 4 if c.startswith("seconds") else 3
            cell = "" if row[c] is None else f"{row[c]:.{digits}f}"
            if c in METRICS and row.get(f"{c}_lo") is not None:
                cell += f" [{row[f'{c}_lo']:.3f}, {row[f'{c}_hi']:.3f}]"
            cells.append(cell)
        out.append("| " + " | ".join([row["rule"], *cells]) + " |")
    return "\n".join(out) + "\n"


def _cell(value: Any) -> Any:
    return "" if value is None else value
