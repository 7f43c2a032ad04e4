"""The evidential occupancy grid of a belief map, and its ROS map_server export.

Each cell of the grid holds a mass function over the frame {free, occupied}
(:data:`GRID_FRAME`), as an array row ``[m(∅), m(free), m(occupied), m(free|occupied)]``
(column = focal-set bitmask, as in :func:`evidential.combine_batch`). Two sources
of evidence are combined in every cell by the map's rule:

- **free**: a cell whose centre lies in the map's free space (:mod:`evmap.maps.free_space`:
  sonar sectors and contour rays of every pose, ending at the believed lines) gets
  ``m(free) = free_mass``, the rest on ``free|occupied``; other cells are vacuous;
- **occupied**: a cell crossed by a line, or holding a corner or an unidentified
  object, gets ``m(occupied) = occupied_mass * Bel(real)`` of the strongest such
  object, the rest on ``free|occupied``; other cells are vacuous. The strongest
  object, not a combination of all of them: a corner and the two lines that meet
  there are one piece of evidence about the cell, not three.

A cell holding a believed object (``Bel(real) >= believed``) takes no free evidence: the free space
reaches up to the surface, so a cell the surface crosses has free space in it too (its centre a
centimetre on the free side), but a robot cannot pass through the cell; combined, the two would read
neither free nor occupied (a wall of belief 0.6 gave 41, unknown in the ROS map, where a planner may go).

The ``int8`` grid follows the ROS ``nav_msgs/OccupancyGrid`` convention: row 0 is
the lowest y, column 0 the lowest x, ``origin`` is the lower-left corner of cell
(0, 0); a value is ``round(100 * BetP(occupied))`` (pignistic probability), or
-1 (unknown) where the ignorance ``m(free|occupied)`` is above
``ignorance_threshold`` (0.5 by default: ignorance outweighs all the rest).
A planner that cannot treat -1 asks for unknown cells as blocked (100) or
free (0) with ``OccupancyParams(unknown=...)``, as
:func:`evmap.maps.planner.is_segment_clear` takes ``unknown="blocked"`` or ``"free"``.

:func:`write_ros_map` writes the PGM + YAML pair exactly as ROS 1's
``map_saver`` does (trinary: 254 free, 0 occupied, 205 unknown; PGM top row =
highest y), so ``map_server`` and nav2 load it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np
import shapely
import yaml
from numpy.typing import ArrayLike, NDArray
from pydantic import BaseModel, ConfigDict, Field

from evidential import Frame, combine_batch
from evmap.maps.atomic_file import write_atomic
from evmap.maps.free_space import free_space
from evmap.maps.planner import is_number, state
from evmap.maps.sensed import sensed

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = [
    "FREE_MAX",
    "GRID_FRAME",
    "OCCUPIED_MIN",
    "OccupancyParams",
    "evidential_grid",
    "grid_bounds",
    "grid_geometry",
    "occupancy_from_masses",
    "occupancy_grid",
    "occupancy_masses",
    "polygon_cells",
    "save_ros_map",
    "segment_cells",
    "write_ros_map",
]

GRID_FRAME = Frame(["free", "occupied"])
"""The frame of every cell: {free, occupied}; mass array columns ∅, free, occupied, free|occupied."""

FREE_MAX = 25
"""Grid values 0..FREE_MAX are written as free (254) in the PGM, as ROS 1 ``map_saver`` does."""

OCCUPIED_MIN = 65
"""Grid values OCCUPIED_MIN..100 are written as occupied (0); all others as unknown (205)."""

_FREE, _OCCUPIED, _EITHER = 1, 2, 3
_UNKNOWN_VALUE = {"unknown": -1, "blocked": 100, "free": 0}


class OccupancyParams(BaseModel):
    """Constants of the evidence that the occupancy grid is built from."""

    model_config = ConfigDict(defer_build=True, extra="forbid", frozen=True)

    free_mass: float = Field(0.7, ge=0, lt=1, description="m(free) of a cell whose centre lies in the sonar open space")
    occupied_mass: float = Field(
        1.0, ge=0, le=1, description="m(occupied) of a cell holding an object of belief 1; scaled by Bel(real)"
    )
    ignorance_threshold: float = Field(
        0.5, ge=0, le=1, description="a cell is unknown (-1) where m(free|occupied) is above this"
    )
    padding: float = Field(0.25, gt=0, le=100, description="margin of unknown cells around the map (m)")
    unknown: Literal["unknown", "blocked", "free"] = Field(
        "unknown",
        description="what an unknown cell holds: -1 (unknown, as ROS expects), 100 (blocked, for a planner that "
        "must stay where the map has seen) or 0 (free, for one that explores)",
    )
    max_cells: int = Field(50_000_000, ge=1, description="largest grid (cells) built; guards against memory blow-up")
    believed: float = Field(
        0.5, ge=0, le=1, description="a cell holding an object of at least this Bel(real) takes no free evidence"
    )


def _checked(params: OccupancyParams | None) -> OccupancyParams:
    """``params``, or the defaults for None; anything else is a TypeError (a dict had no attribute 'padding')."""
    if params is None:
        return OccupancyParams()
    if not isinstance(params, OccupancyParams):
        raise TypeError(f"params must be an OccupancyParams (or None), got {type(params).__name__}")
    return params


def grid_geometry(
    bounds: tuple[float, float, float, float], resolution: float, params: OccupancyParams
) -> tuple[tuple[float, float], tuple[int, int]]:
    """Origin (lower-left corner) and shape (rows, columns) of the grid covering ``bounds``.

    >>> grid_geometry((0.0, 0.0, 1.0, 0.5), 0.1, OccupancyParams(padding=0.1))
    ((-0.1, -0.1), (7, 12))
    """
    if not (is_number(resolution) and np.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a positive number of metres, got {resolution!r}")
    xmin, ymin, xmax, ymax = bounds
    origin = (xmin - params.padding, ymin - params.padding)
    shape = (  # one cell at least, however coarse the resolution
        max(1, int(np.ceil(round((ymax - ymin + 2 * params.padding) / resolution, 9)))),
        max(1, int(np.ceil(round((xmax - xmin + 2 * params.padding) / resolution, 9)))),
    )
    if shape[0] * shape[1] > params.max_cells:
        raise ValueError(
            f"resolution {resolution!r} gives a grid of {shape[0]} x {shape[1]} cells, "
            f"more than max_cells = {params.max_cells}; use a coarser resolution"
        )
    return origin, shape


def segment_cells(
    p: ArrayLike, q: ArrayLike, origin: tuple[float, float], resolution: float, shape: tuple[int, int]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Every grid cell that each segment crosses (exactly: the segment's supercover).

    A segment of zero length marks the cell that holds its point. A segment that
    only touches a cell's corner or runs along a cell border marks the cells on
    one side, not both.

    Returns
    -------
    (flat cell indices ``row * columns + column``, index of the segment), one entry
    per (segment, cell) pair.

    Examples
    --------
    >>> cells, seg = segment_cells([[0.05, 0.05], [0.25, 0.15]], [[0.35, 0.05], [0.25, 0.15]],
    ...                            (0.0, 0.0), 0.1, (3, 4))
    >>> cells.tolist(), seg.tolist()
    ([0, 1, 2, 3, 6], [0, 0, 0, 0, 1])
    """
    a = (np.asarray(p, dtype=float).reshape(-1, 2) - origin) / resolution
    b = (np.asarray(q, dtype=float).reshape(-1, 2) - origin) / resolution
    n = len(a)
    d = b - a
    # grid lines strictly between the ends, per axis: lo .. lo + count - 1
    lo = np.floor(np.minimum(a, b)) + 1
    count = np.maximum(np.ceil(np.maximum(a, b)) - lo, 0).astype(np.intp)
    seg_parts = [np.arange(n), np.arange(n)]
    t_parts = [np.zeros(n), np.ones(n)]
    for axis in (0, 1):
        k = count[:, axis]
        seg = np.repeat(np.arange(n), k)
        step = np.arange(len(seg)) - np.repeat(np.cumsum(k) - k, k)
        seg_parts.append(seg)
        t_parts.append((lo[seg, axis] + step - a[seg, axis]) / d[seg, axis])
    seg = np.concatenate(seg_parts)
    t = np.concatenate(t_parts)
    order = np.lexsort((t, seg))
    seg, t = seg[order], t[order]
    # one cell per non-empty interval between consecutive crossings (a point: t in [0, 1])
    keep = (seg[1:] == seg[:-1]) & (t[1:] > t[:-1])
    seg = seg[1:][keep]
    mid = a[seg] + 0.5 * (t[1:] + t[:-1])[keep, None] * d[seg]
    col = np.clip(np.floor(mid[:, 0]).astype(np.intp), 0, shape[1] - 1)
    row = np.clip(np.floor(mid[:, 1]).astype(np.intp), 0, shape[0] - 1)
    return row * shape[1] + col, seg


def polygon_cells(
    geometry: shapely.Geometry, origin: tuple[float, float], resolution: float, shape: tuple[int, int]
) -> NDArray[np.bool_]:
    """Boolean (rows, columns) mask of the cells whose centre lies in a (multi)polygon.

    A scanline fill over the rings' edges (even-odd rule, so holes are holes),
    vectorised with numpy; the geometry must be valid (disjoint parts).

    Examples
    --------
    >>> import shapely
    >>> polygon_cells(shapely.box(0.1, 0.0, 0.3, 0.2), (0.0, 0.0), 0.1, (3, 4)).astype(int).tolist()
    [[0, 1, 1, 0], [0, 1, 1, 0], [0, 0, 0, 0]]
    """
    rows, cols = shape
    rings = shapely.get_rings(shapely.get_parts(geometry))
    xy, ring = shapely.get_coordinates(rings, return_index=True)
    same = ring[1:] == ring[:-1]
    g = (xy - origin) / resolution - 0.5  # cell (r, c) has its centre at integer (c, r)
    p, q = g[:-1][same], g[1:][same]
    ylo, yhi = np.minimum(p[:, 1], q[:, 1]), np.maximum(p[:, 1], q[:, 1])
    first = np.clip(np.ceil(ylo), 0, rows).astype(np.intp)
    k = np.clip(np.ceil(yhi), 0, rows).astype(np.intp) - first  # rows with ylo <= r < yhi
    edge = np.repeat(np.arange(len(p)), k)
    row = first[edge] + np.arange(len(edge)) - np.repeat(np.cumsum(k) - k, k)
    x = p[edge, 0] + (row - p[edge, 1]) * (q[edge, 0] - p[edge, 0]) / (q[edge, 1] - p[edge, 1])
    order = np.lexsort((x, row))
    row, x = row[order], x[order]
    # crossings pair up along each row: inside between the 1st and 2nd, 3rd and 4th...
    start = np.clip(np.ceil(x[0::2]), 0, cols).astype(np.intp)
    stop = np.clip(np.ceil(x[1::2]), 0, cols).astype(np.intp)
    diff = np.zeros((rows, cols + 1), dtype=np.int32)
    np.add.at(diff, (row[0::2], start), 1)
    np.add.at(diff, (row[0::2], stop), -1)
    return np.cumsum(diff[:, :cols], axis=1) > 0


def evidential_grid(
    open_space: shapely.Geometry,
    p: ArrayLike,
    q: ArrayLike,
    belief: ArrayLike,
    bounds: tuple[float, float, float, float],
    resolution: float,
    rule: str,
    params: OccupancyParams | None = None,
) -> tuple[NDArray[np.float64], tuple[float, float]]:
    """Mass arrays of the evidential occupancy grid.

    Parameters
    ----------
    open_space : the sonar open space (a valid, possibly empty, (multi)polygon).
    p, q : (N, 2) end points of the occupying objects (a point object: p == q).
    belief : (N,) their belief Bel(real).
    bounds : (xmin, ymin, xmax, ymax) the grid must cover.
    resolution : cell side (m).
    rule : the combination rule of the two sources (a name of :data:`evidential.RULES`).
    params : the evidence constants; defaults when None.

    Returns
    -------
    masses : (rows, columns, 4) float array, column b = mass of focal set b over
        :data:`GRID_FRAME` (0 = ∅, 1 = free, 2 = occupied, 3 = free|occupied).
    origin : (x, y) of the lower-left corner of cell (0, 0).

    Notes
    -----
    Every cell's mass is ``combine(free evidence, occupied evidence, rule)``. A
    cell's two sources take few distinct values (free or not; the weight of one
    of the objects), so each distinct pair is combined once by
    :func:`evidential.combine_batch` and spread to its cells.

    Examples
    --------
    >>> import shapely
    >>> m, origin = evidential_grid(shapely.box(0, 0, 1, 1), [[0.5, 0.5]], [[0.5, 0.5]], [0.8],
    ...                             (0, 0, 1, 1), 0.5, "dempster", OccupancyParams(padding=0.5))
    >>> m.shape, origin
    ((4, 4, 4), (-0.5, -0.5))
    >>> m[0, 0].tolist(), m[1, 1].round(3).tolist(), m[2, 2].round(3).tolist()
    ([0.0, 0.0, 0.0, 1.0], [0.0, 0.7, 0.0, 0.3], [0.0, 0.0, 0.8, 0.2])
    """
    params = _checked(params)
    origin, shape = grid_geometry(bounds, resolution, params)
    p = np.asarray(p, dtype=float).reshape(-1, 2)
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    belief = np.asarray(belief, dtype=float).reshape(-1)
    weight = params.occupied_mass * belief
    free = polygon_cells(open_space, origin, resolution, shape).ravel()
    # the strongest object in each cell, as its rank among the distinct weights (rank 0: weight 0)
    values, rank = np.unique(np.concatenate([[0.0], weight]), return_inverse=True)
    occupied = np.zeros(free.size, dtype=np.intp)
    cells, seg = segment_cells(p, q, origin, resolution, shape)
    np.maximum.at(occupied, cells, rank[1:][seg])
    free[cells[belief[seg] >= params.believed]] = False  # a believed surface's cells: no free evidence
    # combine each (occupied weight, free?) pair once: pair code = 2 * rank + free
    m_free = np.zeros((2 * len(values), 4))
    m_free[1::2, _FREE] = params.free_mass
    m_free[:, _EITHER] = 1.0 - m_free[:, _FREE]
    m_occupied = np.zeros((2 * len(values), 4))
    m_occupied[:, _OCCUPIED] = np.repeat(values, 2)
    m_occupied[:, _EITHER] = 1.0 - m_occupied[:, _OCCUPIED]
    combined = np.asarray(combine_batch(m_free, m_occupied, rule=rule), dtype=float)
    return combined[2 * occupied + free].reshape(*shape, 4), origin


def occupancy_from_masses(masses: NDArray[np.float64], params: OccupancyParams | None = None) -> NDArray[np.int8]:
    """The ROS ``int8`` grid of the mass arrays: ``round(100 * BetP(occupied))``, or the unknown value.

    ``BetP(occupied) = (m(occupied) + m(free|occupied) / 2) / (1 - m(∅))``; a cell is
    unknown where ``m(free|occupied)`` is above ``params.ignorance_threshold``, or
    where all its mass is on the empty set. An unknown cell holds -1 (ROS's
    "unknown"; ``params.unknown="unknown"``, the default), 100 (``"blocked"``) or
    0 (``"free"``).

    >>> import numpy as np
    >>> masses = np.array([[[0, 0.7, 0, 0.3], [0, 0, 0.8, 0.2], [0, 0, 0.3, 0.7]]])
    >>> occupancy_from_masses(masses).tolist()
    [[15, 90, -1]]
    >>> occupancy_from_masses(masses, OccupancyParams(unknown="blocked")).tolist()
    [[15, 90, 100]]
    """
    params = _checked(params)
    normal = 1.0 - masses[..., 0]
    known = (masses[..., _EITHER] <= params.ignorance_threshold) & (normal > 0)
    betp = (masses[..., _OCCUPIED] + 0.5 * masses[..., _EITHER]) / np.where(known, normal, 1.0)
    return np.where(known, np.rint(100 * np.clip(betp, 0, 1)), _UNKNOWN_VALUE[params.unknown]).astype(np.int8)


def write_ros_map(
    grid: NDArray[np.int8], resolution: float, origin: tuple[float, float], path_stem: str | Path
) -> tuple[Path, Path]:
    """Write an occupancy grid as a ROS map_server pair ``STEM.pgm`` + ``STEM.yaml``.

    As ROS 1 ``map_saver`` writes it: a binary PGM (P5, maxval 255) whose top row
    is the grid's highest y; values 0..:data:`FREE_MAX` -> 254 (free),
    :data:`OCCUPIED_MIN`..100 -> 0 (occupied), all else (-1 included) -> 205
    (unknown); the YAML names the image relative to itself and gives
    ``resolution``, ``origin: [x, y, 0.0]``, ``negate: 0``,
    ``occupied_thresh: 0.65``, ``free_thresh: 0.196`` and ``mode: trinary``.

    Returns
    -------
    The paths of the PGM and the YAML file.
    """
    grid = np.asarray(grid)
    if grid.ndim != 2 or grid.size == 0:
        raise ValueError(f"grid must be a non-empty 2D array, got shape {grid.shape}")
    stem = Path(path_stem)
    pgm, meta = stem.with_name(stem.name + ".pgm"), stem.with_name(stem.name + ".yaml")
    pixels = np.full(grid.shape, 205, dtype=np.uint8)
    pixels[(grid >= 0) & (grid <= FREE_MAX)] = 254
    pixels[grid >= OCCUPIED_MIN] = 0
    header = f"P5\n# CREATOR: evmap {resolution:.3f} m/pix\n{grid.shape[1]} {grid.shape[0]}\n255\n"
    write_atomic(pgm, header.encode("ascii") + np.flipud(pixels).tobytes())
    info = {
        "image": pgm.name,
        "resolution": float(resolution),
        "origin": [float(origin[0]), float(origin[1]), 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
        "mode": "trinary",
    }
    write_atomic(meta, yaml.safe_dump(info, sort_keys=False, default_flow_style=None).encode("utf-8"))
    return pgm, meta


def occupancy_masses(
    bm: BeliefMap, resolution: float = 0.05, params: OccupancyParams | None = None
) -> tuple[NDArray[np.float64], tuple[float, float]]:
    """The evidential occupancy grid of a belief map: masses (rows, columns, 4) and origin (x, y).

    Columns of the last axis: m(∅), m(free), m(occupied), m(free|occupied);
    row 0 is the lowest y; ``origin`` is the lower-left corner of cell (0, 0).
    The grid spans the map's points, its free space and the places its poses sensed from.
    Free evidence from the map's free space (:func:`evmap.maps.free_space.free_space`), occupied evidence
    from every line,
    corner and unidentified object weighted by its belief, combined by the
    map's rule (see the module doc).
    """
    s = state(bm)
    solid = s.point_kind != "endpoint"
    xy = s.xy[solid]
    p = np.concatenate([s.p, xy])
    q = np.concatenate([s.q, xy])
    belief = np.concatenate([s.line_bel, s.point_bel[solid]])
    return evidential_grid(free_space(bm), p, q, belief, grid_bounds(bm), resolution, bm.rule, params)


def grid_bounds(bm: BeliefMap) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of what the map's grid spans: its points, its free space and its poses' places."""
    origins = np.array([place.origin for place in sensed(bm)], dtype=float).reshape(-1, 2)
    everything = np.concatenate([state(bm).xy, shapely.get_coordinates(free_space(bm)), origins])
    if not len(everything):
        raise ValueError("the map is empty (no points, no open space, no pose): an occupancy grid has no extent")
    return (*everything.min(axis=0), *everything.max(axis=0))


def occupancy_grid(bm: BeliefMap, resolution: float = 0.05, params: OccupancyParams | None = None) -> NDArray[np.int8]:
    """The ROS occupancy grid of a belief map (``int8``; see :func:`occupancy_from_masses`; row 0 = lowest y).

    Its origin is that of :func:`occupancy_masses` (the lower-left corner of the
    map's points and open space, less ``params.padding``).
    """
    masses, _ = occupancy_masses(bm, resolution, params)
    return occupancy_from_masses(masses, params)


def save_ros_map(
    bm: BeliefMap, path_stem: str | Path, resolution: float = 0.05, params: OccupancyParams | None = None
) -> tuple[Path, Path]:
    """Write the map's occupancy grid as ``STEM.pgm`` + ``STEM.yaml`` for ROS map_server (:func:`write_ros_map`)."""
    masses, origin = occupancy_masses(bm, resolution, params)
    return write_ros_map(occupancy_from_masses(masses, params), resolution, origin, path_stem)
