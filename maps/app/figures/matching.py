"""Fig. 6: the RCDs of one pose's actual scan matched against those of a scan simulated from the map.

The RCDs are the matching ones (at least ``config.rcd.min_width_deg`` wide):
summed over the poses they are the report's ``rcds_actual``, ``rcds_simulated``
and ``rcds_matched``, which the headline of a multi-pose run states.
"""

from __future__ import annotations

from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from evmap.maps.app.figures import draw
from evmap.maps.app.figures.captions import every_pose, pose_of, tolerance
from evmap.maps.app.figures.layout import finish, new_figure, title
from evmap.maps.app.figures.runs import observation, outcome
from evmap.maps.app.figures.style import BLACK, FAINT, GREEN, VERMILION
from evmap.maps.app.run import Run

__all__ = ["rcd_matching_figure"]


def rcd_matching_figure(run: Run, pose: int = 0) -> Figure:
    """Fig. 6: (a) actual RCDs numbered 1, 2, ...; (b) the map and its simulated RCDs a, b, ...

    Arcs are coloured by RCD type; a label's frame says whether the RCD matched
    (green), is unmatched (red; an actual one of Type I-III becomes an
    unidentified object) or is an unmatched Type IV (grey). The matched pairs
    are listed in the title of (b). The map drawn is the final one: with several
    poses, later poses may have changed the lines the scan was simulated from.
    """
    obs = observation(run, pose)
    done = outcome(run, pose)
    actual, predicted = done.actual, done.predicted
    ai, si = done.matched
    numbers = [str(k + 1) for k in range(len(actual))]
    names = [draw.letters(k) for k in range(len(predicted))]
    fig, (top, bottom) = new_figure(run, 2)  # or left, right for a tall view

    draw.walls(top, run)
    draw.dots(top, obs.sonar.points, FAINT, "returns-faint", size=2)
    draw.rcd_arcs(top, obs.sonar.pose, actual, numbers, draw.match_status(actual, ai))
    draw.robot(top, obs.pose, f"P{pose}")
    title(
        top,
        f"(a) The {len(actual)} matching RCDs of the actual scan",
        f"RCDs {tolerance(run.config.rcd)} (Fig. 2 plots those at its own tolerance, "
        "Fig. 5b the primitive RCDs of every width)",
    )

    draw.walls(bottom, run, alpha=0.35)
    lines = run.map.lines(0.0)
    draw.segments(bottom, draw.ends(lines, "p"), draw.ends(lines, "q"), color=BLACK, lw=1.3, gid="map-lines")
    draw.rcd_arcs(bottom, done.predicted_scan.pose, predicted, names, draw.match_status(predicted, si))
    draw.robot(bottom, obs.pose, f"P{pose}")
    pairs = ", ".join(  # a no-break space keeps a pair on one line
        f"({numbers[a]},\u00a0{names[s]})" for a, s in sorted(zip(ai.tolist(), si.tolist(), strict=True))
    )
    title(
        bottom,
        f"(b) Line map and the {len(predicted)} RCDs of the scan simulated from it",
        f"Matching RCD pairs ({len(ai)} of {len(actual)} actual RCDs): {pairs or 'none'}",
    )
    finish(
        fig,
        headline=f"Fig. 6  Actual and simulated RCDs, {pose_of(run, pose)}{totals(run)}",
        handles=[
            *draw.wall_handles(run),
            Line2D([], [], lw=1.3, color=BLACK, label="map line"),
            *draw.type_handles(),
            Patch(facecolor="white", edgecolor=GREEN, lw=1.5, label="matched"),
            Patch(facecolor="white", edgecolor=VERMILION, lw=1.5, label="unmatched"),
            Patch(facecolor="white", edgecolor=FAINT, lw=1.5, label="unmatched, Type IV (ignored)"),
        ],
    )
    return fig


def totals(run: Run) -> str:
    """The matching of every pose, for the headline of a multi-pose run (nothing for one pose)."""
    if len(run.outcomes) < 2:
        return ""
    matched = sum(len(o.matched[0]) for o in run.outcomes)
    actual = sum(len(o.actual) for o in run.outcomes)
    simulated = sum(len(o.predicted) for o in run.outcomes)
    return f" ({every_pose(run)}: {matched} of {actual} actual RCDs matched, {simulated} simulated)"
