"""A comparison's tables: the running summary over worlds, ``worlds.csv``, ``summary.csv`` and ``summary.md``.

The summary is built world by world (:class:`Tally`), in world order, so its
memory does not grow with the number of worlds and its numbers do not depend
on the parallelism: per config, rule and column, the mean over the worlds where
the value is defined (empty ratios excluded) and, for each of the :data:`METRICS`
and :data:`HAZARDS` (and :data:`FREE_HAZARDS`, :data:`HEARD`), a 95% Student t interval of that mean (``<metric>_lo``,
``<metric>_hi``), cut to the values the metric can take (a share within [0, 1], a distance at least 0:
the mean lies there, so the cut interval covers it as often); and the :data:`POOLED` ratios, over the
segments of all worlds. Against the first config and rule (the baseline), each other's paired
differences: per metric, the mean over the worlds where both are defined of its value less the
baseline's on the same world, with its Student t interval (``summary.md``): the worlds' own spread,
which the separate intervals carry, cancels out.
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

from evmap.maps.app.compare_metrics import (
    BELIEF_BINS,
    COLUMNS,
    DEFINITIONS,
    DISTANCES,
    EXTRA_COLUMNS,
    FIGURES,
    FREE_HAZARDS,
    HAZARDS,
    HEARD,
    METRICS,
    WorldResult,
)

__all__ = [
    "CONFIDENCE",
    "INTERVAL_COLUMNS",
    "PLOT_WORLDS",
    "POOLED",
    "SUMMARY_COLUMNS",
    "WORLD_COLUMNS",
    "Comparison",
    "Tally",
    "WorldsWriter",
    "markdown_table",
    "summary_markdown",
    "write_csv",
    "write_summary",
]

CONFIDENCE = 0.95
"""Coverage of the interval of each metric's mean over the worlds (Student t)."""

INTERVAL_COLUMNS = tuple(f"{m}_{end}" for m in FIGURES for end in ("lo", "hi"))
"""The interval columns of ``summary.csv``."""

_OLD_INTERVALS = 2 * (len(METRICS) + len(HAZARDS))
_NEW_INTERVALS = _OLD_INTERVALS + 2 * len(FREE_HAZARDS)  # 1.2's; 1.3's after

POOLED = {
    "noise_recall_pooled": ("noise_eliminated", "noise_segments", False),
    "real_loss_pooled": ("real_eliminated", "real_segments", False),
    "noise_recall_seen_twice": ("noise_eliminated", "noise_segments", True),
}
"""Ratios over the segments of all worlds: name -> (numerator, denominator, only the worlds where every
sunlight region is in sight of two poses or more)."""

SUMMARY_COLUMNS = (
    *COLUMNS,
    "worlds",
    *INTERVAL_COLUMNS[: 2 * len(METRICS)],
    *EXTRA_COLUMNS,
    *INTERVAL_COLUMNS[2 * len(METRICS) : _OLD_INTERVALS],
    *POOLED,
    *FREE_HAZARDS,
    *INTERVAL_COLUMNS[_OLD_INTERVALS:_NEW_INTERVALS],
    *HEARD,
    *INTERVAL_COLUMNS[_NEW_INTERVALS:],
)
"""The columns of ``summary.csv``: those other tools read first, as older versions wrote them; new ones appended."""

WORLD_COLUMNS = ("world", *COLUMNS, *EXTRA_COLUMNS, *FREE_HAZARDS, *HEARD)
"""The columns of ``worlds.csv``: older ones first."""

PLOT_WORLDS = 2000
"""The per-world points of the first this many worlds are kept for the plots (memory stays bounded)."""

_VALUES = (*COLUMNS[1:], *EXTRA_COLUMNS[1:], *FREE_HAZARDS, *HEARD)

Variant = tuple[str, str]
"""(config, rule): one map per world."""


@dataclass(frozen=True)
class Comparison:
    """The outcome of a comparison.

    Attributes
    ----------
    configs, rules, worlds, seed : what was run.
    summary : one dict per config and rule (the ``summary.csv`` rows): means and intervals over the worlds.
    beliefs : (config, rule) -> (2, bins) segment counts per line-belief bin, real then noise.
    points : (config, rule) -> (n, 2) (real_loss, noise_recall) of the first :data:`PLOT_WORLDS` worlds
        where both are defined.
    rows : one dict per world, config and rule (the ``worlds.csv`` rows), in world order; empty when streamed.
    scenarios : world name -> its scenario YAML; empty when streamed to files.
    differences : one dict per config and rule but the first: each metric's mean paired difference from the
        first (``<metric>``) and its interval (``<metric>_lo``, ``<metric>_hi``), None below two worlds.
    """

    configs: tuple[str, ...]
    rules: tuple[str, ...]
    worlds: int
    seed: int
    summary: tuple[dict[str, Any], ...]
    beliefs: dict[Variant, NDArray[np.int64]]
    points: dict[Variant, NDArray[np.float64]]
    rows: tuple[dict[str, Any], ...] = ()
    scenarios: dict[str, str] = field(default_factory=dict)
    differences: tuple[dict[str, Any], ...] = ()

    @property
    def variants(self) -> tuple[Variant, ...]:
        """Every (config, rule), configs first, in the order of the summary rows."""
        return tuple((c, r) for c in self.configs for r in self.rules)

    def label(self, variant: Variant) -> str:
        """How plots and tables name a variant: the rule alone when one config ran, else ``config: rule``."""
        return variant[1] if len(self.configs) == 1 else f"{variant[0]}: {variant[1]}"


@dataclass
class Tally:
    """Running statistics per config and rule of the columns over the worlds added so far (Welford's algorithm).

    ``count``, ``mean``, ``m2``: (config, rule) -> one float per numeric column; a
    ``None`` value is not counted. ``pooled``: (config, rule) -> sums of the counts
    that :data:`POOLED` divides.

    >>> t = Tally(("default",), ("dempster",))
    >>> for x in (0.1, 0.2, None, 0.6):
    ...     t.add_row({"config": "default", "rule": "dempster", **dict.fromkeys(_VALUES, x)})
    >>> row = t.summary()[0]
    >>> round(row["noise_recall"], 6), round(row["noise_recall_lo"], 3), round(row["noise_recall_hi"], 3)
    (0.3, 0.0, 0.957)
    """

    configs: tuple[str, ...]
    rules: tuple[str, ...]
    worlds: int = 0
    count: dict[Variant, NDArray[np.float64]] = field(default_factory=dict)
    mean: dict[Variant, NDArray[np.float64]] = field(default_factory=dict)
    m2: dict[Variant, NDArray[np.float64]] = field(default_factory=dict)
    pooled: dict[Variant, dict[str, float]] = field(default_factory=dict)
    rows_per_variant: dict[Variant, int] = field(default_factory=dict)
    beliefs: dict[Variant, NDArray[np.int64]] = field(default_factory=dict)
    points: dict[Variant, list[tuple[float, float]]] = field(default_factory=dict)
    paired: dict[Variant, NDArray[np.float64]] = field(default_factory=dict)  # (3, metrics): count, mean, m2

    def __post_init__(self) -> None:
        for v in self.variants:
            self.count[v], self.mean[v], self.m2[v] = (np.zeros(len(_VALUES)) for _ in range(3))
            self.paired[v] = np.zeros((3, len(FIGURES)))
            self.pooled[v] = dict.fromkeys(_POOLED_SUMS, 0.0)
            self.rows_per_variant[v] = 0
            self.beliefs[v] = np.zeros((2, len(BELIEF_BINS) - 1), dtype=np.int64)
            self.points[v] = []

    @property
    def variants(self) -> tuple[Variant, ...]:
        """Every (config, rule), configs first."""
        return tuple((c, r) for c in self.configs for r in self.rules)

    def add(self, result: WorldResult) -> None:
        """Fold in one world's rows, histograms and plot points (call in world order)."""
        for row in result.rows:
            self.add_row(row)
            v = row["config"], row["rule"]
            if self.worlds < PLOT_WORLDS and row["noise_recall"] is not None and row["real_loss"] is not None:
                self.points[v].append((row["real_loss"], row["noise_recall"]))
        for v, counts in result.beliefs.items():
            self.beliefs[v] += counts
        rows = {(r["config"], r["rule"]): r for r in result.rows}
        base = rows.get(self.variants[0])
        for v in self.variants[1:] if base is not None else ():
            if v in rows:
                values = [np.nan if rows[v][m] is None or base[m] is None else rows[v][m] - base[m] for m in FIGURES]
                _welford(self.paired[v], np.array(values, dtype=float))
        self.worlds += 1

    def add_row(self, row: dict[str, Any]) -> None:
        """Fold in one row of ``worlds.csv``."""
        v = row["config"], row["rule"]
        values = np.array([np.nan if row[c] is None else row[c] for c in _VALUES], dtype=float)
        _welford((self.count[v], self.mean[v], self.m2[v]), values)
        for key, (column, twice) in _POOLED_SUMS.items():
            if row[column] is not None and (not twice or row["sunlight_seen_twice"]):
                self.pooled[v][key] += row[column]
        self.rows_per_variant[v] += 1

    def summary(self) -> tuple[dict[str, Any], ...]:
        """One ``summary.csv`` row per config and rule."""
        out = []
        for v in self.variants:
            count, mean, m2, sums = self.count[v], self.mean[v], self.m2[v], self.pooled[v]
            row: dict[str, Any] = {"config": v[0], "rule": v[1]}
            row.update({c: float(mean[k]) if count[k] else None for k, c in enumerate(_VALUES)})
            row["worlds"] = self.rows_per_variant[v]
            for metric in FIGURES:
                k = _VALUES.index(metric)
                lo, hi = _interval(count[k], mean[k], m2[k], (0.0, _top(metric)))
                row[f"{metric}_lo"], row[f"{metric}_hi"] = lo, hi
            for name, (numerator, denominator, twice) in POOLED.items():
                top, bottom = sums[_sum_key(numerator, twice)], sums[_sum_key(denominator, twice)]
                row[name] = top / bottom if bottom else None
            out.append(row)
        return tuple(out)

    def differences(self) -> tuple[dict[str, Any], ...]:
        """One row per config and rule but the first: each metric's mean paired difference from the first, with
        its interval (within what a difference of the metric can be)."""
        out = []
        for v in self.variants[1:]:
            count, mean, m2 = self.paired[v]
            row: dict[str, Any] = {"config": v[0], "rule": v[1]}
            for k, metric in enumerate(FIGURES):
                row[metric] = float(mean[k]) if count[k] else None
                row[f"{metric}_lo"], row[f"{metric}_hi"] = _interval(
                    count[k], mean[k], m2[k], (-_top(metric), _top(metric))
                )
            out.append(row)
        return tuple(out)

    def comparison(
        self, seed: int, rows: Sequence[dict[str, Any]] = (), scenarios: dict[str, str] | None = None
    ) -> Comparison:
        """The :class:`Comparison` of the worlds added so far."""
        points = {v: np.array(p, dtype=float).reshape(-1, 2) for v, p in self.points.items()}
        beliefs = {v: b.copy() for v, b in self.beliefs.items()}
        return Comparison(
            self.configs,
            self.rules,
            self.worlds,
            seed,
            self.summary(),
            beliefs,
            points,
            tuple(rows),
            dict(scenarios or {}),
            self.differences(),
        )


def _sum_key(column: str, twice: bool) -> str:
    return f"{column}:seen_twice" if twice else column


_POOLED_SUMS = {
    _sum_key(column, twice): (column, twice)
    for numerator, denominator, twice in POOLED.values()
    for column in (numerator, denominator)
}
"""The sums :class:`Tally` keeps for :data:`POOLED`: key -> (column, only worlds seen twice)."""


def _welford(stats: Sequence[NDArray[np.float64]], values: NDArray[np.float64]) -> None:
    """Fold ``values`` (NaN: not counted) into running counts, means and sums of squared deviations."""
    count, mean, m2 = stats
    seen = ~np.isnan(values)
    count[seen] += 1
    delta = values[seen] - mean[seen]
    mean[seen] += delta / count[seen]
    m2[seen] += delta * (values[seen] - mean[seen])


def _top(metric: str) -> float:
    """The largest value the metric can take: 1 for a share, none for a distance."""
    return math.inf if metric in DISTANCES else 1.0


def _interval(n: float, mean: float, m2: float, bounds: tuple[float, float]) -> tuple[float | None, float | None]:
    """The Student t interval of a mean from n values with sum of squared deviations m2, cut to ``bounds``,
    the values the mean can take; None below 2 values."""
    if n < 2:
        return None, None
    from scipy import stats  # here, not at the top: scipy.stats takes a second to import, and only the tables need it

    half = float(stats.t.ppf(0.5 + CONFIDENCE / 2, n - 1)) * math.sqrt(m2 / (n - 1) / n)
    return max(float(mean - half), bounds[0]), min(float(mean + half), bounds[1])


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
    shown = [*FIGURES, *POOLED, "lines", "unidentified", "seconds_per_world"]
    configs = ", ".join(f"`{c}`" for c in comparison.configs)
    out = [
        f"# Comparison: {comparison.worlds} worlds, seed {comparison.seed}, configs {configs}",
        "",
        (
            "Every config and rule fused the same scans. Each cell is the mean over the worlds (a ratio with an "
            f"empty denominator is left out), with, for the metrics, its {CONFIDENCE:.0%} Student t interval over "
            "the worlds in brackets (`<metric>_lo`, `<metric>_hi` in summary.csv), cut to the values the metric can "
            "take (a share within [0, 1], `map_error` at least 0; none where fewer than two worlds give the "
            "metric); the pooled ratios are over the segments of all worlds."
        ),
        "",
        *[f"- `{m}`: {DEFINITIONS[m]}." for m in FIGURES],
        "- `noise_recall_pooled`, `real_loss_pooled`: the same ratios over the segments of all worlds together.",
        (
            "- `noise_recall_seen_twice`: pooled noise recall on the worlds where every sunlight region a pose "
            "sees is in range and in sight of two poses or more."
        ),
        (
            "- `lines`: map lines with belief at least 0.5; `unidentified`: unidentified objects; "
            "`seconds_per_world`: the fusion time of the config and rule on a world."
        ),
        "",
        markdown_table(comparison.summary, shown, {c: ".4f" for c in shown if c.startswith("seconds")}),
    ]
    return "\n".join(out + _differences_markdown(comparison)) + "\n"


def markdown_table(rows: Sequence[dict[str, Any]], columns: Sequence[str], specs: dict[str, str] | None = None) -> str:
    """A Markdown table of ``rows`` (their config, rule and ``columns``): each value formatted by its column's
    format spec in ``specs`` (``.3f`` for the others), its interval (``<column>_lo``, ``_hi``) in brackets if it
    has one, an empty cell for None.

    >>> print(markdown_table([{"config": "a", "rule": "r", "x": 0.5, "x_lo": 0.25, "x_hi": 0.75, "y": None}], ["x", "y"]))
    | config | rule | x | y |
    | --- | --- | ---: | ---: |
    | a | r | 0.500 [0.250, 0.750] |  |
    """
    out = [
        "| " + " | ".join(["config", "rule", *columns]) + " |",
        "| " + " | ".join(["---", "---", *["---:"] * len(columns)]) + " |",
    ]
    for row in rows:
        cells = []
        for c in columns:
            spec = (specs or {}).get(c, ".3f")
            cell = "" if row[c] is None else _shown(row[c], spec)
            if row.get(f"{c}_lo") is not None:
                cell += f" [{_shown(row[f'{c}_lo'], spec)}, {_shown(row[f'{c}_hi'], spec)}]"
            cells.append(cell)
        out.append("| " + " | ".join([row["config"], row["rule"], *cells]) + " |")
    return "\n".join(out)


def _differences_markdown(comparison: Comparison) -> list[str]:
    """The paired differences from the first config and rule, as Markdown lines (none for a single one)."""
    if not comparison.differences:
        return []
    base = comparison.label(comparison.variants[0])
    intro = (
        f"Paired differences from `{base}`: the mean over the worlds of each one's value less `{base}`'s on "
        f"the same world, with its {CONFIDENCE:.0%} Student t interval (the spread of the worlds themselves "
        "cancels out)."
    )
    return ["", intro, "", markdown_table(comparison.differences, FIGURES, dict.fromkeys(FIGURES, "+.3f"))]


def _cell(value: Any) -> Any:
    return "" if value is None else value


def _shown(value: float, spec: str) -> str:
    """``value`` formatted by ``spec``, a value that rounds to zero as 0 (never "-0.000")."""
    text = format(value, spec)
    return format(0.0, spec) if float(text) == 0 else text
