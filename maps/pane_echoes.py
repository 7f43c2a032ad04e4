"""Panes in line with a believed wall, heard at normal incidence, where the paper's rule makes no object.

The paper makes an unidentified object of an unmatched actual RCD of Type I-III at least
``rcd.min_width_deg`` wide (:mod:`evmap.maps.unidentified`). A glass pane in a wall, heard square, often
gives none: a nearer target beside the beam (a jamb, a chair, a pillar) makes its run of readings Type IV
(a range jump to a neighbour) or cuts it narrower than that (the sonar reports the first echo); or the
matching gives its RCD to the map's prediction of the wall's end beside the pane, heard at almost the same
range a few degrees off (the wall ends there in the map, not in the world: the glass goes on). With
``unidentified.pane_in_line``, such a run (of :data:`MIN_READINGS` readings or more) is a pane's echo when a
pane in line with a believed line (at least :data:`MIN_LINE` long) would give it: its range is within that of
the pose's perpendicular distance to the line (extended), the foot of the perpendicular lies within the run's
arc (or, for a Type IV run, beyond its edge on the side of the nearer neighbour, every reading of the run
within a wall's detection half-width of the normal: the readings square to the pane heard the nearer target
first) and in a gap of the believed lines (farther than ``unidentified.explained_distance`` from each), the
scan the map predicts does not hear that range there (the nearest predicted reading to the foot's bearing is
off by more than ``matching.range_gate``), and its arc is in sight
(:func:`~evmap.maps.simulated_sonar.in_sight`). A run the matching gave to the map's prediction must moreover
hold more than :data:`MIN_READINGS` readings the predicted scan does not hear at its range: a doorway's jamb
is heard a reading further than the map predicts it (the edges of a predicted and an actual echo differ by
that much), and made an object in the doorway at seed 22 of the generated worlds; a pane beside the wall's end
is heard over the readings around its own normal. Where the map's echo of that wall end reaches the foot's
bearing (the end a few degrees off the normal, within the beam's width), more than :data:`MIN_READINGS` of
those readings must lie beyond the normal, on the far side from the middle of the predicted RCD the run was
matched to: the end's echo fades away from the end, a pane heard square echoes on both sides of its normal
(at seeds 28 29 of the generated worlds, `threshold`, the glass heard square and explained went from 0.852 to
0.888, the spurious objects from 0.015 to 0.009). A multiple reflection comes back at the range of a wall's
line, square to it, in a gap of it, only by chance: its path is longer than the perpendicular.

Where no believed line is in line with the run (a facade of panes between mullions, a window between two short
pieces of wall the stripe saw but no line holds yet), the pose's own stripe points may frame the pane
(:func:`_framed`): a line square to a normal the run allows, at the run's range, on which the stripe measured a
frame on each side of the foot (two points or more lying along the line within :data:`FRAME` of the pane's
edge: a wall crossing the line gives points across it) at most the free space's ``bridge`` (2.5 m) apart, no
stripe point on the line between them nor within ``unidentified.explained_distance`` of the foot (the stripe
goes through glass), the foot in a gap of the believed lines. The same tests as above follow. A double bounce
placed square to a line that the stripe measured on both sides of it, at its distance, is again a coincidence;
a frame on one side only is not enough (tried: at seeds 28-31 of the generated worlds it took the spurious
objects from 0.02 to 0.07).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from evmap.maps.free_space import FreeSpaceParams
from evmap.maps.simulated_sonar import SonarCheck, in_sight
from evmap.sources.config_model import Config
from evmap.sources.geometry import nearest_angles, perpendicular_feet, point_segment_distances, wrapped
from evmap.sources.rcd import TYPE_IV
from evmap.sources.sim.sonar import echo_halfwidth

__all__ = ["FRAME", "FRAME_POINTS", "FRAME_SLOPE", "MIN_LINE", "MIN_READINGS", "NORMAL_STEP", "pane_echoes"]

MIN_READINGS = 2
"""The fewest readings of a run taken for a pane's echo: one reading tells no constant depth (at seed 22 of the
generated worlds, a single reading off a wall's corner at a wall line's distance made an object 0.47 m from every
surface)."""

MIN_LINE = 0.2
"""The shortest believed line (m) a pane is taken in line with: the direction of a few centimetres of wall (a
jamb's stub, a corner's chamfer) is too loosely known to carry on a metre or two (at seeds 26 27 of the generated
worlds, 30 each, of the 16 pane echoes in line with shorter lines only 2 lay on glass, 12 beside a wall or a chair's
leg and 2 in the open; of the 10 in line with longer ones, 9 on glass)."""

NORMAL_STEP = np.radians(0.25)
"""The step (rad) of the normals tried for a pane between frames."""

SLACK = 1e-6
"""Round-off (rad) allowed when the stripe points that may lie on a line tried are picked before it is tried."""

FRAME = 0.3
"""How far (m) beyond a pane's edge the stripe points of its frame are looked for."""

FRAME_POINTS = 2
"""The fewest stripe points a frame holds: one point could be any surface the line crosses."""

FRAME_SLOPE = float(np.tan(np.radians(15.0)))
"""A frame's points lie along the pane's line: their depth from it changes by at most this share of their spread
along it (a wall crossing the line gives points across it: at seeds 28 29 of the generated worlds, `threshold`,
without this test 5 objects lay 0.36-0.71 m off glass, framed by walls crossing their lines; with it, one, 0.35 m
off)."""


def pane_echoes(
    check: SonarCheck,
    believed: NDArray[np.bool_],
    pose: NDArray[np.float64],
    config: Config,
    stripe: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The runs of ``check.runs`` that are panes' echoes (module doc), and each one's place: the foot of the
    perpendicular on the line whose distance is nearest the run's range, or on the pane's line between its frames.

    ``believed``: which of ``check.surfaces``' segments are believed lines; ``stripe``: the pose's stripe points
    (K, 2), where the pose has any.

    >>> from evmap.maps.simulated_sonar import check_sonar
    >>> from evmap.maps.belief_map import new_map
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.params import SonarParams
    >>> from evmap.sources.rcd import extract_rcds
    >>> from evmap.sources.readings import SonarScan
    >>> config = load_config("default")
    >>> bm = new_map(config)  # a wall y = 2 from x = -3 to -0.6 and from 0.6 to 3: a gap, a pane in it
    >>> for i, ends in enumerate([((-3, 2), (-0.6, 2)), ((0.6, 2), (3, 2))]):
    ...     for end, xy in zip("ab", ends):
    ...         bm.add_point(f"E{i}{end}", xy, "endpoint", bm.vacuous())
    ...     bm.add_line(f"L{i}", f"E{i}a", f"E{i}b", bm.vacuous())
    >>> angles = np.radians(np.arange(0.0, 360.0))
    >>> ranges = np.full(360, 10.0)
    >>> ranges[87:94] = 2.0  # the pane heard square over 7 deg: narrower than an RCD
    >>> ranges[[86, 94]] = 1.5  # something nearer at both edges of the beam
    >>> scan = SonarScan.from_readings(angles, ranges, SonarParams(), pose=(0.0, 0.0, 0.0))
    >>> check = check_sonar(bm, scan, extract_rcds(scan, config.rcd, primitive=True), config)
    >>> runs, places = pane_echoes(check, np.ones(2, dtype=bool), np.zeros(3), config)
    >>> check.runs.count[runs].tolist(), places.round(3).tolist()
    ([7], [[0.0, 2.0]])
    """
    runs, s, params = check.runs, check.surfaces, config.unidentified
    none = np.zeros(0, dtype=np.intp), np.zeros((0, 2))
    if params.pane_in_line <= 0:
        return none
    wide = np.isin(runs.start, check.actual.start)
    matched = np.isin(runs.start, check.actual.start[check.matched[0]])
    echo = runs.range < check.predicted_scan.params.max_range - config.rcd.range_tolerance
    which = np.flatnonzero(echo & (matched | ~wide | (runs.type == TYPE_IV)) & (runs.count >= MIN_READINGS))
    ok = ~matched[which]  # a run the matching gave to the map: only where the map does not predict its readings
    ok[~ok] = _unpredicted(check, which[~ok], config) > MIN_READINGS
    which = which[ok]
    p, q = s.p[believed], s.q[believed]
    ok, place, normal = _in_line(check, which, p, q, pose, config)
    sighted = np.zeros(len(which), dtype=bool)  # found in sight already
    if stripe is not None and not ok.all():
        rest = np.flatnonzero(~ok)
        rest = rest[in_sight(s, pose, runs, which[rest], config)]  # the cheaper test first
        found, at, towards = _framed(check, which[rest], pose, stripe, config)
        if len(p):  # in a gap of the believed lines
            found &= point_segment_distances(at[:, None], p, q).min(axis=1) > params.explained_distance
        rest = rest[found]
        ok[rest], sighted[rest], place[rest], normal[rest] = True, True, at[found], towards[found]
    which, place, normal, sighted = which[ok], place[ok], normal[ok], sighted[ok]
    ok = np.abs(_predicted_ranges(check, normal) - runs.range[which]) > config.matching.range_gate
    beside = np.flatnonzero(~ok & matched[which])
    ok[beside] = _beyond_normal(check, which[beside], normal[beside], config) > MIN_READINGS
    which, place, ok = which[ok], place[ok], sighted[ok]
    ok[~ok] = in_sight(s, pose, runs, which[~ok], config)
    return which[ok], place[ok]


def _in_line(
    check: SonarCheck,
    which: NDArray[np.intp],
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    pose: NDArray[np.float64],
    config: Config,
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """For each run of ``which``: whether a pane in line with a believed line p-q would give it (module doc), the
    foot of the pose's perpendicular on the line whose distance is nearest the run's range, and its bearing."""
    runs, params = check.runs, config.unidentified
    ok, place, normal = np.zeros(len(which), dtype=bool), np.zeros((len(which), 2)), np.zeros(len(which))
    if not len(which) or not len(p):
        return ok, place, normal
    _, foot = perpendicular_feet(pose[:2], p, q)  # (L, 2): on the lines, extended
    away = foot - pose[:2]
    distance = np.hypot(away[:, 0], away[:, 1])
    gap = point_segment_distances(foot[:, None], p, q).min(axis=1) > params.explained_distance
    bearing = np.arctan2(away[:, 1], away[:, 0])
    off = wrapped(bearing - runs.direction[which, None])  # (R, L): signed, from each run's middle
    miss = np.abs(distance - runs.range[which, None])
    wall = np.hypot(*(q - p).T) >= MIN_LINE
    fits = (miss <= params.pane_in_line) & _normal_fits(check, which, off, config) & gap & wall & (distance > 0)
    line = np.argmin(np.where(fits, miss, np.inf), axis=1)
    return fits.any(axis=1), foot[line], bearing[line]


def _framed(
    check: SonarCheck, which: NDArray[np.intp], pose: NDArray[np.float64], stripe: NDArray[np.float64], config: Config
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """For each run of ``which``: whether a pane between two frames of stripe points would give it (module doc),
    the foot of the pose's perpendicular on the pane's line, and its bearing.

    The normals tried are those :func:`_normal_fits` allows, every :data:`NORMAL_STEP`, nearest the run's
    middle first; the first whose line, square to it at the run's range, has a frame on each side of the foot
    (:func:`_frame`) at most the free space's ``bridge`` apart, no stripe point on the line between them nor within
    ``unidentified.explained_distance`` of the foot, is taken.
    """
    runs, tol, gap = check.runs, config.unidentified.pane_in_line, config.unidentified.explained_distance
    span = FreeSpaceParams().bridge
    ok, place, normal = np.zeros(len(which), dtype=bool), np.zeros((len(which), 2)), np.zeros(len(which))
    rel = stripe - pose[:2]
    far = np.maximum(np.hypot(rel[:, 0], rel[:, 1]), np.finfo(float).tiny)
    towards = np.arctan2(rel[:, 1], rel[:, 0])
    half = np.maximum(echo_halfwidth(np.ones(len(which)), runs.range[which], check.predicted_scan.params), 0.0)
    for n, j in enumerate(which):
        r, reach = runs.range[j], runs.width[j] / 2 + half[n]
        offs = np.arange(-reach, reach + NORMAL_STEP / 2, NORMAL_STEP)
        offs = offs[np.argsort(np.abs(offs), kind="stable")]
        offs = offs[_normal_fits(check, which[n : n + 1], offs[None], config)[0]]
        if not len(offs):
            continue
        # the points on one of the lines tried (depth within tol: at a bearing off the normal between a_lo and
        # a_hi), within the span and a frame of its foot
        a_lo = np.arccos(np.clip((r + tol) / far, -1.0, 1.0))
        a_hi = np.arccos(np.clip((r - tol) / far, -1.0, 1.0))
        d = wrapped(towards - runs.direction[j])
        lo, hi = offs.min() - SLACK, offs.max() + SLACK
        near = ((d - a_hi <= hi) & (d - a_lo >= lo)) | ((d + a_lo <= hi) & (d + a_hi >= lo))
        near &= (far >= r - tol) & (far <= np.hypot(r + tol, span + FRAME))
        if near.sum() < 2 * FRAME_POINTS:
            continue
        phi = runs.direction[j] + offs  # (G,)
        u = np.stack([np.cos(phi), np.sin(phi)])  # (2, G)
        depth = rel[near] @ u - r  # (K, G): from the line, away from the pose positive
        on = np.abs(depth) <= tol
        side = rel[near] @ np.stack([-u[1], u[0]])  # along the line, from the foot
        left = np.where(on & (side < 0), side, -np.inf).max(axis=0)
        right = np.where(on & (side > 0), side, np.inf).min(axis=0)
        framed = (right - left <= span) & (np.minimum(-left, right) > gap)  # the foot on glass
        framed &= _frame(side, depth, on, left, -1) & _frame(side, depth, on, right, 1)
        if framed.any():
            g = int(np.argmax(framed))
            ok[n], place[n], normal[n] = True, pose[:2] + r * u[:, g], phi[g]
    return ok, place, normal


def _frame(
    side: NDArray[np.float64], depth: NDArray[np.float64], on: NDArray[np.bool_], edge: NDArray[np.float64], sign: int
) -> NDArray[np.bool_]:
    """For each line tried (the columns of the (K, G) ``side`` and ``depth`` of the points, ``on`` it or not):
    whether its points from ``edge`` (G,) outward (``sign``: -1 toward negative ``side``), at most :data:`FRAME` m,
    are a frame: :data:`FRAME_POINTS` or more, lying along the line (their depth changes by at most
    :data:`FRAME_SLOPE` of their spread along it: the slope of their least-squares line)."""
    with np.errstate(invalid="ignore"):
        out = sign * (side - edge)
        near = on & (out >= 0) & (out <= FRAME)
    count = near.sum(axis=0)
    s, d = np.where(near, side, 0.0), np.where(near, depth, 0.0)
    mean = s.sum(axis=0) / np.maximum(count, 1)
    spread = (s * s).sum(axis=0) - count * mean**2  # sum of (s - mean)^2 over the frame's points
    tilt = (s * d).sum(axis=0) - mean * d.sum(axis=0)  # sum of (s - mean)(d - mean d)
    return (count >= FRAME_POINTS) & (spread > 0) & (np.abs(tilt) <= FRAME_SLOPE * spread)


def _normal_fits(
    check: SonarCheck, which: NDArray[np.intp], off: NDArray[np.float64], config: Config
) -> NDArray[np.bool_]:
    """Whether a pane whose normal lies ``off`` (R, L; rad, signed) from the middle of each run of ``which`` could
    have given it: the normal within the run's arc; or, for a Type IV run, beyond its edge on the side of a
    neighbour nearer by more than the jump threshold (the readings square to the pane heard that nearer target
    first), with every reading of the run within a wall's detection half-width of the normal
    (:func:`~evmap.sources.sim.sonar.echo_halfwidth`)."""
    runs = check.runs
    width, r = runs.width[which], runs.range[which]
    fits = np.abs(off) <= width[:, None] / 2
    step = width / np.maximum(runs.count[which], 1)
    half = echo_halfwidth(np.ones(len(which)), r, check.predicted_scan.params)
    reach = (half - (width - step) / 2)[:, None]  # the first and last readings' beam axes within ``half``
    jump = runs.type[which] == TYPE_IV
    low = (jump & (runs.prev_range[which] < r - config.rcd.jump_threshold))[:, None]  # the readings before it
    high = (jump & (runs.next_range[which] < r - config.rcd.jump_threshold))[:, None]
    return fits | (low & (off < 0) & (-off <= reach)) | (high & (off > 0) & (off <= reach))


def _unpredicted(check: SonarCheck, which: NDArray[np.intp], config: Config) -> NDArray[np.intp]:
    """How many readings of each run of ``which`` the scan the map predicts does not hear at the run's range (the
    nearest predicted reading to the reading's beam axis off by more than ``matching.range_gate``)."""
    run, _, off = _readings(check, which, config)
    return np.bincount(run, weights=off, minlength=len(which)).astype(np.intp)


def _beyond_normal(
    check: SonarCheck, which: NDArray[np.intp], normal: NDArray[np.float64], config: Config
) -> NDArray[np.intp]:
    """How many readings of each run of ``which`` (each matched to a predicted RCD) the map's scan does not hear
    at the run's range on the far side of the pane's ``normal`` from the middle of that predicted RCD: the
    map's echo of a wall end beside the pane reaches the normal by the beam's width, a pane heard square
    echoes on both sides of it."""
    # the predicted RCD matched to each actual one, by the actual RCD's first reading
    partner = dict(zip(check.actual.start[check.matched[0]].tolist(), check.matched[1].tolist(), strict=True))
    middle = check.predicted.direction[[partner[start] for start in check.runs.start[which].tolist()]]
    side = np.sign(wrapped(middle - normal))
    run, axis, off = _readings(check, which, config)
    beyond = np.sign(wrapped(axis - normal[run])) == -side[run]
    return np.bincount(run, weights=off & beyond, minlength=len(which)).astype(np.intp)


def _readings(
    check: SonarCheck, which: NDArray[np.intp], config: Config
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.bool_]]:
    """Every reading of the runs of ``which``: its run (index into ``which``), its beam axis (rad), and whether the
    scan the map predicts does not hear it at its run's range (the nearest predicted reading to its axis off by
    more than ``matching.range_gate``)."""
    runs = check.runs
    count = runs.count[which]
    run = np.repeat(np.arange(len(which)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)  # each reading's place in its run
    step = runs.width[which] / np.maximum(count, 1)
    axis = runs.direction[which][run] + (k - (count[run] - 1) / 2) * step[run]
    off = np.abs(_predicted_ranges(check, axis) - runs.range[which][run]) > config.matching.range_gate
    return run, axis, off


def _predicted_ranges(check: SonarCheck, bearings: NDArray[np.float64]) -> NDArray[np.float64]:
    """The range of the map's predicted reading nearest each bearing (rad)."""
    angles = check.predicted_scan.angles
    if not len(angles):
        return np.full(len(bearings), np.inf)
    return check.predicted_scan.ranges[nearest_angles(angles, bearings)]
