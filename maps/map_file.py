"""``map.json``: a belief map as networkx node-link JSON, written atomically and read back strictly.

The layout (``docs/SCENARIO.md``) is ``networkx.node_link_data(G, edges="edges")``
with every mass as ``{FOCAL: float}`` (segments too, from schema version 2; files
of version 1, whose segment masses are dense rows, still load). :func:`map_data`
makes it, :func:`write_map` writes it atomically, :func:`read_map` checks a parsed
file and returns its :class:`MapParts`, from which
:meth:`~evmap.maps.belief_map.BeliefMap.from_parts` builds the map. Every problem
raises :class:`MapFileError` naming the file, the place (``nodes[3].xy``) and the problem.

The layout's names and data (:class:`MapFileError` among them) are in
:mod:`evmap.maps.map_format`, the checks in :mod:`evmap.maps.map_reader`.
"""

from __future__ import annotations

import hashlib
import os
import re
import stat
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import orjson

from evmap.maps import map_format, map_json
from evmap.maps.atomic_file import write_atomic
from evmap.maps.map_format import CHECKSUM_KEY, GRAPH_KEYS, SCHEMA_VERSION, MapFileError, MapParts
from evmap.maps.map_reader import MapReader
from evmap.maps.sensed import SENSED_KEY, sensed_json

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["map_data", "read_file", "read_map", "write_map"]


def map_data(bm: BeliefMap) -> dict[str, Any]:
    """The map as ``networkx.node_link_data(G, edges="edges")``, every mass as ``{FOCAL: float}``.

    Each edge's ``source`` -> ``target`` is the line's ``u`` -> ``v``; nodes and
    edges in insertion order. The records are new dicts; their values
    (histories, extras) are the map's own. ``networkx.node_link_graph(data)``
    reads it as it is (networkx >= 3.6 reads ``edges`` by default).
    """
    with map_json.gc_paused():
        g = bm.graph
        points = list(g.nodes.values())
        adj = g.adj
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


def write_map(bm: BeliefMap, path: str | Path, *, sync: bool = True) -> None:
    """Write the map to ``path`` as JSON, atomically (a crash leaves the old file or the new one).

    Lossless: floats are written in their shortest round-tripping form and read
    back bit-exact; every attribute and the history round-trip (tuples come back
    as lists, except ``xy``). ``sync=False``: not forced to the disk before the rename, for a
    file in a directory that is itself made to appear whole (a run's staging).
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
    text = text[:-1] + b"," + CHECKSUM_KEY + digest + b'"}'
    if len(text) > map_format.MAX_MAP_BYTES:
        raise ValueError(
            f"cannot save the map to {path}: {len(text)} bytes, more than the {map_format.MAX_MAP_BYTES} a map "
            "file may have (evmap would refuse to read it)"
        )
    write_atomic(path, text, sync=sync)


def read_file(path: str | Path) -> MapParts:
    """Read and check the map file ``path`` (see :func:`read_map`): its size, its checksum, then its content.

    A file of schema version 2 must end with the checksum :func:`write_map` writes;
    one that does not match (a flipped bit, an edit by hand) is refused.
    """
    try:
        with open(path, "rb") as file:
            if not stat.S_ISREG(os.fstat(file.fileno()).st_mode):
                raise MapFileError(f"{path}: not a regular file")
            text = file.read(map_format.MAX_MAP_BYTES + 1)
    except OSError as exc:
        raise MapFileError(f"{path}: cannot read file: {exc}") from None
    if len(text) > map_format.MAX_MAP_BYTES:
        raise MapFileError(f"{path}: larger than the limit of {map_format.MAX_MAP_BYTES} bytes for a map file")
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
        parts = MapReader(str(path), owned=True).read(data)
        if checked is None and version >= 2:
            raise MapFileError(f"{path}: the checksum is missing: the file was changed after evmap wrote it")
        return parts


_CLOSING_CHECKSUM = re.compile(rb',\s*"checksum"\s*:\s*"([0-9a-f]{64})"\s*\}\s*\Z')
"""The file's last member, the checksum, as evmap writes it (``,"checksum":"<hex>"}``) or with whitespace."""


def _checksum_ok(text: bytes) -> bool | None:
    """Whether the file's closing checksum matches the rest (the bytes up to the comma before it, closed by
    ``}``); None if it has none."""
    found = _CLOSING_CHECKSUM.search(text, max(0, len(text) - 4096))
    if found is None:
        return None
    return hashlib.sha256(text[: found.start()] + b"}").hexdigest().encode() == found.group(1)


def read_map(data: Any, name: str = "map") -> MapParts:
    """Check a parsed map file (:func:`map_data`'s layout); :class:`MapFileError` names ``name`` and the problem."""
    with map_json.gc_paused():
        return MapReader(name).read(data)
