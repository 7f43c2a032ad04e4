"""Checking a parsed ``map.json``: :class:`MapReader` returns its :class:`~evmap.maps.map_format.MapParts`.

Every problem raises :class:`~evmap.maps.map_format.MapFileError` naming the
file, the place (``nodes[3].xy``) and the problem. Used by
:func:`~evmap.maps.map_file.read_file` and :func:`~evmap.maps.map_file.read_map`.
"""

from __future__ import annotations

import operator
from itertools import chain, repeat
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import RULES, Frame, MassFunction
from evmap.maps import map_json
from evmap.maps.map_format import (
    CORNERS_DEFERRED,
    GRAPH_KEYS,
    ID_PREFIXES,
    LINE_KIND,
    POINT_KINDS,
    READABLE_VERSIONS,
    RELATIONS,
    TRUTHS,
    MapFileError,
    MapParts,
)
from evmap.maps.segments import SegmentStore
from evmap.maps.sensed import SENSED_KEY, sensed_from_json
from evmap.sources.config import config_from_data
from evmap.sources.conformance import MASS_TOLERANCE
from evmap.sources.loading import InputError
from evmap.sources.readings import MAX_COORDINATE

__all__ = ["MapReader"]

_NODE_REQUIRED = frozenset(("id", "xy", "kind", "mass"))
_EDGE_REQUIRED = frozenset(("id", "kind", "mass", "source", "target"))


class MapReader:
    """Checks the node-link layout of a map file and returns its parts; errors name the file and the place.

    Each part is first checked in bulk, quickly; only where that check fails
    are the records gone through one by one, to find the first problem and
    name its place.
    """

    def __init__(self, name: str, owned: bool = False) -> None:
        self.name = name
        self.owned = owned  # the parsed records are ours to change (read from a file), else copied

    def fail(self, where: str, problem: str) -> MapFileError:
        return MapFileError(f"{self.name}: {where}: {problem}" if where else f"{self.name}: {problem}")

    def read(self, data: Any) -> MapParts:
        if not isinstance(data, dict) or not isinstance(data.get("graph"), dict):
            raise self.fail("", "not a map file (expected a JSON object with 'graph', 'nodes' and 'edges')")
        for key in ("nodes", "edges"):
            if not isinstance(data.get(key), list):
                raise self.fail(key, "required list is missing" if key not in data else "must be a list")
        if data.get("directed", False) is not False or data.get("multigraph", False) is not False:
            raise self.fail("", "a map is an undirected simple graph ('directed' and 'multigraph' false)")
        parts = self.graph(data["graph"])
        codec = map_json.MassCodec(parts.frame)
        nodes = self.records(data["nodes"], "nodes", _NODE_REQUIRED, frozenset())
        xy = self.points(nodes)
        kinds = [d["kind"] for d in nodes]
        if not all(map(POINT_KINDS.__contains__, kinds)):
            i = next(i for i, kind in enumerate(kinds) if kind not in POINT_KINDS)
            raise self.fail(f"nodes[{i}].kind", f"must be one of {list(POINT_KINDS)}, got {map_json.shown(kinds[i])}")
        for d, point, mass in zip(nodes, xy, self.masses(codec, nodes, "nodes", parts.rule), strict=True):
            d["xy"] = point
            d["mass"] = mass
        edges = self.records(data["edges"], "edges", _EDGE_REQUIRED, frozenset(d["id"] for d in nodes))
        parts.ends = self.ends(edges, frozenset(d["id"] for d in nodes))
        for d, mass in zip(edges, self.masses(codec, edges, "edges", parts.rule), strict=True):
            d["mass"] = mass
        parts.nodes, parts.edges = nodes, edges
        if parts.segments is not None and len(parts.segments):
            lines = {d["id"] for d in edges} | {""}
            # an absorbed row names the line it was absorbed into, which a later update may have replaced
            live = zip(parts.segments.line.tolist(), parts.segments.role.tolist(), strict=True)
            bad = [i for i, (line, role) in enumerate(live) if role != "absorbed" and line not in lines]
            if bad:
                problem = f"names line {parts.segments.line[bad[0]]!r}, which is not a line of the map"
                raise self.fail(f"graph.segments.line[{bad[0]}]", problem)
        return parts

    def graph(self, attrs: dict[str, Any]) -> MapParts:
        """The graph attributes checked: frame, rule, segments, open space; no points or lines yet."""
        version = attrs.get("schema_version")
        if version is None:
            raise self.fail("graph.schema_version", "missing: not a map file")
        if version not in READABLE_VERSIONS or isinstance(version, bool):
            raise self.fail(
                "graph.schema_version",
                f"unknown schema version {map_json.shown(version)} (this evmap reads {list(READABLE_VERSIONS)})",
            )
        names = attrs.get("frame")
        if not (isinstance(names, list) and all(isinstance(e, str) for e in names)):
            raise self.fail("graph.frame", f"must be a list of element names, got {map_json.shown(names)}")
        try:
            frame = Frame(names)
        except ValueError as exc:
            raise self.fail("graph.frame", str(exc)) from None
        if "real" not in frame.elements:
            raise self.fail("graph.frame", f"must contain the element 'real' (beliefs are Bel({{real}})), got {names}")
        rule = attrs.get("rule")
        if not isinstance(rule, str) or rule not in RULES:
            raise self.fail("graph.rule", f"must be one of {sorted(RULES)}, got {map_json.shown(rule)}")
        extras = {k: v for k, v in attrs.items() if k not in GRAPH_KEYS}
        self.check_extras(extras, frame, rule)
        segments = None
        if "segments" in attrs:
            columns = attrs["segments"]
            try:
                if version >= 2 and isinstance(columns, dict) and isinstance(columns.get("mass"), list):
                    columns = {**columns, "mass": self.segment_masses(map_json.MassCodec(frame), columns["mass"])}
                segments = SegmentStore.from_json(columns, frame)
            except ValueError as exc:
                raise self.fail("graph.segments", str(exc)) from None
            self.check_segments(segments, rule)
        open_space = None
        if "open_space" in attrs:
            try:
                open_space = map_json.multipolygon(attrs["open_space"])
            except (ValueError, TypeError, shapely.errors.ShapelyError) as exc:
                raise self.fail("graph.open_space", str(exc)) from None
        return MapParts(frame, rule, extras, segments, open_space, [], [], [])

    def check_extras(self, extras: dict[str, Any], frame: Frame, rule: str) -> None:
        """The pipeline's graph attributes, where present: its config (its frame and rule the map's), ids, poses,
        deferred corners."""
        if "config" in extras:
            try:
                config = config_from_data(extras["config"], f"{self.name}: graph.config")
            except InputError as exc:
                raise MapFileError(str(exc)) from None
            if config.frame != frame or config.rule != rule:
                raise self.fail(
                    "graph.config",
                    f"its frame {list(config.frame.elements)} and rule {config.rule!r} are not the map's "
                    f"({list(frame.elements)}, {rule!r})",
                )
        if "next_id" in extras:
            counters = extras["next_id"]
            if not (
                type(counters) is dict
                and set(counters) <= set(ID_PREFIXES)
                and all(type(n) is int and n >= 1 for n in counters.values())
            ):
                raise self.fail(
                    "graph.next_id",
                    f"must map id prefixes {list(ID_PREFIXES)} to whole numbers >= 1, got {map_json.shown(counters)}",
                )
        if SENSED_KEY in extras:
            try:
                sensed_from_json(extras[SENSED_KEY])
            except ValueError as exc:
                raise self.fail(f"graph.{SENSED_KEY}", str(exc)) from None
        if "poses" in extras:
            poses = extras["poses"]
            if not (type(poses) is list and all(type(i) is int and i >= 0 for i in poses)) or len(set(poses)) < len(
                poses
            ):
                raise self.fail("graph.poses", f"must be distinct pose indexes >= 0, got {map_json.shown(poses)}")
        if CORNERS_DEFERRED in extras and extras[CORNERS_DEFERRED] is not True:
            shown = map_json.shown(extras[CORNERS_DEFERRED])
            raise self.fail(f"graph.{CORNERS_DEFERRED}", f"must be true where present, got {shown}")

    def check_segments(self, store: SegmentStore, rule: str) -> None:
        """The segments' columns hold what the pipeline writes: finite ends, known values, mass functions."""
        checks = [
            ("p", np.isfinite(store.p).all(axis=1), "end points must be finite"),
            ("q", np.isfinite(store.q).all(axis=1), "end points must be finite"),
            ("pose", store.pose >= 0, "a pose index is >= 0"),
            ("truth", np.isin(store.truth, TRUTHS), f"must be one of {list(TRUTHS)}"),
            ("relation", np.isin(store.relation, RELATIONS), f"must be one of {list(RELATIONS)}"),
        ]
        mass = store.mass
        total = mass.sum(axis=1)
        judged = total != 0
        checks += [
            ("mass", np.isfinite(mass).all(axis=1) & (mass >= 0).all(axis=1), "masses must be finite and >= 0"),
            (
                "mass",
                ~judged | (np.abs(total - 1) <= MASS_TOLERANCE),
                f"masses must sum to 1 (within {MASS_TOLERANCE})",
            ),
        ]
        if not RULES[rule].open_world:
            checks.append(("mass", mass[:, 0] == 0, f"the map's rule {rule!r} leaves no mass on the empty set"))
        for column, good, problem in checks:
            if not good.all():
                i = int(np.argmin(good))
                raise self.fail(
                    f"graph.segments.{column}[{i}]",
                    f"{problem}, got {map_json.shown(getattr(store, column)[i].tolist())}",
                )

    def segment_masses(self, codec: map_json.MassCodec, masses: list[Any]) -> NDArray[np.float64]:
        """The segments' ``{FOCAL: float}`` masses as dense rows; ``{}`` (a segment not judged) is a row of zeros."""
        judged = [i for i, m in enumerate(masses) if m != {}]
        rows = np.zeros((len(masses), 1 << len(codec.frame)))
        if not all(type(m) is dict for m in masses):
            i = next(i for i, m in enumerate(masses) if type(m) is not dict)
            raise self.fail(
                f"graph.segments.mass[{i}]", f"must be an object {{FOCAL: mass}}, got {map_json.shown(masses[i])}"
            )
        try:
            decoded = codec.decode([masses[i] for i in judged])
        except map_json.BadMass as exc:
            raise self.fail(f"graph.segments.mass[{judged[exc.index]}]", exc.problem) from None
        for i, m in zip(judged, decoded, strict=True):
            rows[i, m.masks] = m.masses
        return rows

    def records(
        self, raw: list[Any], key: str, required: frozenset[str], taken: frozenset[str]
    ) -> list[dict[str, Any]]:
        """The records ``data[key]`` with their ``id`` (new, not in ``taken``), ``mass`` and ``history`` checked.

        Copies, unless the records are ours (``owned``); ``history`` defaults to ``[]``.
        """
        if not _records_look_right(raw, required, taken):
            self.check_records(raw, key, required, taken)
        if not self.owned:  # fold appends to a history: not to the caller's
            return [{**d, "history": [dict(r) for r in d.get("history", ())]} for d in raw]
        for d in raw:
            if "history" not in d:
                d["history"] = []
        return raw

    def check_records(self, raw: list[Any], key: str, required: frozenset[str], taken: frozenset[str]) -> None:
        """What :meth:`records` checks, record by record: raise at the first problem."""
        ids = set(taken)
        for i, d in enumerate(raw):
            if type(d) is not dict:
                raise self.fail(f"{key}[{i}]", f"must be an object, got {map_json.shown(d)}")
            if not d.keys() >= required:
                raise self.fail(f"{key}[{i}]", f"required keys {sorted(required - d.keys())} are missing")
            id = d["id"]
            if not (type(id) is str and id):
                raise self.fail(f"{key}[{i}].id", f"must be a non-empty string, got {map_json.shown(id)}")
            if id in ids:
                raise self.fail(f"{key}[{i}].id", f"id {id!r} is used twice")
            ids.add(id)
            if type(d["mass"]) is not dict:
                raise self.fail(
                    f"{key}[{i}].mass", f"must be an object {{FOCAL: mass}}, got {map_json.shown(d['mass'])}"
                )
            history = d.get("history", [])
            if not (type(history) is list and all(type(r) is dict for r in history)):
                raise self.fail(f"{key}[{i}].history", "must be a list of objects")

    def points(self, nodes: list[dict[str, Any]]) -> list[tuple[float, float]]:
        """The nodes' ``xy`` as tuples of floats; one that is not ``[x, y]`` of finite numbers fails at its place."""
        xys = [d["xy"] for d in nodes]
        if set(map(type, xys)) <= {list, tuple} and set(map(len, xys)) <= {2}:
            flat = list(chain.from_iterable(xys))
            if set(map(type, flat)) <= {float, int} and all(map(_coordinate, flat)):
                return list(zip(map(float, flat[0::2]), map(float, flat[1::2]), strict=True))
        for i, xy in enumerate(xys):
            if not (type(xy) in (list, tuple) and len(xy) == 2 and map_json.finite(xy[0]) and map_json.finite(xy[1])):
                raise self.fail(f"nodes[{i}].xy", f"must be [x, y] with two finite numbers, got {map_json.shown(xy)}")
            if not (_coordinate(xy[0]) and _coordinate(xy[1])):
                raise self.fail(
                    f"nodes[{i}].xy", f"must be within {MAX_COORDINATE:g} m of the origin, got {map_json.shown(xy)}"
                )
        return [(float(x), float(y)) for x, y in xys]

    def ends(self, edges: list[dict[str, Any]], points: frozenset[str]) -> list[tuple[str, str]]:
        """The ends ``(source, target)`` of each line, taken out of its record, checked, with the line's kind."""
        us = list(map(dict.pop, edges, repeat("source")))
        vs = list(map(dict.pop, edges, repeat("target")))
        if not (
            [d["kind"] for d in edges].count(LINE_KIND) == len(edges)
            and set(map(type, chain(us, vs))) <= {str}
            and points.issuperset(us)
            and points.issuperset(vs)
            and not any(map(operator.eq, us, vs))
            and len(set(map(frozenset, zip(us, vs, strict=True)))) == len(edges)  # one line per pair of points
        ):
            seen: set[tuple[str, str]] = set()
            for i, (d, u, v) in enumerate(zip(edges, us, vs, strict=True)):
                if d["kind"] != LINE_KIND:
                    raise self.fail(f"edges[{i}].kind", f"must be {LINE_KIND!r}, got {map_json.shown(d['kind'])}")
                for end, name in ((u, "source"), (v, "target")):
                    if not (type(end) is str and end in points):
                        problem = f"must be the id of a point of the map, got {map_json.shown(end)}"
                        raise self.fail(f"edges[{i}].{name}", problem)
                if u == v or (u, v) in seen or (v, u) in seen:
                    problem = f"line {d['id']!r} from {u!r} to {v!r}: a loop, or a second line there"
                    raise self.fail(f"edges[{i}]", problem)
                seen.add((u, v))
        return list(zip(us, vs, strict=True))

    def masses(
        self, codec: map_json.MassCodec, records: list[dict[str, Any]], key: str, rule: str
    ) -> list[MassFunction]:
        try:
            masses = codec.decode([r["mass"] for r in records])
        except map_json.BadMass as exc:
            raise self.fail(f"{key}[{exc.index}].mass", exc.problem) from None
        if not RULES[rule].open_world:
            for i, m in enumerate(masses):
                if m[0] > 0:
                    raise self.fail(f"{key}[{i}].mass", f"the map's rule {rule!r} leaves no mass on the empty set")
        return masses


_NO_HISTORY: list[Any] = []


def _coordinate(value: Any) -> bool:
    """A finite number within :data:`MAX_COORDINATE` of zero (what every point of a map must be)."""
    return map_json.finite(value) and abs(value) <= MAX_COORDINATE


"""What :func:`_records_look_right` reads as the history of a record without one (never stored)."""


def _records_look_right(raw: list[Any], required: frozenset[str], taken: frozenset[str]) -> bool:
    """True if :meth:`MapReader.check_records` would find no problem; a quick check in bulk (False: look closer)."""
    if not (set(map(type, raw)) <= {dict} and all(map(operator.le, repeat(required), map(dict.keys, raw)))):
        return False
    ids = [d["id"] for d in raw]
    if not set(map(type, ids)) <= {str} or "" in ids:
        return False
    unique = set(ids)
    histories = [d.get("history", _NO_HISTORY) for d in raw]
    return (
        len(unique) == len(ids)
        and unique.isdisjoint(taken)
        and set(map(type, [d["mass"] for d in raw])) <= {dict}
        and set(map(type, histories)) <= {list}
        and set(map(type, chain.from_iterable(histories))) <= {dict}
    )
