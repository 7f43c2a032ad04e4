"""The figure of a robot log's line fit: every scan's returned rays, explained or not, under the final map.

Each returned laser ray ends in a dot: grey where a segment extracted from its
own scan explains it (the ray hits the segment, :mod:`evmap.sources.line_fit`),
vermilion where none does; the final map's believed lines (Bel(real) at least
0.5) are drawn over them in black, the others thin and blue, beside the robot's
path. The title's coverage and error are ``report.json``'s ``line_fit``. Only a
run over a log (``evmap log``) has it.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from evmap.maps.app.figures import draw
from evmap.maps.app.figures.layout import MARGIN, finish, new_figure, title
from evmap.maps.app.figures.style import BLACK, BLUE, FAINT, VERMILION
from evmap.maps.app.run import Run

__all__ = ["line_fit_figure"]

BELIEVED = 0.5
"""Lines with at least this Bel(real) are drawn in black, the others thin and blue."""


def line_fit_figure(run: Run) -> Figure:
    """Fig. 9: the accumulated scans' returned rays, explained by their scan's segments or not, and the final map.

    Raises ValueError for a run that is not over a log.
    """
    if run.log is None:
        raise ValueError("the line fit figure is drawn for a run over a robot log (evmap log)")
    fits = run.log.fits
    points = np.concatenate([np.zeros((0, 2)), *(f.points for f in fits)])
    hit = np.concatenate([np.zeros(0, dtype=bool), *(f.hit for f in fits)])
    fig, (ax,) = new_figure(run, 1)
    if len(points):  # the view holds every ray's end
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        lo, hi = points.min(axis=0) - MARGIN, points.max(axis=0) + MARGIN
        ax.set_xlim(min(x0, lo[0]), max(x1, hi[0]))
        ax.set_ylim(min(y0, lo[1]), max(y1, hi[1]))
    for gid, color, chosen in (("rays-explained", FAINT, hit), ("rays-missed", VERMILION, ~hit)):
        ax.scatter(*points[chosen].T, s=1.0, lw=0, color=color, rasterized=True, zorder=1, gid=gid)
    lines = run.map.lines(0.0)
    for gid, color, lw, chosen in (
        ("lines", BLUE, 0.6, [ln for ln in lines if ln.belief < BELIEVED]),
        ("believed-lines", BLACK, 1.0, [ln for ln in lines if ln.belief >= BELIEVED]),
    ):
        draw.segments(ax, draw.ends(chosen, "p"), draw.ends(chosen, "q"), color=color, lw=lw, gid=gid, zorder=3)
    draw.robots(ax, run)
    paths = [line for line in ax.lines if line.get_gid() == "robot-path"]  # a log of many scans: its path
    log = run.log
    believed = sum(ln.belief >= BELIEVED for ln in lines)
    error = "undefined" if log.rms_error_median is None else f"{100 * log.rms_error_median:.2f} cm"
    coverage = "undefined" if log.coverage_mean is None else f"{log.coverage_mean:.3f}"
    title(
        ax,
        f"Fig. 9  Line fit over the {log.scans} scans of the log, and the final map",
        f"{len(hit)} returned rays, {int(hit.sum())} explained by a segment of their scan; coverage {coverage} "
        f"(mean over scans), error {error} (median over scans); {believed} of {len(lines)} map lines believed",
    )
    finish(
        fig,
        [
            Line2D([], [], ls="", marker="o", ms=3, color=FAINT, label="ray explained by its scan's segments"),
            Line2D([], [], ls="", marker="o", ms=3, color=VERMILION, label="ray no segment explains"),
            Line2D([], [], lw=1.0, color=BLACK, label=f"map line, Bel(real) >= {BELIEVED:g}"),
            Line2D([], [], lw=0.6, color=BLUE, label="map line, less believed"),
            *[Line2D([], [], lw=0.5, color=path.get_color(), label="robot path") for path in paths],
        ],
    )
    return fig
