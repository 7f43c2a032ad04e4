"""``map.json``: a belief map as networkx node-link JSON, written atomically and read back strictly.

The layout (``docs/SCENARIO.md``) is ``networkx.node_link_data(G, edges="edges")``
with every mass as ``{FOCAL: float}`` (segments too, from schema version 2; files
of version 1, whose segment masses are dense rows, still load). :func:`map_data`
makes it, :func:`write_map` writes it atomically, :func:`read_map` checks a parsed
file and returns its :class:`MapParts`, from which
:meth:`~evmap.maps.belief_map.BeliefMap.from_parts` builds the map. Every problem
raises :class:`MapFileError` naming the file, the place (``nodes[3].xy``) and the problem.
"""

from __future__ import annotations

import hashlib
import operator
import os
import stat
from dataclasses import dataclass
from itertools import chain, repeat
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import orjson
import shapely
from numpy.typing import NDArray

from evidential import RULES, Frame, MassFunction
from evmap.maps import map_json
from evmap.maps.occupancy import write_atomic
from evmap.maps.segments import SegmentStore
from evmap.maps.sensed import SENSED_KEY, sensed_from_json, sensed_json
from evmap.sources.config import config_from_data
from evmap.sources.evidence import MASS_TOLERANCE
from evmap.sources.loading import InputError

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = [
    "CHECKSUM_KEY",
    "GRAPH_KEYS",
    "ID_PREFIXES",
    "LINE_KEYS",
    "LINE_KIND",
    "MAX_MAP_BYTES",
    "POINT_KEYS",
    "POINT_KINDS",
    "RELATIONS",
    "SCHEMA_VERSION",
    "TRUTHS",
    "MapFileError",
    "MapParts",
    "map_data",
    "read_file",
    "read_map",
    "write_map",
]

SCHEMA_VERSION = 2
"""Version of the ``map.json`` layout that :func:`write_map` writes; :func:`read_map` reads it and version 1."""

READABLE_VERSIONS = (1, 2)
"""The schema versions :func:`read_map` reads (1: segment masses as dense rows)."""

POINT_KINDS = ("corner", "endpoint", "unidentified")
"""The kinds of points (nodes)."""

LINE_KIND = "line"
"""The kind of every line (edge)."""

GRAPH_KEYS = ("schema_version", "frame", "rule", "open_space", "segments")
"""Graph attributes the map itself keeps (no extra attribute may take these names)."""

POINT_KEYS = ("id", "xy", "kind", "mass", "history")
"""Attributes of a point the map itself keeps."""

LINE_KEYS = ("id", "kind", "mass", "history", "source", "target")
"""Attributes of a line the map itself keeps."""

ID_PREFIXES = ("L", "C", "E", "U")
"""The prefixes of the ids a map hands out (``graph.next_id``): lines, corners, end points, unidentified."""

TRUTHS = ("real", "noise", "")
"""The values of a segment's ``truth``: the simulator's ground truth, ``""`` where unknown (measured data)."""

RELATIONS = ("", "outside", "partly_inside", "inside")
"""The values of a segment's ``relation`` to the sonar open space (``""``: not judged)."""

MAX_MAP_BYTES = 128 * 1024 * 1024
"""The largest map file :func:`read_file` reads (a map in memory takes about 17 times its file's size)."""

CHECKSUM_KEY = b'"checksum":"'
"""The last member of a written map file: the SHA-256 of the file without it, in hex."""

_NODE_REQUIRED = frozenset(("id", "xy", "kind", "mass"))
_EDGE_REQUIRED = frozenset(("id", "kind", "mass", "source", "target"))


class MapFileError(InputError):
    """A map file cannot be read: truncated, of an unknown schema version, or not a map."""


@dataclass(eq=False)
class MapParts:
    """What a map file holds, checked: enough to build the map without another check.

    Attributes
    ----------
    frame, rule : the map's frame and combination rule.
    extras : the other graph attributes (JSON-able).
    segments : the segment store, or None if the file has none.
    open_space : the open space, or None if the file has none.
    nodes : the points' records (``id``, ``xy`` a tuple, ``kind``, ``mass`` a MassFunction, ``history``...).
    edges : the lines' records (``id``, ``kind``, ``mass``, ``history``...), without their ends.
    ends : (u, v) of each line.
    """

    frame: Frame
    rule: str
    extras: dict[str, Any]
    segments: SegmentStore | None
    open_space: shapely.MultiPolygon | None
    nodes: list[dict[str, Any]]
    edges: list[dict[str, Any]]
    ends: list[tuple[str, str]]


def map_data(bm: BeliefMap) -> dict[str, Any]:
    """The map as ``networkx.node_link_data(G, edges="edges")``, every mass as ``{FOCAL: float}``.

    Each edge's ``source`` -> ``target`` is the line's ``u`` -> ``v``; nodes and
    edges in insertion order. The records are new dicts; their values
    (histories, extras) are the map's own. ``networkx.node_link_graph(data)``
    reads it as it is (networkx >= 3.6 reads ``edges`` by default).
    """
    with map_json.gc_paused():
        g = bm.graph
        points = [d for _, d in g.nodes(data=True)]
        adj = dict(g.adjacency())
        ends = [bm.ends(id) for id in bm.line_ids()]
        lines = [adj[u][v] for u, v in ends]
        codec = map_json.MassCodec(bm.frame)
        nodes = [{**d, "mass": m} for d, m in zip(points, codec.encode([d["mass"] for d in points]), strict=True)]
        edges = [
            {**d, "mass": m, "source": u, "target": v}
            for d, m, (u, v) in zip(lines, codec.encode([d["mass"] for d in lines]), ends, strict=True)
        ]
        segments = bm.segments.to_json()
        segments["mass"] = codec.encode_rows(bm.segments.mass)
        kept = sensed_json(bm)  # before the graph's attributes: a loaded map's are read into memory first
        graph = {
            **g.graph,
            **({SENSED_KEY: kept} if kept is not None else {}),
            "schema_version": SCHEMA_VERSION,
            "open_space": map_json.geojson(bm.open_space),
            "segments": segments,
        }
        return {"directed": False, "multigraph": False, "graph": graph, "nodes": nodes, "edges": edges}


def write_map(bm: BeliefMap, path: str | Path) -> None:
    """Write the map to ``path`` as JSON, atomically (a crash leaves the old file or the new one).

    Lossless: floats are written in their shortest round-tripping form and read
    back bit-exact; every attribute and the history round-trip (tuples come back
    as lists, except ``xy``).
    """
    map_json.check_json({k: v for k, v in bm.graph.graph.items() if k not in GRAPH_KEYS}, "graph")
    segments = bm.segments
    for name in ("p", "q"):
        bad = np.flatnonzero(~np.isfinite(getattr(segments, name)).all(axis=1))
        if len(bad):
            raise ValueError(f"cannot save the map to {path}: segment {bad[0]} has a non-finite end ({name})")
    try:
        with map_json.gc_paused():
            text = orjson.dumps(map_data(bm))  # the records are freed before the file is written
    except TypeError as exc:  # an attribute changed in the graph directly, bypassing the checks
        raise ValueError(f"cannot save the map to {path}: {exc}") from None
    digest = hashlib.sha256(text).hexdigest().encode()
    write_atomic(path, text[:-1] + b"," + CHECKSUM_KEY + digest + b'"}')


def read_file(path: str | Path) -> MapParts:
    """Read and check the map file ``path`` (see :func:`read_map`): its size, its checksum, then its content.

    A file of schema version 2 must end with the checksum :func:`write_map` writes;
    one that does not match (a flipped bit, an edit by hand) is refused.
    """
    try:
        with open(path, "rb") as file:
            if not stat.S_ISREG(os.fstat(file.fileno()).st_mode):
                raise MapFileError(f"{path}: not a regular file")
            text = file.read(MAX_MAP_BYTES + 1)
    except OSError as exc:
        raise MapFileError(f"{path}: cannot read file: {exc}") from None
    if len(text) > MAX_MAP_BYTES:
        raise MapFileError(f"{path}: larger than the limit of {MAX_MAP_BYTES} bytes for a map file")
    checked = _checksum_ok(text)
    with map_json.gc_paused():
        try:
            data = orjson.loads(text)
        except orjson.JSONDecodeError as exc:
            raise MapFileError(f"{path}: not valid JSON (truncated or corrupt?): {exc}") from None
        del text  # free the file's bytes before the map is built: a big map needs the memory
        if checked is None and isinstance(data, dict) and "checksum" in data:
            checked = False  # a checksum, but not where and as evmap writes it: the file was rewritten
        if checked is False:
            raise MapFileError(f"{path}: the checksum does not match the content: the file was changed or damaged")
        if isinstance(data, dict):
            data.pop("checksum", None)
        version = (
            data["graph"].get("schema_version")
            if isinstance(data, dict) and isinstance(data.get("graph"), dict)
            else None
        )
        parts = _MapReader(str(path), owned=True).read(data)
        if checked is None and version >= 2:
            raise MapFileError(f"{path}: the checksum is missing: the file was changed after evmap wrote it")
        return parts


def _checksum_ok(text: bytes) -> bool | None:
    """Whether the file's closing checksum matches the rest; None if it has none."""
    end = text.rstrip()
    at = end.rfind(b"," + CHECKSUM_KEY)
    if at < 0 or not end.endswith(b'"}') or len(end) - at != len(CHECKSUM_KEY) + 1 + 64 + 2:
        return None
    digest = end[at + 1 + len(CHECKSUM_KEY) : -2]
    return hashlib.sha256(end[:at] + b"}").hexdigest().encode() == digest


def read_map(data: Any, name: str = "map") -> MapParts:
    """Check a parsed map file (:func:`map_data`'s layout); :class:`MapFileError` names ``name`` and the problem."""
    with map_json.gc_paused():
        return _MapReader(name).read(data)


class _MapReader:
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
            bad = [i for i, line in enumerate(parts.segments.line.tolist()) if line not in lines]
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
        """The pipeline's graph attributes, where present: its config (its frame and rule the map's), ids, poses."""
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
            if set(map(type, flat)) <= {float, int} and all(map(map_json.finite, flat)):
                return list(zip(map(float, flat[0::2]), map(float, flat[1::2]), strict=True))
        for i, xy in enumerate(xys):
            if not (type(xy) in (list, tuple) and len(xy) == 2 and map_json.finite(xy[0]) and map_json.finite(xy[1])):
                raise self.fail(f"nodes[{i}].xy", f"must be [x, y] with two finite numbers, got {map_json.shown(xy)}")
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
"""What :func:`_records_look_right` reads as the history of a record without one (never stored)."""


def _records_look_right(raw: list[Any], required: frozenset[str], taken: frozenset[str]) -> bool:
    """True if :meth:`_MapReader.check_records` would find no problem; a quick check in bulk (False: look closer)."""
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
