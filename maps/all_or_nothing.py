"""All-or-nothing changes of a belief map (:meth:`BeliefMap.transaction`): on an exception, the map as it was.

:func:`all_or_nothing` saves what the map's objects do not log themselves (the
segment store's rows, the open space's pieces, the ids counters, poses and whether corners are deferred),
logs the objects' changes (:class:`~evmap.maps.undo_log.UndoLog`) and, if the
block raises, undoes them and puts the rest back. Inside an outer one it does
nothing: the outer one decides.

>>> from evidential import MassFunction
>>> from evmap.maps import BeliefMap
>>> bm = BeliefMap(["real", "noise"])
>>> m = MassFunction(bm.frame, {"real": 1.0})
>>> bm.add_point("A", (0, 0), "corner", m)
>>> try:
...     with bm.transaction():
...         bm.add_point("B", (1, 0), "corner", m)
...         bm.remove_point("A")
...         raise RuntimeError("half-way")
... except RuntimeError:
...     pass
>>> sorted(bm.graph.nodes)
['A']
"""

from __future__ import annotations

import copy
from collections.abc import Iterator
from contextlib import contextmanager

from evmap.maps.map_format import CORNERS_DEFERRED
from evmap.maps.map_graph import MapGraph
from evmap.maps.map_objects import MapObjects
from evmap.maps.open_space_pieces import OpenSpacePieces
from evmap.maps.segments import SegmentStore

__all__ = ["all_or_nothing"]


@contextmanager
def all_or_nothing(
    objects: MapObjects, space: OpenSpacePieces, segments: SegmentStore, graph: MapGraph
) -> Iterator[None]:
    """The changes to ``objects``, ``space``, ``segments`` and ``graph``'s ids and poses inside the block,
    undone if it raises (then the exception goes on)."""
    if objects.undo.active:
        yield
        return
    g = graph.graph
    store = segments.checkpoint()
    pieces, union, geojson = len(space), space.made_union(), g.get("open_space")
    next_id = copy.deepcopy(g.get("next_id"))
    poses = list(g.get("poses", [])) if "poses" in g else None
    deferred = g.get(CORNERS_DEFERRED)
    objects.undo.start()
    try:
        yield
    except BaseException:
        objects.roll_back()
        segments.restore(store)
        space.truncate(pieces, union)
        g["open_space"] = geojson
        if next_id is not None:
            g["next_id"] = next_id
        if poses is not None:
            g["poses"] = poses
        if deferred is None:
            g.pop(CORNERS_DEFERRED, None)
        else:
            g[CORNERS_DEFERRED] = deferred
        raise
    finally:
        objects.undo.stop()
        segments.release(store)
