"""The figures of the paper's pipeline (Figs. 2 and 4-7), one matplotlib figure per stage.

Each function takes a :class:`~evmap.maps.app.run.Run` and returns a
:class:`matplotlib.figure.Figure` on an Agg canvas: no pyplot, so no global
figure state, and a figure is freed when its last reference goes. The figures
of one observation take the index of the pose to show (``pose=0``); the map
figures show the map after every pose. Units are metres, axes have equal
aspect, and the true walls are drawn dashed like the paper's hand-measured
contour (LSL-transparent ones, glass and mirrors, in blue; sonar-absorbing
ones in brown).

:func:`write_figures` writes them all as PNG files (150 dpi) with these names:

=============================  ===========================  =========  ==============================================
file                           function                     paper      what it shows
=============================  ===========================  =========  ==============================================
``fig2_sonar_scan_rcds.png``   :func:`sonar_scan_figure`    Fig. 2     the sonar scan (a dot per return, a ray every
                                                                       10th) and its RCDs at ``config.rcd_figure``
``fig4_lsl_lines.png``         :func:`lsl_lines_figure`     Fig. 4     the LSL segments, real and sunlight phantoms
``fig5_open_space.png``        :func:`open_space_figure`    Fig. 5     (a) raw range scan, multiple reflections
                                                                       marked; (b) the open space of the typed RCDs
``fig6a_noise_eliminated.png`` :func:`noise_figure`         Sec. III   segments kept and eliminated (faint) against
                                                                       the open space
``fig6b_merged_corners.png``   :func:`merged_map_figure`    Sec. III   the merged lines over the surviving segments,
                                                                       corners (concave, convex) and free ends
``fig6c_rcd_matching.png``     :func:`rcd_matching_figure`  Fig. 6     (a) actual RCDs 1, 2, ...; (b) the map and its
                                                                       simulated RCDs a, b, ...; the matched pairs
``fig7_final_map.png``         :func:`final_map_figure`     Fig. 7     the final map, line width by Bel(real),
                                                                       landmarks emphasised, unidentified objects
=============================  ===========================  =========  ==============================================

Artists carry ``gid`` tags (``"rcd-arcs"``, ``"lsl-phantom"``, ``"landmark-lines"``,
...) so tests and users can find what a figure drew.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import shapely
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, PathPatch, Polygon
from matplotlib.path import Path as MplPath
from numpy.typing import NDArray

from evmap.maps.app.run import Run
from evmap.maps.observation import Observation
from evmap.maps.pipeline import PoseOutcome
from evmap.sources.rcd import Rcds, extract_rcds
from evmap.sources.readings import SonarScan

__all__ = [
    "FIGURE_FILES",
    "final_map_figure",
    "lsl_lines_figure",
    "merged_map_figure",
    "noise_figure",
    "open_space_figure",
    "rcd_matching_figure",
    "sonar_scan_figure",
    "write_figures",
]

# Okabe-Ito colours: distinguishable with every common colour-vision deficiency.
_BLACK, _ORANGE, _GREEN, _BLUE, _VERMILION, _PURPLE = "#000000", "#E69F00", "#009E73", "#0072B2", "#D55E00", "#CC79A7"
_WALL, _GLASS, _ABSORBING, _FAINT = "#6e6e6e", "#3a8fd0", "#a0522d", "#9a9a9a"
_TYPE_COLOURS = {1: _BLUE, 2: _GREEN, 3: _ORANGE, 4: _PURPLE}
_ROMAN = {1: "I", 2: "II", 3: "III", 4: "IV"}
_TYPE_MEANING = {
    1: "I: both neighbours farther",
    2: "II: one neighbour nearer",
    3: "III: both neighbours nearer",
    4: "IV: multiple reflection",
}
_OPEN = "#8cc8ec"
_DASH = (0, (4, 2.5))  # the hand-measured contour
# layout, in inches
_AXES_WIDTH = 10.0  # the widest axes
_AXES_HEIGHT = 7.5  # all the axes of a figure together, at most
_MIN_WIDTH = 7.0  # the narrowest figure
_LEFT, _RIGHT = 0.7, 0.25  # beside the axes: y tick labels and label; nothing
_PAD = 0.12  # at the top and bottom of the figure
_LINE = 0.2  # a line of title or legend text
_CHAR = 0.075  # average width of a character of 10 pt text
_TITLE_PAD = 0.12  # between a title and its axes
_GAP = 0.15  # between stacked axes (no tick labels there)
_HGAP = 0.3  # between axes side by side
_TALL = 0.6  # a view higher than this times its width puts panels side by side
_XAXIS = 0.5  # x tick labels and label
_MARGIN = 0.5  # metres around what a figure shows
_ARC_STEP = np.radians(1.0)
_ROBOT_RADIUS = 0.15


# --------------------------------------------------------------------- figures


def sonar_scan_figure(run: Run, pose: int = 0) -> Figure:
    """Fig. 2: the sonar scan from one pose and its RCDs (``config.rcd_figure``: 1 cm, 10 deg).

    A dot per return (time of flight), a ray every 10th return, and each RCD as
    an arc at its mean range over its width, coloured by type and numbered.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.maps.app.run import run_scenario
    >>> fig = sonar_scan_figure(run_scenario(default_scenario(), load_config()))
    >>> fig.axes[0].get_xlabel()
    'x (m)'
    """
    obs = _observation(run, pose)
    params = run.config.rcd_figure
    rcds = extract_rcds(obs.sonar, params)
    fig, (ax,) = _figure(run, 1)
    _walls(ax, run)
    _scan(ax, obs.sonar, rays_every=10)
    _rcd_arcs(ax, obs.sonar.pose, rcds, [str(k + 1) for k in range(len(rcds))])
    _robot(ax, obs.pose, f"P{pose}")
    counts = ", ".join(f"{int((rcds.type == t).sum())} {_ROMAN[t]}" for t in _TYPE_COLOURS)
    _title(
        ax,
        f"Fig. 2  Sonar scan from pose {pose} and its RCDs",
        f"{len(obs.sonar)} returns; {len(rcds)} RCDs of readings within "
        f"{params.range_tolerance * 100:g} cm over at least {params.min_width_deg:g}° (types: {counts})",
    )
    _finish(
        fig,
        [
            *_wall_handles(run),
            Line2D([], [], ls="", marker=".", ms=4, color=_BLACK, label="return (TOF dot)"),
            Line2D([], [], lw=0.6, color=_FAINT, label="ray, every 10th return"),
            *_type_handles(),
        ],
    )
    return fig


def lsl_lines_figure(run: Run, pose: int = 0) -> Figure:
    """Fig. 4: the LSL segments from one pose, real ones and sunlight phantoms, over the true contour."""
    obs = _observation(run, pose)
    lsl = obs.lsl
    phantom = lsl.truth == "noise"
    fig, (ax,) = _figure(run, 1)
    _sunlight(ax, run)
    _walls(ax, run)
    _segments(ax, lsl.p[~phantom], lsl.q[~phantom], color=_BLACK, lw=1.6, gid="lsl-real")
    _segments(ax, lsl.p[phantom], lsl.q[phantom], color=_VERMILION, lw=1.6, gid="lsl-phantom")
    _robot(ax, obs.pose, f"P{pose}")
    _title(
        ax,
        f"Fig. 4  LSL line map from pose {pose}",
        f"{len(lsl)} segments: {int((~phantom).sum())} on true surfaces, {int(phantom.sum())} phantoms from sunlight",
    )
    _finish(
        fig,
        [
            *_wall_handles(run),
            Line2D([], [], lw=1.6, color=_BLACK, label="LSL segment (real)"),
            Line2D([], [], lw=1.6, color=_VERMILION, label="LSL segment (sunlight phantom)"),
            *([Patch(color=_ORANGE, alpha=0.15, label="sunlight region")] if run.world.sunlight else []),
        ],
    )
    return fig


def open_space_figure(run: Run, pose: int = 0) -> Figure:
    """Fig. 5: (a) the raw range scan, multiple reflections marked; (b) the open space of its RCDs.

    The open space of the pose is filled; with several poses, the union of the
    other poses' open spaces is drawn lighter.
    """
    obs = _observation(run, pose)
    outcome = _outcome(run, pose)
    scan = obs.sonar
    fig, (top, bottom) = _figure(run, 2)  # or left, right for a tall view
    _walls(top, run)
    rays = np.repeat(scan.pose[None, :2], len(scan), axis=0)
    top.add_collection(
        LineCollection(np.stack([rays, scan.points], axis=1), colors=_FAINT, linewidths=0.3, alpha=0.5, gid="rays")
    )
    multiple = scan.order >= 2
    _dots(top, scan.points[~multiple], _BLACK, "returns")
    _dots(top, scan.points[multiple], _VERMILION, "multiple-reflections", size=9)
    _robot(top, obs.pose, f"P{pose}")
    _title(
        top,
        "(a) Raw range scan",
        f"{len(scan)} returns, {int(multiple.sum())} of them multiple reflections (SR), "
        f"{int((scan.order == 0).sum())} at max range",
    )

    union = run.map.open_space
    if len(run.outcomes) > 1 and not union.is_empty:
        _area(bottom, union, _OPEN, alpha=0.25, gid="open-space-union")
    _area(bottom, outcome.open_space, _OPEN, alpha=0.6, gid="open-space")
    _walls(bottom, run)
    _dots(bottom, scan.points, _FAINT, "returns-faint", size=2)
    _robot(bottom, obs.pose, f"P{pose}")
    types = outcome.primitive.type
    counts = ", ".join(f"{int((types == t).sum())} {_ROMAN[t]}" for t in _TYPE_COLOURS)
    _title(
        bottom,
        "(b) Open space estimated from the typed RCDs",
        f"{outcome.open_space.area:.1f} m² from {len(types)} primitive RCDs ({counts}; Type IV gives none)",
    )
    _finish(
        fig,
        headline=f"Fig. 5  Sonar scan and open space, pose {pose}",
        handles=[
            *_wall_handles(run),
            Line2D([], [], ls="", marker=".", ms=4, color=_BLACK, label="return"),
            Line2D([], [], ls="", marker=".", ms=6, color=_VERMILION, label="multiple reflection (SR)"),
            Patch(color=_OPEN, alpha=0.6, label=f"open space, pose {pose}"),
            *([Patch(color=_OPEN, alpha=0.25, label="open space, all poses")] if len(run.outcomes) > 1 else []),
        ],
    )
    return fig


def noise_figure(run: Run, pose: int = 0) -> Figure:
    """Noise elimination: the pose's LSL segments kept (solid) and eliminated (faint).

    Colour is the simulator's ground truth (real or phantom); the open space the
    segments were judged against (all poses') is drawn beneath.
    """
    obs = _observation(run, pose)
    store = run.map.segments
    ids = _outcome(run, pose).segments
    p, q = store.p[ids], store.q[ids]
    gone = store.eliminated[ids]
    phantom = store.truth[ids] == "noise"
    fig, (ax,) = _figure(run, 1)
    if not run.map.open_space.is_empty:
        _area(ax, run.map.open_space, _OPEN, alpha=0.3, gid="open-space")
    _walls(ax, run)
    for keep_mask, gid, color, kwargs in (
        (~phantom & gone, "eliminated-real", _BLACK, {"lw": 1.0, "alpha": 0.3}),
        (phantom & gone, "eliminated-phantom", _VERMILION, {"lw": 1.0, "alpha": 0.3}),
        (~phantom & ~gone, "kept-real", _BLACK, {"lw": 1.6}),
        (phantom & ~gone, "kept-phantom", _VERMILION, {"lw": 1.8}),
    ):
        _segments(ax, p[keep_mask], q[keep_mask], color=color, gid=gid, **kwargs)
    _robot(ax, obs.pose, f"P{pose}")
    n_phantom, n_real = int(phantom.sum()), int((~phantom).sum())
    _title(
        ax,
        f"Noise elimination of the segments from pose {pose}",
        f"{int((phantom & gone).sum())} of {n_phantom} phantoms eliminated, {int((~phantom & gone).sum())} of "
        f"{n_real} real segments lost, {int((~gone).sum())} kept (m(noise) > {run.config.noise.threshold:g}, "
        f"{run.config.rule} rule)",
    )
    _finish(
        fig,
        [
            *_wall_handles(run),
            Patch(color=_OPEN, alpha=0.3, label="sonar open space"),
            Line2D([], [], lw=1.6, color=_BLACK, label="real, kept"),
            Line2D([], [], lw=1.8, color=_VERMILION, label="phantom, kept"),
            Line2D([], [], lw=1.0, color=_BLACK, alpha=0.3, label="real, eliminated"),
            Line2D([], [], lw=1.0, color=_VERMILION, alpha=0.3, label="phantom, eliminated"),
        ],
    )
    return fig


def merged_map_figure(run: Run) -> Figure:
    """Merging and corners: the map's lines over the segments that survived noise elimination.

    Corners are marked by shape as seen from the robot (concave, convex), free
    line ends by small open circles.
    """
    bm = run.map
    store = bm.segments
    kept = ~store.eliminated
    fig, (ax,) = _figure(run, 1)
    _walls(ax, run)
    _segments(ax, store.p[kept], store.q[kept], color=_ORANGE, lw=4.0, alpha=0.45, gid="segments")
    lines = bm.lines(0.0)
    _segments(ax, _ends(lines, "p"), _ends(lines, "q"), color=_BLACK, lw=1.3, gid="map-lines")
    nodes = bm.graph.nodes
    by_kind: dict[str, list[tuple[float, float]]] = {"concave": [], "convex": [], "unknown": [], "endpoint": []}
    for _, d in nodes(data=True):
        if d["kind"] == "endpoint":
            by_kind["endpoint"].append(d["xy"])
        elif d["kind"] == "corner":
            by_kind[d.get("shape", "unknown")].append(d["xy"])
    styles = {
        "concave": {"marker": "o", "ms": 7, "mfc": _BLUE, "mec": "white", "label": "concave corner"},
        "convex": {"marker": "D", "ms": 6, "mfc": _VERMILION, "mec": "white", "label": "convex corner (edge)"},
        "unknown": {"marker": "s", "ms": 6, "mfc": _FAINT, "mec": "white", "label": "corner"},
        "endpoint": {"marker": "o", "ms": 4, "mfc": "white", "mec": _BLACK, "label": "free end point"},
    }
    handles = []
    for kind, xy in by_kind.items():
        style = styles[kind]
        if xy or kind in ("concave", "convex", "endpoint"):
            pts = np.array(xy, dtype=float).reshape(-1, 2)
            ax.plot(pts[:, 0], pts[:, 1], ls="", zorder=5, gid=f"points-{kind}", **style)
            handles.append(Line2D([], [], ls="", **style))
    for pose_index, xy in enumerate(run.world.poses):
        _robot(ax, xy, f"P{pose_index}")
    n_corners = sum(len(by_kind[k]) for k in ("concave", "convex", "unknown"))
    merge, corners = run.config.merge, run.config.corners
    _title(
        ax,
        "Merged line map with corners",
        f"{int(kept.sum())} segments → {len(lines)} lines (tolerances {merge.distance * 100:g} cm, "
        f"{merge.angle_deg:g}°); {n_corners} corners within {corners.distance * 100:g} cm "
        f"({len(by_kind['concave'])} concave, {len(by_kind['convex'])} convex)",
    )
    _finish(
        fig,
        [
            *_wall_handles(run),
            Line2D([], [], lw=4.0, color=_ORANGE, alpha=0.45, label="segment after noise elimination"),
            Line2D([], [], lw=1.3, color=_BLACK, label="merged line"),
            *handles,
        ],
    )
    return fig


def rcd_matching_figure(run: Run, pose: int = 0) -> Figure:
    """Fig. 6: (a) actual RCDs numbered 1, 2, ...; (b) the map and its simulated RCDs a, b, ...

    Arcs are coloured by RCD type; a label's frame says whether the RCD matched
    (green), is unmatched (red; an actual one of Type I-III becomes an
    unidentified object) or is an unmatched Type IV (grey). The matched pairs
    are listed in the title of (b). The map drawn is the final one: with several
    poses, later poses may have changed the lines the scan was simulated from.
    """
    obs = _observation(run, pose)
    outcome = _outcome(run, pose)
    actual, predicted = outcome.actual, outcome.predicted
    ai, si = outcome.matched
    numbers = [str(k + 1) for k in range(len(actual))]
    letters = [_letters(k) for k in range(len(predicted))]
    fig, (top, bottom) = _figure(run, 2)  # or left, right for a tall view

    _walls(top, run)
    _dots(top, obs.sonar.points, _FAINT, "returns-faint", size=2)
    _rcd_arcs(top, obs.sonar.pose, actual, numbers, _match_status(actual, ai))
    _robot(top, obs.pose, f"P{pose}")
    _title(
        top,
        "(a) RCDs of the actual scan",
        f"{len(actual)} RCDs at least {run.config.rcd.min_width_deg:g}° wide, readings within "
        f"{run.config.rcd.range_tolerance * 100:g} cm",
    )

    _walls(bottom, run, alpha=0.35)
    lines = run.map.lines(0.0)
    _segments(bottom, _ends(lines, "p"), _ends(lines, "q"), color=_BLACK, lw=1.3, gid="map-lines")
    _rcd_arcs(bottom, outcome.predicted_scan.pose, predicted, letters, _match_status(predicted, si))
    _robot(bottom, obs.pose, f"P{pose}")
    pairs = ", ".join(  # a no-break space keeps a pair on one line
        f"({numbers[a]},\u00a0{letters[s]})" for a, s in sorted(zip(ai.tolist(), si.tolist(), strict=True))
    )
    _title(
        bottom,
        f"(b) Line map and the {len(predicted)} RCDs of the scan simulated from it",
        f"Matching RCD pairs ({len(ai)} of {len(actual)} actual RCDs): {pairs or 'none'}",
    )
    _finish(
        fig,
        headline=f"Fig. 6  Actual and simulated RCDs, pose {pose}",
        handles=[
            *_wall_handles(run),
            Line2D([], [], lw=1.3, color=_BLACK, label="map line"),
            *_type_handles(),
            Patch(facecolor="white", edgecolor=_GREEN, lw=1.5, label="matched"),
            Patch(facecolor="white", edgecolor=_VERMILION, lw=1.5, label="unmatched"),
            Patch(facecolor="white", edgecolor=_FAINT, lw=1.5, label="unmatched, Type IV (ignored)"),
        ],
    )
    return fig


def final_map_figure(run: Run) -> Figure:
    """Fig. 7: the final line-corner map, line width by Bel(real), landmarks emphasised.

    Reinforced lines and corners (the landmarks: seen by both sensors) are blue,
    the others grey; unidentified objects (seen by sonar only) are red crosses
    labelled with their id and belief.
    """
    bm = run.map
    lines = bm.lines(0.0)
    landmark_ids = {obj.id for obj in bm.landmarks()}
    fig, (ax,) = _figure(run, 1)
    _walls(ax, run, alpha=0.45)
    for gid, color, chosen in (
        ("lines", _FAINT, [ln for ln in lines if ln.id not in landmark_ids]),
        ("landmark-lines", _BLUE, [ln for ln in lines if ln.id in landmark_ids]),
    ):
        _segments(
            ax,
            _ends(chosen, "p"),
            _ends(chosen, "q"),
            color=color,
            lw=_belief_width(np.array([ln.belief for ln in chosen])),
            gid=gid,
            capstyle="round",
        )
    corners = bm.corners(0.0)
    for gid, color, size, chosen in (
        ("corners", _FAINT, 5, [c for c in corners if c.id not in landmark_ids]),
        ("landmark-corners", _BLUE, 8, [c for c in corners if c.id in landmark_ids]),
    ):
        xy = np.array([c.xy for c in chosen], dtype=float).reshape(-1, 2)
        ax.plot(xy[:, 0], xy[:, 1], ls="", marker="o", ms=size, mfc=color, mec="white", zorder=5, gid=gid)
    unidentified = bm.unidentified()
    xy = np.array([u.xy for u in unidentified], dtype=float).reshape(-1, 2)
    ax.scatter(
        xy[:, 0],
        xy[:, 1],
        s=40 + 120 * np.array([u.belief for u in unidentified]),
        marker="X",
        color=_VERMILION,
        edgecolors="white",
        linewidths=0.5,
        zorder=6,
        gid="unidentified",
    )
    for u in unidentified:
        _label(ax, u.xy, f"{u.id} {u.belief:.2f}", _VERMILION, offset=(6, 6), gid="unidentified-label")
    for pose_index, pose_xy in enumerate(run.world.poses):
        _robot(ax, pose_xy, f"P{pose_index}")
    n_landmark_lines = sum(ln.id in landmark_ids for ln in lines)
    _title(
        ax,
        "Fig. 7  Final line-corner map; line width by belief Bel(real)",
        f"{len(lines)} lines ({n_landmark_lines} reinforced), {len(corners)} corners "
        f"({sum(c.id in landmark_ids for c in corners)} reinforced), {len(unidentified)} unidentified objects; "
        f"{run.config.rule} rule",
    )
    _finish(
        fig,
        [
            *_wall_handles(run),
            Line2D([], [], lw=3, color=_BLUE, label="landmark line (reinforced)"),
            Line2D([], [], lw=3, color=_FAINT, label="line not reinforced"),
            *[
                Line2D([], [], lw=float(_belief_width(b)), color=_BLACK, label=f"Bel(real) = {b:g}")
                for b in (0.5, 0.8, 0.95)
            ],
            Line2D([], [], ls="", marker="o", ms=8, mfc=_BLUE, mec="white", label="landmark corner"),
            Line2D([], [], ls="", marker="o", ms=5, mfc=_FAINT, mec="white", label="corner"),
            Line2D([], [], ls="", marker="X", ms=9, color=_VERMILION, label="unidentified object (sonar only)"),
        ],
    )
    return fig


FIGURE_FILES: dict[str, Callable[..., Figure]] = {
    "fig2_sonar_scan_rcds.png": sonar_scan_figure,
    "fig4_lsl_lines.png": lsl_lines_figure,
    "fig5_open_space.png": open_space_figure,
    "fig6a_noise_eliminated.png": noise_figure,
    "fig6b_merged_corners.png": merged_map_figure,
    "fig6c_rcd_matching.png": rcd_matching_figure,
    "fig7_final_map.png": final_map_figure,
}
"""File name -> figure function, in the paper's order (what :func:`write_figures` writes)."""

_MAP_FIGURES = (merged_map_figure, final_map_figure)


def write_figures(run: Run, directory: str | Path, *, pose: int = 0, dpi: int = 150) -> list[Path]:
    """Write every figure of :data:`FIGURE_FILES` into ``directory`` as PNG; return their paths.

    ``pose`` is the pose shown by the figures of one observation (the map
    figures show the map after every pose). The directory must exist.

    >>> import tempfile
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.maps.app.run import run_scenario
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     [path.name for path in write_figures(run_scenario(default_scenario(), load_config()), tmp)][:2]
    ['fig2_sonar_scan_rcds.png', 'fig4_lsl_lines.png']
    """
    _check_pose(run, pose)
    directory = Path(directory)
    paths = []
    for name, make in FIGURE_FILES.items():
        fig = make(run) if make in _MAP_FIGURES else make(run, pose)
        path = directory / name
        fig.savefig(path, dpi=dpi)
        paths.append(path)
    return paths


# --------------------------------------------------------------------- layout


def _check_pose(run: Run, pose: int) -> None:
    n = len(run.observations)
    if isinstance(pose, bool) or not isinstance(pose, int | np.integer) or not 0 <= pose < n:
        raise ValueError(f"pose must be an integer index in [0, {n}), the run's poses; got {pose!r}")


def _observation(run: Run, pose: int) -> Observation:
    _check_pose(run, pose)
    return run.observations[pose]


def _outcome(run: Run, pose: int) -> PoseOutcome:
    _check_pose(run, pose)
    return run.outcomes[pose]


def _view(run: Run) -> NDArray[np.float64]:
    """(xmin, ymin, xmax, ymax) of what the figures of a run show: world, poses, map, plus a margin."""
    s = run.world.surfaces()
    r = s.cylinder_radii[:, None]
    bm = run.map
    points = [
        s.vertices,
        s.cylinder_centers - r,
        s.cylinder_centers + r,
        run.world.poses[:, :2],
        np.array([d["xy"] for _, d in bm.graph.nodes(data=True)], dtype=float).reshape(-1, 2),
    ]
    xy = np.concatenate(points)
    return np.r_[xy.min(axis=0) - _MARGIN, xy.max(axis=0) + _MARGIN]


def _grid(view: NDArray[np.float64], panels: int) -> tuple[int, int, float, float]:
    """Rows, columns, and the width and height (inches) of each axes showing ``view`` at equal aspect.

    Several panels stack for a wide view and stand side by side for a tall one.
    """
    width, height = view[2] - view[0], view[3] - view[1]
    rows, cols = (panels, 1) if height / width <= _TALL else (1, panels)
    axes_w = (_AXES_WIDTH - _HGAP * (cols - 1)) / cols
    axes_h = axes_w * height / width
    if axes_h * rows > _AXES_HEIGHT:
        axes_h = _AXES_HEIGHT / rows
        axes_w = axes_h * width / height
    return rows, cols, axes_w, axes_h


def _figure(run: Run, panels: int) -> tuple[Figure, list[Axes]]:
    """A figure of ``panels`` axes showing the run's view, on an Agg canvas; :func:`_finish` lays it out."""
    view = _view(run)
    rows, cols, _, _ = _grid(view, panels)
    fig = Figure()
    FigureCanvasAgg(fig)
    axes: list[Axes] = []
    for k in range(panels):
        first = axes[0] if axes else None
        ax = fig.add_axes((0, 0, 1, 1), sharex=first, sharey=first)
        ax.set_aspect("equal")
        ax.set_xlim(view[0], view[2])
        ax.set_ylim(view[1], view[3])
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


def _view_of(ax: Axes) -> NDArray[np.float64]:
    return np.r_[ax.get_xlim(), ax.get_ylim()][[0, 2, 1, 3]]


def _wrap(text: str, inches: float) -> str:
    """Wrap each line of ``text`` to about ``inches`` of 10 pt text."""
    width = max(20, int(inches / _CHAR))
    return "\n".join(wrapped for line in text.split("\n") for wrapped in textwrap.wrap(line, width) or [""])


def _title(ax: Axes, headline: str, details: str = "") -> None:
    """The axes' title: a headline over the figure's numbers, wrapped to the axes' width."""
    _, _, axes_w, _ = _grid(_view_of(ax), len(ax.figure.axes))
    ax.set_title(_wrap(f"{headline}\n{details}" if details else headline, axes_w), fontsize="medium", loc="left")


def _finish(fig: Figure, handles: Sequence[Artist], headline: str = "") -> None:
    """Lay the figure out: ``headline`` (bold) on top, the titled axes, then the legend of ``handles``.

    Sizes are computed, not measured (no layout engine: a constrained layout
    draws the figure twice).
    """
    axes = fig.axes
    rows, cols, axes_w, axes_h = _grid(_view_of(axes[0]), len(axes))
    grid_w = cols * axes_w + (cols - 1) * _HGAP
    fig_w = max(grid_w + _LEFT + _RIGHT, _MIN_WIDTH)
    longest = max(len(h.get_label()) for h in handles)
    ncols = max(1, min(len(handles), int(fig_w / (_CHAR * 0.85 * longest + 0.6)), 5))
    legend_h = _LINE * -(-len(handles) // ncols) + 0.1
    lines = [ax.get_title(loc="left").count("\n") + 1 for ax in axes]
    title_h = [_LINE * max(lines[r * cols : (r + 1) * cols]) + _TITLE_PAD for r in range(rows)]
    head_h = (_LINE * 1.2 * (headline.count("\n") + 1) + 0.15) if headline else 0.0
    fig_h = _PAD + head_h + sum(title_h) + rows * axes_h + _GAP * (rows - 1) + _XAXIS + legend_h + _PAD
    fig.set_size_inches(fig_w, fig_h)
    left = (fig_w - grid_w) / 2 + (_LEFT - _RIGHT) / 2
    top = fig_h - _PAD - head_h
    for r in range(rows):
        top -= title_h[r] + axes_h
        for c in range(cols):
            x = left + c * (axes_w + _HGAP)
            axes[r * cols + c].set_position((x / fig_w, top / fig_h, axes_w / fig_w, axes_h / fig_h))
        top -= _GAP
    if headline:
        fig.suptitle(headline, x=left / fig_w, y=1 - _PAD / fig_h, ha="left", va="top", fontweight="bold")
    fig.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, (legend_h + _PAD) / fig_h),
        ncols=ncols,
        fontsize="small",
        frameon=False,
        borderaxespad=0,
    )


# --------------------------------------------------------------------- drawing


def _walls(ax: Axes, run: Run, alpha: float = 1.0) -> None:
    """The true contour, dashed: walls grey, LSL-transparent (glass, mirror) blue, sonar-absorbing brown."""
    s = run.world.surfaces()
    p, q = s.p, s.q
    glass = ~s.lsl_opaque
    absorbing = s.lsl_opaque & ~s.sonar_reflective
    wall = s.lsl_opaque & s.sonar_reflective
    for mask, color, lw, gid in (
        (wall, _WALL, 1.0, "walls"),
        (glass, _GLASS, 2.0, "glass"),
        (absorbing, _ABSORBING, 2.0, "absorbing"),
    ):
        if mask.any():
            _segments(ax, p[mask], q[mask], color=color, lw=lw, ls=_DASH, alpha=alpha, gid=gid, zorder=1)
    for xy, radius, opaque in zip(s.cylinder_centers, s.cylinder_radii, s.cylinder_lsl_opaque, strict=True):
        ax.add_patch(
            Circle(
                xy,
                radius,
                fill=False,
                ec=_WALL if opaque else _GLASS,
                lw=1.0,
                ls=_DASH,
                alpha=alpha,
                gid="cylinders",
                zorder=1,
            )
        )


def _wall_handles(run: Run) -> list[Line2D]:
    s = run.world.surfaces()
    dash = _DASH
    handles = [Line2D([], [], lw=1.0, ls=dash, color=_WALL, label="true wall (hand-measured contour)")]
    if (~s.lsl_opaque).any() or (~s.cylinder_lsl_opaque).any():
        handles.append(Line2D([], [], lw=2.0, ls=dash, color=_GLASS, label="glass / mirror (LSL-transparent)"))
    if (s.lsl_opaque & ~s.sonar_reflective).any():
        handles.append(Line2D([], [], lw=2.0, ls=dash, color=_ABSORBING, label="sonar-absorbing surface"))
    return handles


def _segments(
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


def _ends(lines: Sequence[object], attr: str) -> NDArray[np.float64]:
    return np.array([getattr(ln, attr) for ln in lines], dtype=float).reshape(-1, 2)


def _dots(ax: Axes, xy: NDArray[np.float64], color: str, gid: str, size: float = 4) -> None:
    ax.scatter(xy[:, 0], xy[:, 1], s=size, c=color, linewidths=0, zorder=2, gid=gid)


def _scan(ax: Axes, scan: SonarScan, rays_every: int) -> None:
    """A dot per return, and a ray from the sensor every ``rays_every``-th return."""
    points = scan.points
    origin = scan.pose[:2]
    shown = points[::rays_every]
    ax.add_collection(
        LineCollection(
            np.stack([np.broadcast_to(origin, shown.shape), shown], axis=1),
            colors=_FAINT,
            linewidths=0.6,
            zorder=2,
            gid="rays",
        )
    )
    _dots(ax, points, _BLACK, "returns")


def _sunlight(ax: Axes, run: Run) -> None:
    for region in run.world.sunlight:
        ax.add_patch(
            Polygon(
                np.array(region.polygon, dtype=float),
                closed=True,
                fc=_ORANGE,
                alpha=0.15,
                ec="none",
                gid="sunlight",
                zorder=0,
            )
        )


def _area(ax: Axes, geometry: shapely.Geometry, color: str, alpha: float, gid: str) -> None:
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


def _robot(ax: Axes, pose: NDArray[np.float64], name: str) -> None:
    """The robot: a disc with its heading, and its name."""
    x, y, heading = (float(v) for v in pose)
    ax.add_patch(Circle((x, y), _ROBOT_RADIUS, fc="white", ec=_BLACK, lw=1.2, zorder=7, gid="robot"))
    tip = (x + 2 * _ROBOT_RADIUS * np.cos(heading), y + 2 * _ROBOT_RADIUS * np.sin(heading))
    ax.plot([x, tip[0]], [y, tip[1]], color=_BLACK, lw=1.5, zorder=7, gid="robot-heading")
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


def _match_status(rcds: Rcds, matched: NDArray[np.intp]) -> list[str]:
    status = np.where(rcds.type == 4, "ignored", "unmatched").astype("<U9")
    status[matched] = "matched"
    return status.tolist()


_STATUS_EDGE = {"matched": _GREEN, "unmatched": _VERMILION, "ignored": _FAINT, "": "none"}


def _rcd_arcs(
    ax: Axes, pose: NDArray[np.float64], rcds: Rcds, labels: Sequence[str], status: Sequence[str] | None = None
) -> None:
    """RCDs as arcs at their mean range over their width, coloured by type, labelled ``label·type``.

    A label sits just beyond its arc along the RCD's direction, pulled inside
    the view when the arc is out of it (long readings); ``status`` frames it.
    """
    origin = np.asarray(pose[:2], dtype=float)
    arcs = []
    for direction, width, r in zip(rcds.direction, rcds.width, rcds.range, strict=True):
        t = np.linspace(direction - width / 2, direction + width / 2, max(2, int(np.ceil(width / _ARC_STEP)) + 1))
        arcs.append(origin + r * np.column_stack([np.cos(t), np.sin(t)]))
    ax.add_collection(
        LineCollection(
            arcs,
            colors=[_TYPE_COLOURS[int(t)] for t in rcds.type],
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
        distance = min(r + beyond, _inside(origin, u, box, inset))
        xy = origin + distance * u
        _label(
            ax,
            xy,
            f"{labels[k]}·{_ROMAN[int(kind)]}",
            _TYPE_COLOURS[int(kind)],
            edge=_STATUS_EDGE[status[k]],
            gid="rcd-label",
        )


def _inside(origin: NDArray[np.float64], u: NDArray[np.float64], box: NDArray[np.float64], inset: float) -> float:
    """How far from ``origin`` along ``u`` one stays ``inset`` inside ``box`` = (xmin, xmax, ymin, ymax)."""
    reach = np.inf
    for axis in (0, 1):
        if abs(u[axis]) > 1e-12:
            bound = box[2 * axis + 1] - inset if u[axis] > 0 else box[2 * axis] + inset
            reach = min(reach, (bound - origin[axis]) / u[axis])
    return max(float(reach), 0.0)


def _label(
    ax: Axes,
    xy: Sequence[float],
    text: str,
    color: str,
    *,
    edge: str = "none",
    offset: tuple[float, float] = (0, 0),
    gid: str,
) -> None:
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


def _type_handles() -> list[Line2D]:
    return [Line2D([], [], lw=3, color=c, label=f"RCD type {_TYPE_MEANING[t]}") for t, c in _TYPE_COLOURS.items()]


def _letters(k: int) -> str:
    """0 -> a, 25 -> z, 26 -> aa, ... (the paper's labels of simulated RCDs)."""
    name = ""
    k += 1
    while k:
        k, rest = divmod(k - 1, 26)
        name = chr(ord("a") + rest) + name
    return name


def _belief_width(belief: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Line width (points) for Bel(real): 0.6 + 6 Bel³, so the high beliefs that matter differ visibly."""
    return 0.6 + 6.0 * np.clip(np.asarray(belief, dtype=float), 0.0, 1.0) ** 3
