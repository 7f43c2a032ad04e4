"""The panes of glass among the map's unidentified objects: glass heard at normal incidence, which the stripe saw
through.

A believed unidentified object heard from a pose whose stripe put no point within ``radius`` of
it (its rays within :attr:`~evmap.maps.free_space.FreeSpaceParams.max_gap` of the object's
bearing) is a pane toward that pose: a face ``width`` across, square to the bearing (a specular
surface echoes back along its normal). A pose whose stripe did put a point there saw an opaque
surface, a corner or a pillar: it gives no face, nor does a pose the map does not remember.
:mod:`evmap.maps.unidentified` and :mod:`evmap.maps.mirror_echoes` read the faces.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from evmap.maps.free_space import FreeSpaceParams
from evmap.maps.sensed import heard_from, laid_out, pose_sensed, rays_within
from evmap.sources.geometry import wrapped

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["Panes", "pane_faces"]


class Panes(NamedTuple):
    """Faces p-q ((F, 2) each) and the object each is a face of (``owner``, (F,) ids)."""

    p: NDArray[np.float64]
    q: NDArray[np.float64]
    owner: NDArray[np.str_]

    def without(self, removed: Iterable[str]) -> Panes:
        """The faces of the objects not ``removed``."""
        keep = ~np.isin(self.owner, list(removed))
        return Panes(self.p[keep], self.q[keep], self.owner[keep])


def pane_faces(bm: BeliefMap, objects: Iterable[str], width: float, radius: float) -> Panes:
    """The faces of the ``objects`` (ids of believed unidentified objects) toward the poses that heard them and
    whose stripe saw through them (module doc), every (object, pose) pair at once: the rays within ``max_gap`` of
    each object's bearing from each pose (:func:`~evmap.maps.sensed.rays_within`)."""
    max_gap = FreeSpaceParams().max_gap
    ids = list(objects)
    xy = np.array([bm.graph.nodes[u]["xy"] for u in ids], dtype=float).reshape(-1, 2)
    heard = [(i, pose) for i, u in enumerate(ids) for pose in heard_from(bm, u)]
    sensed = {pose: s for pose in sorted({pose for _, pose in heard}) if (s := pose_sensed(bm, pose)) is not None}
    slot = {pose: j for j, pose in enumerate(sensed)}
    kept = [(i, k) for i, k in heard if k in slot]  # a pose the map does not remember gives no face
    obj, pose = np.array([i for i, _ in kept], dtype=np.intp), np.array([k for _, k in kept], dtype=np.intp)
    at = np.array([slot[k] for _, k in kept], dtype=np.intp)
    poses = list(sensed.values())
    origin = np.array([s.origin for s in poses], dtype=float).reshape(-1, 2)
    d = xy[obj] - origin[at]
    n = np.hypot(*d.T)
    lo = wrapped(np.arctan2(d[:, 1], d[:, 0]) - max_gap)
    pair, ray = rays_within(poses, at, lo, np.full(len(lo), 2 * max_gap))
    _, _, bearing, rng = laid_out(poses)
    t = bearing[ray]
    ends = origin[at[pair]] + rng[ray, None] * np.column_stack([np.cos(t), np.sin(t)])  # NaN: the ray returned nothing
    seen = np.zeros(len(obj), dtype=bool)  # the stripe put a point near the object: opaque from that pose
    seen[pair[np.hypot(*(ends - xy[obj[pair]]).T) <= radius]] = True
    face = np.flatnonzero((n > 0) & ~seen)
    face = face[np.lexsort((pose[face], obj[face]))]  # by object, then pose
    side = np.column_stack([-d[face, 1], d[face, 0]]) / n[face, None] * width / 2
    return Panes(xy[obj[face]] - side, xy[obj[face]] + side, np.array([ids[i] for i in obj[face].tolist()], dtype=str))
