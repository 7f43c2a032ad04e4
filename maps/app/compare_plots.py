"""A comparison's plots: noise recall against real loss, the metrics' intervals, the line beliefs, the paired
differences from the first config and rule.

One series per config and rule (a *variant*). Every variant stays visible when
they agree (Yager's and Dubois–Prade's rules are equal on a two-element frame):
each has its own marker and colour, and its mean is drawn shifted sideways by a
few points (not data units) from the others.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.transforms import offset_copy

from evmap.maps.app.compare_metrics import BELIEF_BINS, FIGURES
from evmap.maps.app.compare_tables import CONFIDENCE, Comparison

__all__ = ["MARKERS", "PLOT_FILES", "SHIFT_POINTS", "write_plots"]

MARKERS = "oDs^vPX*<>"
"""Marker of the k-th variant (cycled)."""

SHIFT_POINTS = 7.0
"""Sideways shift (typographic points) between the means of consecutive variants."""

PLOT_FILES = ("noise_recall_vs_real_loss.png", "metric_intervals.png", "line_beliefs.png", "paired_differences.png")
"""What :func:`write_plots` writes."""


def write_plots(comparison: Comparison, directory: Path) -> None:
    """Write the :data:`PLOT_FILES` into ``directory``."""
    plots = (plot_recall_loss, plot_intervals, plot_beliefs, plot_differences)
    for name, plot in zip(PLOT_FILES, plots, strict=True):
        plot(comparison, directory / name)


def plot_recall_loss(comparison: Comparison, path: Path) -> None:
    """Noise recall against real loss: each world (dots) and each variant's mean with its intervals (bars)."""
    fig = Figure(figsize=(6.4, 4.8))
    ax = fig.subplots()
    n = len(comparison.variants)
    for k, (variant, row) in enumerate(zip(comparison.variants, comparison.summary, strict=True)):
        color, marker = f"C{k % 10}", MARKERS[k % len(MARKERS)]
        points = comparison.points[variant]
        ax.scatter(points[:, 0], points[:, 1], s=8, alpha=0.25, color=color, linewidths=0)
        if row["real_loss"] is None or row["noise_recall"] is None:
            continue
        shifted = offset_copy(ax.transData, fig=fig, x=(k - (n - 1) / 2) * SHIFT_POINTS, y=0, units="points")
        ax.errorbar(
            row["real_loss"],
            row["noise_recall"],
            xerr=_bar(row, "real_loss"),
            yerr=_bar(row, "noise_recall"),
            fmt=marker,
            ms=8,
            color=color,
            mec="k",
            capsize=3,
            transform=shifted,
            label=comparison.label(variant),
            zorder=3,
        )
    ax.set_xlabel("real loss (real segments eliminated)")
    ax.set_ylabel("noise recall (phantom segments eliminated)")
    ax.set_title(
        f"{comparison.worlds} worlds: worlds (dots), means with {CONFIDENCE:.0%} intervals\n"
        "(means shifted sideways by a few points so that equal ones stay visible)",
        fontsize="medium",
    )
    ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def plot_intervals(comparison: Comparison, path: Path) -> None:
    """One panel per metric: each variant's mean and interval on its own row."""
    title = f"Means over {comparison.worlds} worlds with {CONFIDENCE:.0%} Student t intervals"
    _panels(comparison.summary, [comparison.label(v) for v in comparison.variants], title, path)


def plot_differences(comparison: Comparison, path: Path) -> None:
    """One panel per metric: each variant's mean paired difference from the first variant, with its interval."""
    base = comparison.label(comparison.variants[0])
    title = (
        f"Paired differences from {base} over {comparison.worlds} worlds (the same worlds' values less {base}'s), "
        f"with {CONFIDENCE:.0%} Student t intervals"
    )
    labels = [comparison.label(v) for v in comparison.variants[1:]]
    _panels(comparison.differences, labels, title, path, zero=True)


def _panels(rows: Sequence[dict], labels: list[str], title: str, path: Path, zero: bool = False) -> None:
    """One panel per metric, a row per variant (the k-th marked as the k-th variant of the comparison, or
    the (k+1)-th with ``zero``, where a line marks no difference)."""
    metrics = FIGURES
    fig = Figure(figsize=(3.0 * len(metrics), 0.45 * max(len(labels), 1) + 1.6))
    axes = fig.subplots(1, len(metrics), sharey=True)
    for ax, metric in zip(axes, metrics, strict=True):
        for k, row in enumerate(rows):
            if row[metric] is None:
                continue
            style = k + zero
            ax.errorbar(
                row[metric],
                k,
                xerr=_bar(row, metric),
                fmt=MARKERS[style % len(MARKERS)],
                color=f"C{style % 10}",
                mec="k",
                capsize=3,
            )
        if zero:
            ax.axvline(0.0, color="k", lw=0.8)
        ax.set_title(metric, fontsize="medium")
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(labels)), labels)
    axes[0].set_ylim(max(len(labels), 1) - 0.5, -0.5)
    fig.suptitle(title if labels else f"{title}: one config and rule, nothing to compare", fontsize="medium")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def plot_beliefs(comparison: Comparison, path: Path) -> None:
    """Per variant: the share of real and phantom segments per Bel(real) of their line."""
    n = len(comparison.variants)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig = Figure(figsize=(4.2 * cols, 3.2 * rows))
    axes = fig.subplots(rows, cols, squeeze=False, sharey=True)
    for ax, variant in zip(axes.flat, comparison.variants):
        for counts, label, color in zip(comparison.beliefs[variant], ("real", "phantom"), ("C0", "C3")):
            share = counts / max(int(counts.sum()), 1)
            ax.stairs(share, BELIEF_BINS, label=f"{label} ({int(counts.sum())})", color=color, fill=False, lw=1.5)
        ax.set_title(comparison.label(variant))
        ax.set_xlabel("Bel(real) of the segment's line (0: eliminated)")
        ax.legend(fontsize="small")
    for ax in axes.flat[n:]:
        ax.axis("off")
    axes[0, 0].set_ylabel("share of segments")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def _bar(row: dict, metric: str) -> list[list[float]] | None:
    """Error bar lengths below and above the mean, from ``<metric>_lo``/``_hi``; None without an interval."""
    lo, hi = row.get(f"{metric}_lo"), row.get(f"{metric}_hi")
    if lo is None or hi is None:
        return None
    return [[row[metric] - lo], [hi - row[metric]]]
