"""What the sensors give the pipeline: a rotational sonar scan, the LSL stripe and its line segments.

These are the readings of the sensors, whether simulated (:mod:`evmap.sources.sim`)
or measured: the evidence side and the map read them, never the world they came from.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.params import SonarParams

__all__ = [
    "MAX_COORDINATE",
    "OVER_RANGE",
    "TRUTHS",
    "LslSegments",
    "ScanError",
    "SonarScan",
    "StripeScan",
    "concat_segments",
]

MAX_COORDINATE = 2e7
"""Largest distance (m) of a reading's, a pose's or a map's coordinates from the origin (float64 resolves 4 nm
there): twice a scenario's (:data:`evmap.sources.sim.spec.MAX_COORDINATE`), so that what a world at its limit
measures (the readings' noise) and maps (echoes placed up to the sonar's range beyond the walls) stays within it."""

OVER_RANGE = 1.5
"""A reading above max_range by up to this factor is clipped to it (noise, timing); beyond it, refused."""

TRUTHS = ("real", "noise", "")
"""A segment's ground truth: ``real``, ``noise`` (simulated data), ``""`` unknown (measured data)."""


def _readonly(a: NDArray[Any]) -> NDArray[Any]:
    a.setflags(write=False)
    return a


class ScanError(ValueError):
    """Readings, angles or a pose that no sonar scan can have; the message names the array and index."""


def _readonly(a: NDArray[Any]) -> NDArray[Any]:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class SonarScan:
    """One rotational sonar scan: a reading per beam-axis angle, with ground-truth labels.

    Attributes
    ----------
    pose : (3,) float: sensor x, y (m) and heading (rad) in world coordinates.
    angles : (M,) float: world-frame beam-axis angle of each reading (rad), strictly
        increasing and spanning less than a full turn (they need not be wrapped).
    ranges : (M,) float: range of each reading (m), in ``[0, params.max_range]``.
    target : (M,) str: id of the object that made the reading (a segment, vertex or
        cylinder id; for a multiple reflection the first wall); ``""`` for none or unknown.
    order : (M,) int: reflection order: 0 no echo (max range), 1 direct, 2 double
        bounce, -1 unknown (measured data).
    params : the sensor's :class:`~evmap.sources.params.SonarParams`.

    Construction validates the arrays (the one place where raw readings are
    checked): a NaN or negative range, a non-finite angle, duplicate or unordered
    angles, angles spanning a full turn or more, or arrays of different lengths
    raise :class:`ScanError` naming the array and index. A range beyond
    ``max_range`` is set to ``max_range`` (the timing circuit reports nothing longer),
    and one beyond :data:`OVER_RANGE` times it is refused (a reading in millimetres, say).
    The arrays are stored read-only.

    Examples
    --------
    >>> scan = SonarScan.from_readings([0.0, 0.1, 0.2], [1.0, 1.0, 11.0], SonarParams())
    >>> scan.ranges.tolist(), scan.order.tolist()
    ([1.0, 1.0, 10.0], [-1, -1, 0])
    >>> SonarScan.from_readings([0.0, 0.0], [1.0, 1.0], SonarParams())
    Traceback (most recent call last):
    ...
    sources.readings.ScanError: angles[1] = 0.0 is not greater than angles[0] = 0.0: angles must be strictly increasing
    """

    pose: NDArray[np.float64]
    angles: NDArray[np.float64]
    ranges: NDArray[np.float64]
    target: NDArray[np.str_]
    order: NDArray[np.int_]
    params: SonarParams

    def __post_init__(self) -> None:
        pose = np.array(self.pose, dtype=float)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ScanError(f"pose must be three finite numbers (x, y, heading); got {self.pose!r}")
        angles = np.array(self.angles, dtype=float).reshape(-1)
        ranges = np.array(self.ranges, dtype=float).reshape(-1)
        target = np.array(self.target, dtype=str).reshape(-1)
        order = np.array(self.order, dtype=int).reshape(-1)
        m = len(angles)
        for name, arr in (("ranges", ranges), ("target", target), ("order", order)):
            if len(arr) != m:
                raise ScanError(f"{name} has {len(arr)} entries but angles has {m}")
        bad = np.flatnonzero(~np.isfinite(angles))
        if len(bad):
            raise ScanError(f"angles[{bad[0]}] = {angles[bad[0]]} is not finite")
        bad = np.flatnonzero(np.isnan(ranges) | (ranges < 0))
        if len(bad):
            raise ScanError(f"ranges[{bad[0]}] = {ranges[bad[0]]}: a range must be a number >= 0")
        steps = np.diff(angles)
        bad = np.flatnonzero(steps <= 0)
        if len(bad):
            i = bad[0] + 1
            raise ScanError(
                f"angles[{i}] = {angles[i]} is not greater than angles[{i - 1}] = {angles[i - 1]}: "
                "angles must be strictly increasing"
            )
        if m and angles[-1] - angles[0] >= 2 * np.pi:
            raise ScanError(f"angles span {angles[-1] - angles[0]:.6g} rad: a scan covers less than a full turn")
        bad = np.flatnonzero(order < -1)
        if len(bad):
            raise ScanError(f"order[{bad[0]}] = {order[bad[0]]}: an order is -1 (unknown) or >= 0")
        bad = np.flatnonzero(ranges > OVER_RANGE * self.params.max_range)
        if len(bad):
            raise ScanError(
                f"ranges[{bad[0]}] = {ranges[bad[0]]:g}: more than {OVER_RANGE:g} times max_range "
                f"({self.params.max_range:g} m): a reading in another unit (mm?) or of another sensor"
            )
        ranges = np.minimum(ranges, self.params.max_range)
        for name, arr in (("pose", pose), ("angles", angles), ("ranges", ranges), ("target", target), ("order", order)):
            object.__setattr__(self, name, _readonly(arr))

    @classmethod
    def from_readings(
        cls, angles: ArrayLike, ranges: ArrayLike, params: SonarParams, *, pose: ArrayLike = (0.0, 0.0, 0.0)
    ) -> SonarScan:
        """A scan from measured readings (angles in rad, ranges in m); targets unknown.

        Readings at or beyond ``max_range`` get order 0 (no echo), the others -1 (unknown).
        """
        r = np.asarray(ranges, dtype=float).reshape(-1)
        with np.errstate(invalid="ignore"):
            order = np.where(r >= params.max_range, 0, -1)
        return cls(np.asarray(pose, dtype=float), angles, r, np.full(len(r), ""), order, params)

    def __len__(self) -> int:
        return len(self.angles)

    @cached_property
    def step(self) -> float:
        """Angle between consecutive readings (rad): the median spacing, or the configured step."""
        if len(self.angles) >= 2:
            return float(np.median(np.diff(self.angles)))
        return float(np.radians(self.params.step_deg))

    @property
    def closed(self) -> bool:
        """True when the readings go all round: the last and first are neighbours (gap <= 1.5 steps)."""
        if len(self.angles) < 2:
            return False
        return bool(2 * np.pi - (self.angles[-1] - self.angles[0]) <= 1.5 * self.step)

    @property
    def points(self) -> NDArray[np.float64]:
        """(M, 2) world position of every reading: pose + range along the beam axis."""
        u = np.stack([np.cos(self.angles), np.sin(self.angles)], axis=1)
        return self.pose[:2] + self.ranges[:, None] * u


@dataclass(frozen=True, eq=False)
class StripeScan:
    """The stripe points of one rotational scan: ``S`` snapshots of ``R`` rays each.

    Attributes
    ----------
    origin : (2,) sensor position.
    angles : (S, R) world bearing of every ray (radians), increasing within a snapshot.
    ranges : (S, R) measured (noisy) range, NaN where the ray returned nothing.
    true_ranges : (S, R) noise-free range, NaN where nothing.
    hit : (S, R) what each ray hit: index into the surfaces' segments, or
        ``N + k`` for cylinder ``k`` (``N`` segments), or -1 for nothing.
    """

    origin: NDArray[np.float64]
    angles: NDArray[np.float64]
    ranges: NDArray[np.float64]
    true_ranges: NDArray[np.float64]
    hit: NDArray[np.intp]

    @property
    def points(self) -> NDArray[np.float64]:
        """(S, R, 2) measured stripe points in world coordinates, NaN where nothing."""
        direction = np.stack([np.cos(self.angles), np.sin(self.angles)], axis=-1)
        return self.origin + self.ranges[..., None] * direction


@dataclass(frozen=True, eq=False)
class LslSegments:
    """LSL line segments, of one pose or of several.

    Attributes
    ----------
    p, q : (N, 2) end points (metres, world frame).
    truth : (N,) ``"real"`` (fitted to stripe points on a true surface) or ``"noise"`` (sunlight).
    snapshot : (N,) index of the snapshot that saw the segment.
    source : (N,) id of the world segment or cylinder that made most of a real
        segment's points; ``""`` for a phantom.
    pose : (N,) index of the pose the segment was observed from.

    Construction checks the arrays: ends finite and within :data:`MAX_COORDINATE`
    of the origin, no segment of zero length, ``truth`` one of :data:`TRUTHS`, one entry per segment in every
    array; a :class:`ScanError` names the array and index otherwise.

    >>> LslSegments(np.array([[0.0, 0.0]]), np.array([[np.nan, 1.0]]), np.array(["real"]),
    ...             np.zeros(1, int), np.array([""]), np.zeros(1, int))
    Traceback (most recent call last):
    ...
    sources.readings.ScanError: q[0] = [nan, 1.0]: segment ends must be finite (metres)
    """

    p: NDArray[np.float64]
    q: NDArray[np.float64]
    truth: NDArray[np.str_]
    snapshot: NDArray[np.intp]
    source: NDArray[np.str_]
    pose: NDArray[np.intp]

    def __post_init__(self) -> None:
        n = len(self.p)
        for name in ("p", "q"):
            ends = np.asarray(getattr(self, name), dtype=float)
            if ends.shape != (n, 2):
                raise ScanError(f"{name} must be an (N, 2) array of end points, got shape {ends.shape}")
            bad = np.flatnonzero(~np.isfinite(ends).all(axis=1))
            if len(bad):
                raise ScanError(f"{name}[{bad[0]}] = {ends[bad[0]].tolist()}: segment ends must be finite (metres)")
            bad = np.flatnonzero((np.abs(ends) > MAX_COORDINATE).any(axis=1))
            if len(bad):
                raise ScanError(
                    f"{name}[{bad[0]}] = {ends[bad[0]].tolist()}: beyond {MAX_COORDINATE:g} m of the origin "
                    "(metres expected; move the origin near the data)"
                )
        same = np.flatnonzero((np.asarray(self.p, dtype=float) == np.asarray(self.q, dtype=float)).all(axis=1))
        if len(same):
            raise ScanError(f"segment {same[0]} has zero length: p == q == {np.asarray(self.p)[same[0]].tolist()}")
        for name in ("truth", "snapshot", "source", "pose"):
            if len(getattr(self, name)) != n:
                raise ScanError(f"{name} has {len(getattr(self, name))} entries, p has {n}")
        bad = np.flatnonzero(~np.isin(self.truth, TRUTHS))
        if len(bad):
            raise ScanError(f"truth[{bad[0]}] = {str(self.truth[bad[0]])!r}: must be one of {list(TRUTHS)}")

    def __len__(self) -> int:
        return len(self.p)

    @property
    def length(self) -> NDArray[np.float64]:
        """(N,) segment lengths."""
        return np.hypot(*(self.q - self.p).T)


def concat_segments(parts: Sequence[LslSegments]) -> LslSegments:
    """Concatenate segment sets (e.g. the poses' outputs), keeping each one's pose index.

    >>> concat_segments([]).p.shape
    (0, 2)
    """
    return LslSegments(
        p=np.concatenate([s.p for s in parts] or [np.zeros((0, 2))]),
        q=np.concatenate([s.q for s in parts] or [np.zeros((0, 2))]),
        truth=np.concatenate([s.truth for s in parts] or [np.zeros(0, dtype="<U5")]),
        snapshot=np.concatenate([s.snapshot for s in parts] or [np.zeros(0, dtype=np.intp)]),
        source=np.concatenate([s.source for s in parts] or [np.zeros(0, dtype=str)]),
        pose=np.concatenate([s.pose for s in parts] or [np.zeros(0, dtype=np.intp)]),
    )
