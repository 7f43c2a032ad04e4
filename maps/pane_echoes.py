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
is heard over the readings around its own normal. A multiple reflection comes back at the range of a wall's
line, square to it, in a gap of it, only by chance: its path is longer than the perpendicular.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from evmap.maps.simulated_sonar import SonarCheck, in_sight
from evmap.sources.config_model import Config
from evmap.sources.geometry import perpendicular_feet, point_segment_distances
from evmap.sources.rcd import TYPE_IV
from evmap.sources.sim.sonar import echo_halfwidth

__all__ = ["MIN_LINE", "MIN_READINGS", "pane_echoes"]

MIN_READINGS = 2
"""The fewest readings of a run taken for a pane's echo: one reading tells no constant depth (at seed 22 of the
generated worlds, a single reading off a wall's corner at a wall line's distance made an object 0.47 m from every
surface)."""

MIN_LINE = 0.2
"""The shortest believed line (m) a pane is taken in line with: the direction of a few centimetres of wall (a
jamb's stub, a corner's chamfer) is too loosely known to carry on a metre or two (at seeds 26 27 of the generated
worlds, 30 each, of the 16 pane echoes in line with shorter lines only 2 lay on glass, 12 beside a wall or a chair's
leg and 2 in the open; of the 10 in line with longer ones, 9 on glass)."""


def pane_echoes(
    check: SonarCheck, believed: NDArray[np.bool_], pose: NDArray[np.float64], config: Config
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The runs of ``check.runs`` that are panes' echoes (module doc), and each one's place: the foot of the
    perpendicular on the line whose distance is nearest the run's range.

    ``believed``: which of ``check.surfaces``' segments are believed lines.

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
    if params.pane_in_line <= 0 or not believed.any():
        return none
    wide = np.isin(runs.start, check.actual.start)
    matched = np.isin(runs.start, check.actual.start[check.matched[0]])
    echo = runs.range < check.predicted_scan.params.max_range - config.rcd.range_tolerance
    which = np.flatnonzero(echo & (matched | ~wide | (runs.type == TYPE_IV)) & (runs.count >= MIN_READINGS))
    if not len(which):
        return none
    p, q = s.p[believed], s.q[believed]
    _, foot = perpendicular_feet(pose[:2], p, q)  # (L, 2): on the lines, extended
    away = foot - pose[:2]
    distance = np.hypot(away[:, 0], away[:, 1])
    gap = point_segment_distances(foot[:, None], p, q).min(axis=1) > params.explained_distance
    bearing = np.arctan2(away[:, 1], away[:, 0])
    off = np.angle(np.exp(1j * (bearing - runs.direction[which, None])))  # (R, L): signed, from each run's middle
    miss = np.abs(distance - runs.range[which, None])
    wall = np.hypot(*(q - p).T) >= MIN_LINE
    fits = (miss <= params.pane_in_line) & _normal_fits(check, which, off, config) & gap & wall & (distance > 0)
    line = np.argmin(np.where(fits, miss, np.inf), axis=1)
    ok = fits.any(axis=1)
    which, line = which[ok], line[ok]
    heard = _predicted_ranges(check, bearing[line])
    ok = np.abs(heard - runs.range[which]) > config.matching.range_gate
    which, line = which[ok], line[ok]
    ok = ~matched[which]  # a run the matching gave to the map: only where the map does not predict its readings
    ok[~ok] = _unpredicted(check, which[~ok], config) > MIN_READINGS
    which, line = which[ok], line[ok]
    ok = in_sight(s, pose, runs, which, config)
    return which[ok], foot[line[ok]]


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
    runs = check.runs
    count = runs.count[which]
    run = np.repeat(np.arange(len(which)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)  # each reading's place in its run
    step = runs.width[which] / np.maximum(count, 1)
    axis = runs.direction[which][run] + (k - (count[run] - 1) / 2) * step[run]
    off = np.abs(_predicted_ranges(check, axis) - runs.range[which][run]) > config.matching.range_gate
    return np.bincount(run, weights=off, minlength=len(which)).astype(np.intp)


def _predicted_ranges(check: SonarCheck, bearings: NDArray[np.float64]) -> NDArray[np.float64]:
    """The range of the map's predicted reading nearest each bearing (rad)."""
    angles = check.predicted_scan.angles
    if not len(angles):
        return np.full(len(bearings), np.inf)
    nearest = np.argmin(np.abs(np.angle(np.exp(1j * (bearings[:, None] - angles[None])))), axis=1)
    return check.predicted_scan.ranges[nearest]
