"""Drawing on a figure's axes: walls, segments, scans, areas, the robot, RCD arcs and labels.

Every artist carries a ``gid`` (``"walls"``, ``"rcd-arcs"``, ...) so tests and
users can find what a figure drew.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, PathPatch, Polygon
from matplotlib.path import Path as MplPath
from numpy.typing import NDArray

from evmap.maps.app.figures.runs import poses, world
from evmap.maps.app.figures.style import (
    ABSORBING,
    BLACK,
    DASH,
    FAINT,
    GLASS,
    ORANGE,
    STATUS_EDGE,
    TYPE_COLOURS,
    TYPE_MEANING,
    WALL,
)
from evmap.maps.app.run import Run
from evmap.sources.rcd import TYPE_NAMES, Rcds
from evmap.sources.readings import SonarScan

__all__ = [
    "area",
    "belief_width",
    "dots",
    "ends",
    "label",
    "letters",
    "match_status",
    "rcd_arcs",
    "robot",
    "robots",
    "scan",
    "segments",
    "sunlight",
    "type_handles",
    "wall_handles",
    "walls",
]

ARC_STEP = np.radians(1.0)
ROBOT_RADIUS = 0.15
MAX_ROBOTS = 50
"""Most robots a map figure draws one by one; beyond, their path."""


def _polylines(p: NDArray[np.float64], q: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """Segments p-q (in order) joined into polylines where one ends where the next begins.

    >>> [x.tolist() for x in _polylines(np.array([[0.0, 0], [1, 0], [5, 5]]), np.array([[1.0, 0], [1, 1], [6, 5]]))]
    [[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], [[5.0, 5.0], [6.0, 5.0]]]
    """
    if not len(p):
        return []
    starts = np.flatnonzero(np.r_[True, (q[:-1] != p[1:]).any(axis=1)])
    stops = np.r_[starts[1:], len(p)]
    return [np.concatenate([p[a:b], q[b - 1 : b]]) for a, b in zip(starts, stops, strict=True)]


def walls(ax: Axes, run: Run, alpha: float = 1.0) -> None:
    """The true walls of a simulated world, dashed: walls grey, LSL-transparent (glass, mirror) blue,
    sonar-absorbing brown. Nothing for a run without a world (measured data).

    A wall's consecutive segments are drawn as one polyline and all cylinders as one collection: a figure
    costs the same few artists however many segments and cylinders the world has.
    """
    simulated = world(run)
    if simulated is None:
        return
    s = simulated.surfaces()
    glass = ~s.lsl_opaque
    absorbing = s.lsl_opaque & ~s.sonar_reflective
    wall = s.lsl_opaque & s.sonar_reflective
    for mask, color, lw, gid in (
        (wall, WALL, 1.0, "walls"),
        (glass, GLASS, 2.0, "glass"),
        (absorbing, ABSORBING, 2.0, "absorbing"),
    ):
        if mask.any():
            # segments of other materials in between break a polyline: only neighbours in the list are joined
            index = np.flatnonzero(mask)
            lines = [
                part
                for block in np.split(index, np.flatnonzero(np.diff(index) != 1) + 1)
                for part in _polylines(s.p[block], s.q[block])
            ]
            ax.add_collection(
                LineCollection(lines, colors=color, linewidths=lw, linestyles=DASH, alpha=alpha, gid=gid, zorder=1)
            )
    if len(s.cylinder_radii):
        ax.add_collection(
            PatchCollection(
                [Circle(xy, radius) for xy, radius in zip(s.cylinder_centers, s.cylinder_radii, strict=True)],
                facecolors="none",
                edgecolors=[WALL if opaque else GLASS for opaque in s.cylinder_lsl_opaque],
                linewidths=1.0,
                linestyles=DASH,
                alpha=alpha,
                gid="cylinders",
                zorder=1,
            )
        )


def wall_handles(run: Run) -> list[Line2D]:
    """Legend entries of :func:`walls`: the simulated world's true walls, by material; none without a world."""
    simulated = world(run)
    if simulated is None:
        return []
    s = simulated.surfaces()
    handles = [Line2D([], [], lw=1.0, ls=DASH, color=WALL, label="true walls (simulated world)")]
    if (~s.lsl_opaque).any() or (~s.cylinder_lsl_opaque).any():
        handles.append(Line2D([], [], lw=2.0, ls=DASH, color=GLASS, label="true glass / mirror (LSL-transparent)"))
    if (s.lsl_opaque & ~s.sonar_reflective).any():
        handles.append(Line2D([], [], lw=2.0, ls=DASH, color=ABSORBING, label="true sonar-absorbing surface"))
    return handles


def segments(
    ax: Axes, p: NDArray[np.float64], q: NDArray[np.float64], *, color: str, gid: str, **kwargs: object
) -> None:
    """Segments p-q as one LineCollection (``lw``, ``ls``, ``alpha``, ``zorder``, ``capstyle`` pass on)."""
    lw = kwargs.pop("lw", 1.0)
    ls = kwargs.pop("ls", "solid")
    coll = LineCollection(
        np.stack([np.asarray(p, dtype=float).reshape(-1, 2), np.asarray(q, dtype=float).reshape(-1, 2)], axis=1),
        colors=color,
        linewidths=lw,
        linestyles=ls,
        gid=gid,
        **kwargs,  # type: ignore[arg-type]
    )
    if "zorder" not in kwargs:
        coll.set_zorder(3)
    ax.add_collection(coll)


def ends(lines: Sequence[object], attr: str) -> NDArray[np.float64]:
    """(N, 2) end points ``attr`` (``"p"`` or ``"q"``) of map lines."""
    return np.array([getattr(ln, attr) for ln in lines], dtype=float).reshape(-1, 2)


def dots(ax: Axes, xy: NDArray[np.float64], color: str, gid: str, size: float = 4) -> None:
    """Points as small dots."""
    ax.scatter(xy[:, 0], xy[:, 1], s=size, c=color, linewidths=0, zorder=2, gid=gid)


def scan(ax: Axes, sonar: SonarScan, rays_every: int) -> None:
    """A dot per return, and a ray from the sensor every ``rays_every``-th return."""
    shown = sonar.points[::rays_every]
    ax.add_collection(
        LineCollection(
            np.stack([np.broadcast_to(sonar.pose[:2], shown.shape), shown], axis=1),
            colors=FAINT,
            linewidths=0.6,
            zorder=2,
            gid="rays",
        )
    )
    dots(ax, sonar.points, BLACK, "returns")


def sunlight(ax: Axes, run: Run) -> bool:
    """The simulated world's sunlight regions, lightly filled; whether there were any."""
    simulated = world(run)
    regions = simulated.sunlight if simulated is not None else ()
    for region in regions:
        ax.add_patch(
            Polygon(
                np.array(region.polygon, dtype=float),
                closed=True,
                fc=ORANGE,
                alpha=0.15,
                ec="none",
                gid="sunlight",
                zorder=0,
            )
        )
    return bool(regions)


def area(ax: Axes, geometry: shapely.Geometry, color: str, alpha: float, gid: str) -> None:
    """A shapely (Multi)Polygon, holes included, as one filled patch."""
    paths = []
    for polygon in shapely.get_parts(geometry):
        for ring in (polygon.exterior, *polygon.interiors):
            xy = np.asarray(ring.coords)
            codes = np.full(len(xy), MplPath.LINETO, dtype=MplPath.code_type)
            codes[0], codes[-1] = MplPath.MOVETO, MplPath.CLOSEPOLY
            paths.append(MplPath(xy, codes))
    if paths:
        ax.add_patch(
            PathPatch(MplPath.make_compound_path(*paths), fc=color, ec=color, alpha=alpha, lw=0.8, gid=gid, zorder=0)
        )


def robot(ax: Axes, pose: NDArray[np.float64], name: str) -> None:
    """The robot: a disc with its heading, and its name."""
    x, y, heading = (float(v) for v in pose)
    ax.add_patch(Circle((x, y), ROBOT_RADIUS, fc="white", ec=BLACK, lw=1.2, zorder=7, gid="robot"))
    tip = (x + 2 * ROBOT_RADIUS * np.cos(heading), y + 2 * ROBOT_RADIUS * np.sin(heading))
    ax.plot([x, tip[0]], [y, tip[1]], color=BLACK, lw=1.5, zorder=7, gid="robot-heading")
    ax.annotate(
        name,
        (x, y),
        xytext=(-8, -8),
        textcoords="offset points",
        ha="right",
        va="top",
        fontsize="small",
        fontweight="bold",
        zorder=7,
    )


def robots(ax: Axes, run: Run, pose: int | None = None) -> None:
    """The robot at one pose, or at every pose of the run (``None``), named P0, P1, ...

    A run of more than :data:`MAX_ROBOTS` poses (a robot log) gets its path, and the robot at its first and last.
    """
    at = poses(run)
    chosen = range(len(at)) if pose is None else [pose]
    if pose is None and len(at) > MAX_ROBOTS:
        ax.plot(at[:, 0], at[:, 1], color="0.5", linewidth=0.5, zorder=5, gid="robot-path")
        chosen = [0, len(at) - 1]
    for k in chosen:
        robot(ax, at[k], f"P{k}")


def match_status(rcds: Rcds, matched: NDArray[np.intp]) -> list[str]:
    """Per RCD: ``matched``, ``unmatched``, or ``ignored`` (an unmatched Type IV)."""
    status = np.where(rcds.type == 4, "ignored", "unmatched").astype("<U9")
    status[matched] = "matched"
    return status.tolist()


def rcd_arcs(
    ax: Axes, pose: NDArray[np.float64], rcds: Rcds, labels: Sequence[str], status: Sequence[str] | None = None
) -> None:
    """RCDs as arcs at their mean range over their width, coloured by type, labelled ``label·type``.

    A label sits just beyond its arc along the RCD's direction, pulled inside
    the view when the arc is out of it (long readings); ``status`` frames it.
    """
    origin = np.asarray(pose[:2], dtype=float)
    arcs = []
    for direction, width, r in zip(rcds.direction, rcds.width, rcds.range, strict=True):
        t = np.linspace(direction - width / 2, direction + width / 2, max(2, int(np.ceil(width / ARC_STEP)) + 1))
        arcs.append(origin + r * np.column_stack([np.cos(t), np.sin(t)]))
    ax.add_collection(
        LineCollection(
            arcs,
            colors=[TYPE_COLOURS[int(t)] for t in rcds.type],
            linewidths=3.0,
            capstyle="butt",
            zorder=4,
            gid="rcd-arcs",
        )
    )
    box = np.array([*ax.get_xlim(), *ax.get_ylim()])
    inset = 0.04 * min(box[1] - box[0], box[3] - box[2])
    beyond = 0.02 * max(box[1] - box[0], box[3] - box[2])  # from the arc to its label
    status = status if status is not None else [""] * len(rcds)
    for k, (direction, r, kind) in enumerate(zip(rcds.direction, rcds.range, rcds.type, strict=True)):
        u = np.array([np.cos(direction), np.sin(direction)])
        xy = origin + min(r + beyond, reach_inside(origin, u, box, inset)) * u
        text = f"{labels[k]}·{TYPE_NAMES[int(kind)]}"
        label(ax, xy, text, TYPE_COLOURS[int(kind)], edge=STATUS_EDGE[status[k]], gid="rcd-label")


def reach_inside(origin: NDArray[np.float64], u: NDArray[np.float64], box: NDArray[np.float64], inset: float) -> float:
    """How far from ``origin`` along ``u`` one stays ``inset`` inside ``box`` = (xmin, xmax, ymin, ymax)."""
    reach = np.inf
    for axis in (0, 1):
        if abs(u[axis]) > 1e-12:
            bound = box[2 * axis + 1] - inset if u[axis] > 0 else box[2 * axis] + inset
            reach = min(reach, (bound - origin[axis]) / u[axis])
    return max(float(reach), 0.0)


def label(
    ax: Axes,
    xy: Sequence[float],
    text: str,
    color: str,
    *,
    edge: str = "none",
    offset: tuple[float, float] = (0, 0),
    gid: str,
) -> None:
    """A small bold label in a white box at ``xy`` (shifted by ``offset`` points), framed ``edge``."""
    ax.annotate(
        text,
        tuple(xy),
        xytext=offset,
        textcoords="offset points",
        ha="center" if offset == (0, 0) else "left",
        va="center" if offset == (0, 0) else "bottom",
        fontsize="x-small",
        color=color,
        fontweight="bold",
        zorder=8,
        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": edge, "lw": 1.2, "alpha": 0.85},
        gid=gid,
        annotation_clip=True,
    )


def type_handles() -> list[Line2D]:
    """Legend entries of the four RCD types."""
    return [Line2D([], [], lw=3, color=c, label=f"RCD type {TYPE_MEANING[t]}") for t, c in TYPE_COLOURS.items()]


def letters(k: int) -> str:
    """0 -> a, 25 -> z, 26 -> aa, ... (the paper's labels of simulated RCDs)."""
    name = ""
    k += 1
    while k:
        k, rest = divmod(k - 1, 26)
        name = chr(ord("a") + rest) + name
    return name


def belief_width(belief: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Line width (points) for Bel(real): 0.6 + 6 Bel³, so the high beliefs that matter differ visibly."""
    return 0.6 + 6.0 * np.clip(np.asarray(belief, dtype=float), 0.0, 1.0) ** 3
