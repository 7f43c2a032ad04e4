"""The figures of the contour segments (the LSL's, or a log's laser's): Fig. 4 (the segments as seen) and noise
elimination (kept, eliminated).

Both show every pose's segments by default, so their numbers are the report's
(``lsl_segments``, ``noise_segments``, ``noise_eliminated``, ``real_eliminated``,
``lines_before_merge``); ``pose=k`` shows one pose's. When the segments' ground
truth is unknown (measured data), segments are not told real from phantom.
"""

from __future__ import annotations

from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from evmap.maps.app.figures import draw
from evmap.maps.app.figures.captions import pose_span
from evmap.maps.app.figures.layout import finish, new_figure, title
from evmap.maps.app.figures.runs import contour_sensor, pose_ids, truth_known
from evmap.maps.app.figures.style import BLACK, OPEN, ORANGE, VERMILION
from evmap.maps.app.run import Run

__all__ = ["lsl_lines_figure", "noise_figure"]


def lsl_lines_figure(run: Run, pose: int | None = None) -> Figure:
    """Fig. 4: the LSL segments of every pose (or of pose ``pose``), real ones and sunlight phantoms.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.maps.app.run import run_scenario
    >>> fig = lsl_lines_figure(run_scenario(default_scenario(), load_config()))
    >>> fig.axes[0].get_title(loc="left").splitlines()[1]
    '66 LSL segments: 38 on true surfaces, 28 sunlight phantoms'
    """
    ids = pose_ids(run, pose)
    store = run.map.segments
    p, q, truth = store.p[ids], store.q[ids], store.truth[ids]
    sensor = contour_sensor(run)
    fig, (ax,) = new_figure(run, 1)
    lit = draw.sunlight(ax, run)
    draw.walls(ax, run)
    draw.robots(ax, run, pose)
    handles = [*draw.wall_handles(run)]
    if truth_known(truth):
        phantom = truth == "noise"
        draw.segments(ax, p[~phantom], q[~phantom], color=BLACK, lw=1.6, gid="lsl-real")
        draw.segments(ax, p[phantom], q[phantom], color=VERMILION, lw=1.6, gid="lsl-phantom")
        counts = (
            f"{len(ids)} LSL segments: {int((~phantom).sum())} on true surfaces, {int(phantom.sum())} sunlight phantoms"
        )
        handles += [
            Line2D([], [], lw=1.6, color=BLACK, label="LSL segment (real)"),
            Line2D([], [], lw=1.6, color=VERMILION, label="LSL segment (sunlight phantom)"),
        ]
    else:
        draw.segments(ax, p, q, color=BLACK, lw=1.6, gid="lsl-segments")
        counts = f"{len(ids)} {sensor} segments (ground truth unknown)"
        handles.append(Line2D([], [], lw=1.6, color=BLACK, label=f"{sensor} segment"))
    title(ax, f"Fig. 4  {sensor} line map from {pose_span(run, pose)}", counts)
    finish(fig, [*handles, *([Patch(color=ORANGE, alpha=0.15, label="sunlight region")] if lit else [])])
    return fig


def noise_figure(run: Run, pose: int | None = None) -> Figure:
    """Noise elimination: the LSL segments of every pose (or of pose ``pose``) kept (solid) and eliminated (faint).

    Colour is the simulator's ground truth (real or phantom) when it is known;
    the open space the segments were judged against (every pose's) is drawn beneath.
    """
    ids = pose_ids(run, pose)
    store = run.map.segments
    p, q, truth = store.p[ids], store.q[ids], store.truth[ids]
    gone = store.eliminated[ids]
    fig, (ax,) = new_figure(run, 1)
    if not run.map.open_space.is_empty:
        draw.area(ax, run.map.open_space, OPEN, alpha=0.3, gid="open-space")
    draw.walls(ax, run)
    draw.robots(ax, run, pose)
    rule = f"(m(noise) > {run.config.noise.threshold:g}, {run.config.rule} rule)"
    if truth_known(truth):
        phantom = truth == "noise"
        groups = [
            (~phantom & ~gone, "kept-real", BLACK, False, "real, kept"),
            (phantom & ~gone, "kept-phantom", VERMILION, False, "phantom, kept"),
            (~phantom & gone, "eliminated-real", BLACK, True, "real, eliminated"),
            (phantom & gone, "eliminated-phantom", VERMILION, True, "phantom, eliminated"),
        ]
        counts = (
            f"{int((phantom & gone).sum())} of {int(phantom.sum())} phantoms eliminated, "
            f"{int((~phantom & gone).sum())} of {int((~phantom).sum())} real segments lost, "
            f"{int((~gone).sum())} kept {rule}"
        )
    else:
        groups = [
            (~gone, "kept", BLACK, False, "segment, kept"),
            (gone, "eliminated", BLACK, True, "segment, eliminated"),
        ]
        counts = f"{int(gone.sum())} of {len(ids)} segments eliminated as noise, {int((~gone).sum())} kept {rule}"
    handles = [*draw.wall_handles(run), Patch(color=OPEN, alpha=0.3, label="sonar open space, all poses")]
    for mask, gid, color, faint, name in groups:
        style = {"lw": 1.0, "alpha": 0.3, "zorder": 2.5} if faint else {"lw": 1.6}  # faint ones beneath
        draw.segments(ax, p[mask], q[mask], color=color, gid=gid, **style)
        handles.append(Line2D([], [], color=color, label=name, **style))
    title(ax, f"Noise elimination of the {contour_sensor(run)} segments from {pose_span(run, pose)}", counts)
    finish(fig, handles)
    return fig
