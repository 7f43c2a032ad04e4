"""Figure layout: the view of a run, axes at equal aspect, titles wrapped to their axes, the legend below.

Sizes are computed, not measured (no layout engine: a constrained layout draws
the figure twice). Figures are made on an Agg canvas, without pyplot: no global
figure state, and a figure is freed when its last reference goes.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from evmap.maps.app.figures.runs import poses, world
from evmap.maps.app.run import Run

__all__ = ["finish", "new_figure", "title", "view"]

# in inches
AXES_WIDTH = 10.0  # the widest axes
AXES_HEIGHT = 7.5  # all the axes of a figure together, at most
MIN_WIDTH = 7.0  # the narrowest figure
LEFT, RIGHT = 0.7, 0.25  # beside the axes: y tick labels and label; nothing
PAD = 0.12  # at the top and bottom of the figure
LINE = 0.2  # a line of title or legend text
CHAR = 0.075  # average width of a character of 10 pt text
TITLE_PAD = 0.12  # between a title and its axes
GAP = 0.15  # between stacked axes (no tick labels there)
HGAP = 0.3  # between axes side by side
XAXIS = 0.5  # x tick labels and label
TALL = 0.6  # a view higher than this times its width puts panels side by side
MARGIN = 0.5  # metres around what a figure shows


def view(run: Run) -> NDArray[np.float64]:
    """(xmin, ymin, xmax, ymax) of what the figures of a run show, plus a margin.

    The world (when the run has one), the poses, the LSL segments and the map's points.
    """
    store = run.map.segments
    points = [
        poses(run)[:, :2],
        store.p,
        store.q,
        np.array([d["xy"] for d in run.map.graph.nodes.values()], dtype=float).reshape(-1, 2),
    ]
    simulated = world(run)
    if simulated is not None:
        s = simulated.surfaces()
        r = s.cylinder_radii[:, None]
        points += [s.vertices, s.cylinder_centers - r, s.cylinder_centers + r]
    xy = np.concatenate(points)
    return np.r_[xy.min(axis=0) - MARGIN, xy.max(axis=0) + MARGIN]


def grid(box: NDArray[np.float64], panels: int) -> tuple[int, int, float, float]:
    """Rows, columns, and the width and height (inches) of each axes showing ``box`` at equal aspect.

    Several panels stack for a wide view and stand side by side for a tall one.
    """
    width, height = box[2] - box[0], box[3] - box[1]
    rows, cols = (panels, 1) if height / width <= TALL else (1, panels)
    axes_w = (AXES_WIDTH - HGAP * (cols - 1)) / cols
    axes_h = axes_w * height / width
    if axes_h * rows > AXES_HEIGHT:
        axes_h = AXES_HEIGHT / rows
        axes_w = axes_h * width / height
    return rows, cols, axes_w, axes_h


def new_figure(run: Run, panels: int) -> tuple[Figure, list[Axes]]:
    """A figure of ``panels`` axes showing the run's view, on an Agg canvas; :func:`finish` lays it out."""
    box = view(run)
    rows, cols, _, _ = grid(box, panels)
    fig = Figure()
    FigureCanvasAgg(fig)
    axes: list[Axes] = []
    for k in range(panels):
        first = axes[0] if axes else None
        ax = fig.add_axes((0, 0, 1, 1), sharex=first, sharey=first)
        ax.set_aspect("equal")
        ax.set_xlim(box[0], box[2])
        ax.set_ylim(box[1], box[3])
        ax.grid(True, color="#e6e6e6", lw=0.5)
        ax.set_axisbelow(True)
        bottom, left = k // cols == rows - 1, k % cols == 0
        ax.tick_params(labelsize="small", labelbottom=bottom, labelleft=left)
        if bottom:
            ax.set_xlabel("x (m)")
        if left:
            ax.set_ylabel("y (m)")
        axes.append(ax)
    return fig, axes


def axes_box(ax: Axes) -> NDArray[np.float64]:
    """(xmin, ymin, xmax, ymax) the axes show."""
    return np.r_[ax.get_xlim(), ax.get_ylim()][[0, 2, 1, 3]]


def wrap(text: str, inches: float) -> str:
    """Wrap each line of ``text`` to about ``inches`` of 10 pt text."""
    width = max(20, int(inches / CHAR))
    return "\n".join(wrapped for line in text.split("\n") for wrapped in textwrap.wrap(line, width) or [""])


def title(ax: Axes, headline: str, details: str = "") -> None:
    """The axes' title: a headline over the figure's numbers, wrapped to the axes' width."""
    _, _, axes_w, _ = grid(axes_box(ax), len(ax.figure.axes))
    ax.set_title(wrap(f"{headline}\n{details}" if details else headline, axes_w), fontsize="medium", loc="left")


def finish(fig: Figure, handles: Sequence[Artist], headline: str = "") -> None:
    """Lay the figure out: ``headline`` (bold) on top, the titled axes, then the legend of ``handles``."""
    axes = fig.axes
    rows, cols, axes_w, axes_h = grid(axes_box(axes[0]), len(axes))
    grid_w = cols * axes_w + (cols - 1) * HGAP
    fig_w = max(grid_w + LEFT + RIGHT, MIN_WIDTH)
    headline = wrap(headline, 0.8 * fig_w) if headline else ""  # bold and larger than 10 pt
    longest = max(len(h.get_label()) for h in handles)
    ncols = max(1, min(len(handles), int(fig_w / (CHAR * 0.85 * longest + 0.6)), 5))
    legend_h = LINE * -(-len(handles) // ncols) + 0.1
    lines = [ax.get_title(loc="left").count("\n") + 1 for ax in axes]
    title_h = [LINE * max(lines[r * cols : (r + 1) * cols]) + TITLE_PAD for r in range(rows)]
    head_h = (LINE * 1.2 * (headline.count("\n") + 1) + 0.15) if headline else 0.0
    fig_h = PAD + head_h + sum(title_h) + rows * axes_h + GAP * (rows - 1) + XAXIS + legend_h + PAD
    fig.set_size_inches(fig_w, fig_h)
    left = (fig_w - grid_w) / 2 + (LEFT - RIGHT) / 2
    top = fig_h - PAD - head_h
    for r in range(rows):
        top -= title_h[r] + axes_h
        for c in range(cols):
            x = left + c * (axes_w + HGAP)
            axes[r * cols + c].set_position((x / fig_w, top / fig_h, axes_w / fig_w, axes_h / fig_h))
        top -= GAP
    if headline:
        fig.suptitle(headline, x=left / fig_w, y=1 - PAD / fig_h, ha="left", va="top", fontweight="bold")
    fig.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, (legend_h + PAD) / fig_h),
        ncols=ncols,
        fontsize="small",
        frameon=False,
        borderaxespad=0,
    )
