"""The figures of one sonar scan: Fig. 2 (the scan and its RCDs) and Fig. 5 (raw scan, open space).

Three sets of RCDs come from one scan, and each figure says which it counts:
Fig. 2 plots the RCDs at the figure's tolerance (``config.rcd_figure``, the
paper's 1 cm over at least 10 deg); Fig. 5b the primitive RCDs (every width, at
``config.rcd``'s tolerance) that make the open space; Fig. 6 the matching RCDs
(at least ``config.rcd.min_width_deg`` wide, the report's ``rcds_actual``).
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from evmap.maps.app.figures import draw
from evmap.maps.app.figures.captions import every_pose, pose_of, tolerance, type_counts
from evmap.maps.app.figures.layout import finish, new_figure, title
from evmap.maps.app.figures.runs import observation, outcome
from evmap.maps.app.figures.style import BLACK, FAINT, OPEN, VERMILION
from evmap.maps.app.run import Run
from evmap.sources.rcd import extract_rcds

__all__ = ["open_space_figure", "sonar_scan_figure"]


def sonar_scan_figure(run: Run, pose: int = 0) -> Figure:
    """Fig. 2: the sonar scan from one pose and its RCDs at ``config.rcd_figure`` (1 cm, 10 deg).

    A dot per return (time of flight), a ray every 10th return, and each RCD as
    an arc at its mean range over its width, coloured by type and numbered. The
    title says how many RCDs that is, and how many the matching (Fig. 6) and the
    open space (Fig. 5b) use instead.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.maps.app.run import run_scenario
    >>> fig = sonar_scan_figure(run_scenario(default_scenario(), load_config()))
    >>> fig.axes[0].get_xlabel()
    'x (m)'
    """
    obs = observation(run, pose)
    done = outcome(run, pose)
    params = run.config.rcd_figure
    rcds = extract_rcds(obs.sonar, params)
    fig, (ax,) = new_figure(run, 1)
    draw.walls(ax, run)
    draw.scan(ax, obs.sonar, rays_every=10)
    draw.rcd_arcs(ax, obs.sonar.pose, rcds, [str(k + 1) for k in range(len(rcds))])
    draw.robot(ax, obs.pose, f"P{pose}")
    title(
        ax,
        f"Fig. 2  Sonar scan from {pose_of(run, pose)} and its RCDs at the Fig. 2 tolerance",
        f"{len(obs.sonar)} returns; {len(rcds)} RCDs {tolerance(params)} (types: {type_counts(rcds)}). "
        f"The matching (Fig. 6) uses {len(done.actual)} RCDs {tolerance(run.config.rcd)}, "
        f"the open space (Fig. 5b) {len(done.primitive)} primitive RCDs of every width",
    )
    finish(
        fig,
        [
            *draw.wall_handles(run),
            Line2D([], [], ls="", marker=".", ms=4, color=BLACK, label="return (TOF dot)"),
            Line2D([], [], lw=0.6, color=FAINT, label="ray, every 10th return"),
            *draw.type_handles(),
        ],
    )
    return fig


def open_space_figure(run: Run, pose: int = 0) -> Figure:
    """Fig. 5: (a) the raw range scan, multiple reflections marked; (b) the open space of its primitive RCDs.

    The open space of the pose is filled; with several poses, the union of every
    pose's open space (what the segments are judged against) is drawn lighter.
    """
    obs = observation(run, pose)
    done = outcome(run, pose)
    sonar = obs.sonar
    several = len(run.outcomes) > 1
    fig, (top, bottom) = new_figure(run, 2)  # or left, right for a tall view
    draw.walls(top, run)
    rays = np.repeat(sonar.pose[None, :2], len(sonar), axis=0)
    top.add_collection(
        LineCollection(np.stack([rays, sonar.points], axis=1), colors=FAINT, linewidths=0.3, alpha=0.5, gid="rays")
    )
    multiple = sonar.order >= 2
    draw.dots(top, sonar.points[~multiple], BLACK, "returns")
    draw.dots(top, sonar.points[multiple], VERMILION, "multiple-reflections", size=9)
    draw.robot(top, obs.pose, f"P{pose}")
    title(
        top,
        "(a) Raw range scan",
        f"{len(sonar)} returns, {int(multiple.sum())} of them multiple reflections (SR), "
        f"{int((sonar.order == 0).sum())} at max range",
    )

    union = run.map.open_space
    if several and not union.is_empty:
        draw.area(bottom, union, OPEN, alpha=0.25, gid="open-space-union")
    draw.area(bottom, done.open_space, OPEN, alpha=0.6, gid="open-space")
    draw.walls(bottom, run)
    draw.dots(bottom, sonar.points, FAINT, "returns-faint", size=2)
    draw.robot(bottom, obs.pose, f"P{pose}")
    every = f"; {every_pose(run)} together: {union.area:.1f} m² (lighter)" if several else ""
    title(
        bottom,
        "(b) Open space estimated from the primitive RCDs",
        f"{done.open_space.area:.1f} m² from {len(done.primitive)} primitive RCDs, every width, readings within "
        f"{run.config.rcd.range_tolerance * 100:g} cm ({type_counts(done.primitive)}; Type IV gives none){every}",
    )
    finish(
        fig,
        headline=f"Fig. 5  Sonar scan and open space, {pose_of(run, pose)}",
        handles=[
            *draw.wall_handles(run),
            Line2D([], [], ls="", marker=".", ms=4, color=BLACK, label="return"),
            Line2D([], [], ls="", marker=".", ms=6, color=VERMILION, label="multiple reflection (SR)"),
            Patch(color=OPEN, alpha=0.6, label=f"open space, pose {pose}"),
            *([Patch(color=OPEN, alpha=0.25, label="open space, all poses")] if several else []),
        ],
    )
    return fig
