"""What each pose of a map sensed, kept for the evidence that other poses' segments need.

The noise-elimination features of :mod:`evmap.maps.contour_free_space` and
:mod:`evmap.maps.sonar_forward` test a segment against the readings of every
pose: the stripe's rays (free from the sensor to their point) and the sonar
scan. :func:`remember` keeps them per map as the map's observations are folded.

:func:`sensed_json` and :func:`sensed_from_json` give them (and the features last
computed from them) the form that ``map.json`` keeps in its optional graph key
``sensed``, so a loaded map goes on updating as the map that was saved.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np
import shapely
from numpy.typing import NDArray

from evmap.sources.geometry import wrapped
from evmap.sources.params import SonarParams
from evmap.sources.readings import SonarScan

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap
    from evmap.maps.observation import Observation

__all__ = [
    "LATEST_POSES",
    "SENSED_FEATURES",
    "SENSED_KEY",
    "Sensed",
    "farthest_returns",
    "features_checkpoint",
    "forget",
    "heard_from",
    "keep_features",
    "kept_features",
    "laid_out",
    "pose_sensed",
    "rays_within",
    "remember",
    "sensed",
    "sensed_from_json",
    "sensed_json",
    "sensed_near",
]

SENSED_KEY = "sensed"
"""The graph attribute of ``map.json`` that keeps what the poses sensed (optional)."""

LATEST_POSES = 16
"""A segment is judged by the latest poses whose readings reach it, an unidentified object by the latest poses
that heard it: at most this many (a scenario has at most 10 poses: all of them; a robot log passes the same place
hundreds of times)."""

SENSED_FEATURES = {"contour_free": "clear", "lsl_persistence": "unobserved", "sonar_forward": "silent"}
"""The features computed from the sensed readings, and the value that is no evidence."""


@dataclass(frozen=True, eq=False)
class Sensed:
    """One pose's readings, ready for ray queries.

    Attributes
    ----------
    pose_index : the pose.
    origin : (2,) the sensors' position.
    bearing : (K,) world bearing of every stripe ray, wrapped to [-pi, pi), sorted.
    range : (K,) its measured range (m), NaN where nothing returned.
    sonar : the pose's sonar scan; None without sonar.
    all_returns : the rays hold every surface a bearing lit within range (:attr:`Observation.all_returns
        <evmap.maps.observation.Observation>`), not only one.
    """

    pose_index: int
    origin: NDArray[np.float64]
    bearing: NDArray[np.float64]
    range: NDArray[np.float64]
    sonar: SonarScan | None
    all_returns: bool = False

    @cached_property
    def points(self) -> NDArray[np.float64]:
        """(R, 2) the points of the rays that returned, in bearing order."""
        ok = np.isfinite(self.range)
        return self.origin + self.range[ok, None] * np.column_stack(
            [np.cos(self.bearing[ok]), np.sin(self.bearing[ok])]
        )

    @cached_property
    def point_index(self) -> shapely.STRtree:
        """An STRtree of :attr:`points` (what :func:`~evmap.sources.geometry.near_segments` asks of them)."""
        return shapely.STRtree(shapely.points(self.points))

    @cached_property
    def reach(self) -> float:
        """How far from the origin its readings can tell anything: its farthest stripe point, or its
        sonar's range (0 without readings)."""
        returned = self.range[np.isfinite(self.range)]
        sonar = 0.0 if self.sonar is None else self.sonar.params.max_range
        return max(float(returned.max()) if len(returned) else 0.0, sonar)


@dataclass(eq=False)
class _Kept:
    """The sensed features last computed for a map's segments, and what an update overwrote of them.

    Attributes
    ----------
    columns : name -> the feature of every segment row, at least ``rows`` long (room to grow; the rows beyond
        ``rows`` hold the feature's :data:`SENSED_FEATURES` value, as never computed).
    rows : the rows the features are kept for (the segments the last judgement saw).
    journal : since :func:`features_checkpoint`, (name, rows, old values) of every write, in order.
    """

    columns: dict[str, NDArray[np.str_]] = field(default_factory=dict)
    rows: int = 0
    journal: list[tuple[str, NDArray[np.intp], NDArray[np.str_]]] = field(default_factory=list)


_MEMORY: WeakKeyDictionary[BeliefMap, dict[int, Sensed]] = WeakKeyDictionary()
_PLACES: WeakKeyDictionary[BeliefMap, tuple[list[Sensed], NDArray[np.float64], NDArray[np.float64]]] = (
    WeakKeyDictionary()
)  # the poses by pose index, their origins and reaches: kept as poses are remembered
_FEATURES: WeakKeyDictionary[BeliefMap, _Kept] = WeakKeyDictionary()


def remember(bm: BeliefMap, obs: Observation) -> Sensed:
    """Keep what the observation sensed with the map (an observation without rays keeps no rays).

    >>> from evmap.maps.belief_map import new_map
    >>> from evmap.maps.observation import observe
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.sources.sim.world import World
    >>> bm = new_map(load_config())
    >>> kept = remember(bm, observe(World(default_scenario()), 0, load_config()))
    >>> [s.pose_index for s in sensed(bm)], bool(np.all(np.diff(kept.bearing) >= 0))
    ([0], True)
    """
    rays = np.zeros((0, 2)) if obs.rays is None else np.asarray(obs.rays, dtype=float).reshape(-1, 2)
    bearing = wrapped(rays[:, 0])
    order = np.argsort(bearing, kind="stable")
    kept = Sensed(
        int(obs.pose_index), np.array(obs.pose[:2]), bearing[order], rays[order, 1], obs.sonar, bool(obs.all_returns)
    )
    _memory(bm)[kept.pose_index] = kept
    if bm in _PLACES:
        poses, origin, reach = _PLACES[bm]
        if poses and kept.pose_index > poses[-1].pose_index:  # the usual case: the next pose, appended
            _PLACES[bm] = ([*poses, kept], np.vstack([origin, kept.origin]), np.append(reach, kept.reach))
        else:
            del _PLACES[bm]
    return kept


def features_checkpoint(bm: BeliefMap) -> tuple[int, frozenset[str]]:
    """What :func:`forget` needs to put the segments' features back as they are now: their rows and names;
    the writes from now on are journalled (what an update writes, not every row)."""
    kept = _kept(bm)
    kept.journal = []
    return kept.rows, frozenset(kept.columns)


def forget(bm: BeliefMap, pose_index: int, features: tuple[int, frozenset[str]]) -> None:
    """Forget what a pose sensed and put back the segments' features of a :func:`features_checkpoint` (the
    pose's update failed, and the map is put back as it was before it)."""
    _memory(bm).pop(int(pose_index), None)
    _PLACES.pop(bm, None)
    kept = _kept(bm)
    for name, rows, old in reversed(kept.journal):
        kept.columns[name][rows] = old
    kept.rows, names = features
    kept.columns = {name: column for name, column in kept.columns.items() if name in names}
    for name, column in kept.columns.items():
        column[kept.rows :] = SENSED_FEATURES[name]  # the rows beyond: never computed
    kept.journal = []


def _memory(bm: BeliefMap) -> dict[int, Sensed]:
    """The map's remembered readings; those of a loaded map come from its graph attribute, read once."""
    if bm not in _MEMORY:
        kept, features = sensed_from_json(bm.graph.graph.pop(SENSED_KEY, None))
        _MEMORY[bm] = {s.pose_index: s for s in kept}
        rows = max((len(column) for column in features.values()), default=0)
        _FEATURES[bm] = _Kept({name: _grown(column, rows, name) for name, column in features.items()}, rows)
    return _MEMORY[bm]


def _kept(bm: BeliefMap) -> _Kept:
    """The map's kept features."""
    _memory(bm)
    return _FEATURES[bm]


def _grown(column: NDArray[np.str_], rows: int, name: str) -> NDArray[np.str_]:
    """The column, with room for at least ``rows`` rows (doubling; the new rows never computed)."""
    if len(column) >= rows:
        return column
    more = np.full(max(rows, 2 * len(column)) - len(column), SENSED_FEATURES[name], dtype="<U12")
    return np.concatenate([column.astype("<U12"), more])


def sensed(bm: BeliefMap) -> list[Sensed]:
    """The readings of every pose remembered for this map, by pose index."""
    memory = _memory(bm)
    return [memory[k] for k in sorted(memory)]


def sensed_near(bm: BeliefMap, bounds: tuple[float, float, float, float], reach: float, latest: int) -> list[Sensed]:
    """The latest ``latest`` poses (by pose index) whose readings can reach the box ``bounds`` (xmin, ymin,
    xmax, ymax): its distance from their origin at most their :attr:`Sensed.reach`, or ``reach``.

    A place seen again and again is judged by its latest poses: what an update costs does not grow with
    the number of times the robot came by.
    """
    if bm not in _PLACES:
        poses = sensed(bm)
        _PLACES[bm] = (poses, np.array([s.origin for s in poses]).reshape(-1, 2), np.array([s.reach for s in poses]))
    poses, origin, far = _PLACES[bm]
    if not poses:
        return []
    far = np.maximum(far, reach)
    lo, hi = np.asarray(bounds[:2]), np.asarray(bounds[2:])
    gap = np.hypot(*(origin - np.clip(origin, lo, hi)).T)
    near = np.flatnonzero(gap <= far)[-latest:]
    return [poses[k] for k in near.tolist()]


def heard_from(bm: BeliefMap, uid: str) -> list[int]:
    """The latest :data:`LATEST_POSES` poses (by pose index, ascending) whose evidence the history of the map
    object ``uid`` records: the poses that judge an unidentified object (a place passed again and again is not
    judged from every pass)."""
    return sorted({r["pose"] for r in bm.graph.nodes[uid].get("history", ()) if "pose" in r})[-LATEST_POSES:]


def pose_sensed(bm: BeliefMap, pose_index: int) -> Sensed | None:
    """What one pose sensed, if the map remembers it."""
    return _memory(bm).get(int(pose_index))


def farthest_returns(s: Sensed) -> Sensed:
    """The pose's readings with only the farthest return of each bearing still returned.

    >>> s = Sensed(0, np.zeros(2), np.array([0.0, 0.0, 0.1]), np.array([1.0, 3.0, 1.0]), None, all_returns=True)
    >>> farthest_returns(s).range.tolist()  # a sunlit patch at 1 m, the stripe on a wall behind it at 3 m
    [nan, 3.0, 1.0]
    """
    ok = np.flatnonzero(np.isfinite(s.range))
    if not len(ok):
        return s
    _, column = np.unique(s.bearing[ok], return_inverse=True)
    far = np.full(column.max() + 1, -np.inf)
    np.maximum.at(far, column, s.range[ok])
    nearer = ok[s.range[ok] < far[column]]
    if not len(nearer):
        return s
    rng = s.range.copy()
    rng[nearer] = np.nan
    return replace(s, range=rng)


def laid_out(
    poses: Sequence[Sensed],
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """The rays of the ``poses`` laid end to end: per pose its number of rays and first ray, every ray's bearing and
    range."""
    sizes = np.array([len(s.bearing) for s in poses], dtype=np.intp)
    starts = np.cumsum(sizes) - sizes
    bearing = np.concatenate([np.zeros(0), *(s.bearing for s in poses)])
    rng = np.concatenate([np.zeros(0), *(s.range for s in poses)])
    return sizes, starts, bearing, rng


def rays_within(
    poses: Sequence[Sensed], pose: NDArray[np.intp], lo: NDArray[np.float64], width: NDArray[np.float64]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The rays of each window ``k``: those of ``poses[pose[k]]`` whose bearing lies in ``[lo[k], lo[k] + width[k])``
    (``lo`` in [-pi, pi), ``width`` under 2 pi), as (window, ray) pairs, ``ray`` numbering the poses' rays laid end
    to end, pose after pose (:func:`laid_out`). All windows at once: each pose's bearings, doubled over two turns, are laid end to
    end ``4 pi`` apart, so that one sorted array and one ``searchsorted`` find every window's rays.

    >>> s = Sensed(0, np.zeros(2), np.array([-3.0, 0.0, 3.0]), np.ones(3), None)
    >>> [x.tolist() for x in rays_within([s, s], np.array([0, 1]), np.array([2.9, -0.1]), np.array([0.5, 0.2]))]
    [[0, 0, 1], [2, 0, 4]]
    """
    sizes, starts, _, _ = laid_out(poses)
    shift = 4 * np.pi * np.arange(len(poses))
    doubled = np.concatenate(
        [np.zeros(0), *(t + shift[k] for k, s in enumerate(poses) for t in (s.bearing, s.bearing + 2 * np.pi))]
    )
    start = lo + shift[pose]
    first = np.searchsorted(doubled, start)
    count = np.maximum(np.searchsorted(doubled, start + width) - first, 0)
    window = np.repeat(np.arange(len(lo)), count)
    at = np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())  # in ``doubled``
    k = pose[window]
    return window, starts[k] + (at - 2 * starts[k]) % np.maximum(sizes[k], 1)  # 2 * size entries a pose


def _floats(values: NDArray[np.float64]) -> list[float | None]:
    """JSON numbers, None for NaN."""
    return [None if np.isnan(v) else float(v) for v in values.tolist()]


def sensed_json(bm: BeliefMap) -> dict[str, Any] | None:
    """What the map's poses sensed and the features last computed from it, as JSON; None if nothing was.

    >>> from evmap.maps.belief_map import new_map
    >>> from evmap.maps.observation import observe
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.sources.sim.world import World
    >>> bm = new_map(load_config())
    >>> kept = remember(bm, observe(World(default_scenario()), 0, load_config()))
    >>> (back,), _ = sensed_from_json(sensed_json(bm))
    >>> bool(np.array_equal(back.range, kept.range, equal_nan=True) and np.array_equal(back.sonar.ranges,
    ...                                                                                kept.sonar.ranges))
    True
    """
    poses = sensed(bm)
    if not poses:
        return None
    records = []
    for s in poses:
        sonar = None
        if s.sonar is not None:
            sonar = {
                "pose": s.sonar.pose.tolist(),
                "angles": s.sonar.angles.tolist(),
                "ranges": s.sonar.ranges.tolist(),
                "params": s.sonar.params.model_dump(),
            }
        record = {"pose_index": s.pose_index, "origin": s.origin.tolist(), "bearing": s.bearing.tolist()}
        record |= {"range": _floats(s.range), "sonar": sonar}
        records.append(record | {"all_returns": True} if s.all_returns else record)
    kept = _kept(bm)
    features = {name: column[: kept.rows].tolist() for name, column in kept.columns.items()}
    return {"poses": records, "features": features}


def sensed_from_json(data: Any) -> tuple[list[Sensed], dict[str, NDArray[np.str_]]]:
    """The readings and features of :func:`sensed_json` (None: none); ``ValueError`` names what is wrong.

    >>> sensed_from_json({"poses": [{"pose_index": 0, "origin": [0, 0], "bearing": [0.1], "range": [None, 2]}]})
    Traceback (most recent call last):
    ...
    ValueError: poses[0]: bearing and range have 1 and 2 entries
    """
    if data is None:
        return [], {}
    if not isinstance(data, dict) or not isinstance(data.get("poses"), list):
        raise ValueError("must be an object with a list 'poses'")  # noqa: TRY004
    kept = []
    for k, record in enumerate(data["poses"]):
        try:
            bearing = np.array(record["bearing"], dtype=float).reshape(-1)
            rng = np.array([np.nan if r is None else r for r in record["range"]], dtype=float).reshape(-1)
            origin = np.array(record["origin"], dtype=float).reshape(2)
            sonar = record.get("sonar")
            scan = None
            if sonar is not None:
                params = SonarParams(**sonar["params"])
                scan = SonarScan.from_readings(sonar["angles"], sonar["ranges"], params, pose=sonar["pose"])
            index = record["pose_index"]
            all_returns = record.get("all_returns", False)
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"poses[{k}]: {exc}") from None
        if len(bearing) != len(rng):
            raise ValueError(f"poses[{k}]: bearing and range have {len(bearing)} and {len(rng)} entries")
        if type(index) is not int or index < 0:
            raise ValueError(f"poses[{k}].pose_index: a pose index is a whole number >= 0, got {index!r}")
        if type(all_returns) is not bool:
            raise ValueError(f"poses[{k}].all_returns: must be true or false, got {all_returns!r}")
        kept.append(Sensed(index, origin, bearing, rng, scan, all_returns))
    features = data.get("features", {})
    if not isinstance(features, dict) or not set(features) <= set(SENSED_FEATURES):
        raise ValueError(f"features: must map some of {sorted(SENSED_FEATURES)} to lists of values")
    return kept, {name: np.array(values, dtype="<U12").reshape(-1) for name, values in features.items()}


def keep_features(bm: BeliefMap, ids: NDArray[np.intp], features: dict[str, NDArray[np.str_]]) -> None:
    """Keep the sensed features last computed for the map's segments ``ids`` (rows of its segment store)."""
    kept = _kept(bm)
    kept.rows = max(kept.rows, len(bm.segments))
    for name, values in features.items():
        column = kept.columns[name] = _grown(kept.columns.get(name, np.zeros(0, dtype="<U12")), kept.rows, name)
        kept.journal.append((name, ids, column[ids]))
        column[ids] = values


def kept_features(bm: BeliefMap, ids: NDArray[np.intp]) -> dict[str, NDArray[np.str_]]:
    """The sensed features last computed for segments ``ids``; no evidence for those never computed."""
    kept = _kept(bm)
    ids = np.asarray(ids, dtype=np.intp)
    out = {}
    for name, none in SENSED_FEATURES.items():
        column = kept.columns.get(name, np.zeros(0, dtype="<U12"))
        known = ids < min(len(column), kept.rows)
        out[name] = np.full(ids.shape, none, dtype="<U12")
        out[name][known] = column[ids[known]]
    return out
