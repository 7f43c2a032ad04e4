"""Open space implied by the typed primitive RCDs of a scan (paper, section II.A).

A sonar reading is the first echo, so nothing lies closer within the sonic cone.
Each primitive RCD gives a sector from the sensor over its beam-axis angles, plus
half a step each side (``docs/METHOD.md``), whose radius is

- Type I: the RCD's shortest reading (the whole area of the RCD is open);
- Types II and III: the shorter neighbouring reading (the echo point may lie
  outside the RCD, or the RCD may be a multiple reflection);
- Type IV: no sector (a multiple reflection: nothing is guaranteed);

each shrunk by ``margin``. ``widen_by_half_beam`` widens every sector by half the
beam angle on each side (the "sonic cone"; off by default). The robot's own
footprint, a disc of ``footprint_radius``, is open space too. The union over
several poses is ``shapely.union_all`` of their open spaces.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from evmap.sources.params import OpenSpaceParams
from evmap.sources.rcd import TYPE_I, TYPE_IV, Rcds
from evmap.sources.readings import SonarScan

__all__ = ["GRID", "open_space", "unite"]

GRID = 1e-6
"""The micrometre grid (m) of :func:`unite`'s snap-rounding; the map's free space is snapped to it too."""


def unite(geometries: Sequence[shapely.Geometry]) -> shapely.Geometry:
    """The union of polygons (``shapely.union_all``); where GEOS's floating overlay cannot node edges that nearly
    touch ("found non-noded intersection"), the union by its snap-rounding on the grid :data:`GRID`, which can.

    >>> unite([shapely.box(0, 0, 1, 1), shapely.box(1, 0, 2, 1)]).area
    2.0
    """
    try:
        return shapely.union_all(geometries)
    except shapely.errors.GEOSException:
        return shapely.union_all(geometries, grid_size=GRID)


def _sector(center: np.ndarray, radius: float, a0: float, a1: float, arc_step: float) -> shapely.Polygon:
    """The sector from angle a0 to a1 (rad, a0 < a1); a full disc if it spans a full turn."""
    full = a1 - a0 >= 2 * np.pi
    if full:
        a1 = a0 + 2 * np.pi
    t = np.linspace(a0, a1, int(np.ceil((a1 - a0) / arc_step)) + 1)
    arc = center + radius * np.column_stack([np.cos(t), np.sin(t)])
    return shapely.Polygon(arc if full else np.vstack([center, arc]))


def open_space(scan: SonarScan, rcds: Rcds, params: OpenSpaceParams) -> shapely.Polygon | shapely.MultiPolygon:
    """The open space of one scan: the union of its RCD sectors and the robot's footprint.

    Parameters
    ----------
    scan : the scan the RCDs come from (its pose and beam-axis angles).
    rcds : its *primitive* RCDs (``extract_rcds(scan, ..., primitive=True)``).
    params : margin, widening, footprint radius and arc resolution.

    Returns
    -------
    A shapely (Multi)Polygon in world coordinates; it contains the sensor position
    whenever ``footprint_radius > 0``. Empty when there is nothing open.

    Examples
    --------
    A wall 1 m ahead seen as a Type I RCD over 25 deg, nothing else returning:

    >>> from evmap.sources.params import RcdParams, SonarParams
    >>> from evmap.sources.rcd import extract_rcds
    >>> ranges = np.full(360, 10.0)
    >>> ranges[np.r_[348:360, 0:13]] = 1.0
    >>> scan = SonarScan.from_readings(np.radians(np.arange(360.0)), ranges, SonarParams())
    >>> area = open_space(scan, extract_rcds(scan, RcdParams(), primitive=True), OpenSpaceParams())
    >>> round(area.area, 3)  # pi 0.97^2 (25/360) + the part of the 0.2 m footprint outside the sector
    0.322
    """
    center = scan.pose[:2]
    half = scan.step / 2 + (np.radians(scan.params.beam_width_deg) / 2 if params.widen_by_half_beam else 0.0)
    arc_step = np.radians(params.arc_step_deg)
    shorter = np.fmin(rcds.prev_range, rcds.next_range)
    radius = np.where(rcds.type == TYPE_I, rcds.min_range, shorter) - params.margin
    pieces = []
    for k in np.flatnonzero((rcds.type != TYPE_IV) & (radius > 0)):
        a0 = scan.angles[rcds.start[k]] - half
        pieces.append(_sector(center, float(radius[k]), a0, a0 + rcds.width[k] - scan.step + 2 * half, arc_step))
    if params.footprint_radius > 0:
        pieces.append(_sector(center, params.footprint_radius, 0.0, 2 * np.pi, arc_step))
    if not pieces:
        return shapely.Polygon()
    return unite(pieces)
