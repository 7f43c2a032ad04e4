"""The figures of the map: merged lines with corners, and Fig. 7 (the final line-corner map).

They show the map after every pose, the robot at each pose; their numbers are
the report's (``lines_before_merge``, ``lines_after_merge``, ``corners``,
``unidentified``).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from evmap.maps.app.figures import draw
from evmap.maps.app.figures.captions import pose_span
from evmap.maps.app.figures.layout import finish, new_figure, title
from evmap.maps.app.figures.style import BLACK, BLUE, FAINT, ORANGE, VERMILION
from evmap.maps.app.run import Run

__all__ = ["final_map_figure", "merged_map_figure"]


def merged_map_figure(run: Run) -> Figure:
    """Merging and corners: the map's lines over the segments that survived noise elimination.

    Corners are marked by shape as seen from the robot (concave, convex), free
    line ends by small open circles.
    """
    bm = run.map
    store = bm.segments
    kept = ~store.eliminated & store.raw  # the raw segments kept, as report.json counts them
    fig, (ax,) = new_figure(run, 1)
    draw.walls(ax, run)
    draw.segments(ax, store.p[kept], store.q[kept], color=ORANGE, lw=4.0, alpha=0.45, gid="segments")
    lines = bm.lines(0.0)
    draw.segments(ax, draw.ends(lines, "p"), draw.ends(lines, "q"), color=BLACK, lw=1.3, gid="map-lines")
    by_kind: dict[str, list[tuple[float, float]]] = {"concave": [], "convex": [], "unknown": [], "endpoint": []}
    for d in bm.graph.nodes.values():
        if d["kind"] == "endpoint":
            by_kind["endpoint"].append(d["xy"])
        elif d["kind"] == "corner":
            by_kind[d.get("shape", "unknown")].append(d["xy"])
    styles = {
        "concave": {"marker": "o", "ms": 7, "mfc": BLUE, "mec": "white", "label": "concave corner"},
        "convex": {"marker": "D", "ms": 6, "mfc": VERMILION, "mec": "white", "label": "convex corner (edge)"},
        "unknown": {"marker": "s", "ms": 6, "mfc": FAINT, "mec": "white", "label": "corner"},
        "endpoint": {"marker": "o", "ms": 4, "mfc": "white", "mec": BLACK, "label": "free end point"},
    }
    handles = []
    for kind, xy in by_kind.items():
        style = styles[kind]
        if xy or kind in ("concave", "convex", "endpoint"):
            pts = np.array(xy, dtype=float).reshape(-1, 2)
            ax.plot(pts[:, 0], pts[:, 1], ls="", zorder=5, gid=f"points-{kind}", **style)
            handles.append(Line2D([], [], ls="", **style))
    draw.robots(ax, run)
    n_corners = sum(len(by_kind[k]) for k in ("concave", "convex", "unknown"))
    merge, corners = run.config.merge, run.config.corners
    title(
        ax,
        f"Merged line map with corners, {pose_span(run, None)}",
        f"{int(kept.sum())} segments → {len(lines)} lines (tolerances {merge.distance * 100:g} cm, "
        f"{merge.angle_deg:g}°); {n_corners} corners within {corners.distance * 100:g} cm "
        f"({len(by_kind['concave'])} concave, {len(by_kind['convex'])} convex)",
    )
    finish(
        fig,
        [
            *draw.wall_handles(run),
            Line2D([], [], lw=4.0, color=ORANGE, alpha=0.45, label="segment after noise elimination"),
            Line2D([], [], lw=1.3, color=BLACK, label="merged line"),
            *handles,
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
    fig, (ax,) = new_figure(run, 1)
    draw.walls(ax, run, alpha=0.45)
    for gid, color, chosen in (
        ("lines", FAINT, [ln for ln in lines if ln.id not in landmark_ids]),
        ("landmark-lines", BLUE, [ln for ln in lines if ln.id in landmark_ids]),
    ):
        draw.segments(
            ax,
            draw.ends(chosen, "p"),
            draw.ends(chosen, "q"),
            color=color,
            lw=draw.belief_width(np.array([ln.belief for ln in chosen])),
            gid=gid,
            capstyle="round",
        )
    corners = bm.corners(0.0)
    for gid, color, size, chosen in (
        ("corners", FAINT, 5, [c for c in corners if c.id not in landmark_ids]),
        ("landmark-corners", BLUE, 8, [c for c in corners if c.id in landmark_ids]),
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
        color=VERMILION,
        edgecolors="white",
        linewidths=0.5,
        zorder=6,
        gid="unidentified",
    )
    for u in unidentified:
        draw.label(ax, u.xy, f"{u.id} {u.belief:.2f}", VERMILION, offset=(6, 6), gid="unidentified-label")
    draw.robots(ax, run)
    n_landmark_lines = sum(ln.id in landmark_ids for ln in lines)
    title(
        ax,
        f"Fig. 7  Final line-corner map, {pose_span(run, None)}; line width by belief Bel(real)",
        f"{len(lines)} lines ({n_landmark_lines} reinforced), {len(corners)} corners "
        f"({sum(c.id in landmark_ids for c in corners)} reinforced), {len(unidentified)} unidentified objects; "
        f"{run.config.rule} rule",
    )
    finish(
        fig,
        [
            *draw.wall_handles(run),
            Line2D([], [], lw=3, color=BLUE, label="landmark line (reinforced)"),
            Line2D([], [], lw=3, color=FAINT, label="line not reinforced"),
            *[
                Line2D([], [], lw=float(draw.belief_width(b)), color=BLACK, label=f"Bel(real) = {b:g}")
                for b in (0.5, 0.8, 0.95)
            ],
            Line2D([], [], ls="", marker="o", ms=8, mfc=BLUE, mec="white", label="landmark corner"),
            Line2D([], [], ls="", marker="o", ms=5, mfc=FAINT, mec="white", label="corner"),
            Line2D([], [], ls="", marker="X", ms=9, color=VERMILION, label="unidentified object (sonar only)"),
        ],
    )
    return fig
