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
from evmap.maps.sensed import heard_from, pose_sensed

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
    whose stripe saw through them (module doc), each pose's objects tested against its rays at once."""
    max_gap = FreeSpaceParams().max_gap
    ids = list(objects)
    xy = np.array([bm.graph.nodes[u]["xy"] for u in ids], dtype=float).reshape(-1, 2)
    heard: dict[int, list[int]] = {}  # pose -> the objects it heard
    for i, u in enumerate(ids):
        for pose in heard_from(bm, u):
            heard.setdefault(pose, []).append(i)
    found: list[tuple[int, int, NDArray[np.float64]]] = []  # (object, pose, half the face)
    for pose, objects_heard in heard.items():
        s = pose_sensed(bm, pose)
        if s is None:
            continue
        mine = np.array(objects_heard, dtype=np.intp)
        d = xy[mine] - s.origin
        n = np.hypot(*d.T)
        bearing = np.arctan2(d[:, 1], d[:, 0])
        ok = np.isfinite(s.range)
        t = s.bearing[ok]
        ends = s.origin + s.range[ok, None] * np.column_stack([np.cos(t), np.sin(t)])
        off = (t[None] - bearing[:, None] + np.pi) % (2 * np.pi) - np.pi
        near = np.hypot(*(ends[None] - xy[mine, None]).transpose(2, 0, 1)) <= radius
        face = (n > 0) & ~((off >= -max_gap) & (off < max_gap) & near).any(axis=1)
        for i, di, ni in zip(mine[face], d[face], n[face], strict=True):
            found.append((int(i), pose, np.array([-di[1], di[0]]) / ni * width / 2))
    found.sort(key=lambda f: (f[0], f[1]))  # by object, then pose
    p = np.array([xy[i] - side for i, _, side in found], dtype=float).reshape(-1, 2)
    q = np.array([xy[i] + side for i, _, side in found], dtype=float).reshape(-1, 2)
    return Panes(p, q, np.array([ids[i] for i, _, _ in found], dtype=str))
