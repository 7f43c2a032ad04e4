"""map.json under faults: every garbage file refused by name, bit flips caught by the checksum, a size limit."""

import hashlib
import json
import os

import numpy as np
import pytest

from evmap.maps import BeliefMap, MapFileError, map_format, new_map
from evmap.maps.observation import observe
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import default_scenario
from evmap.sources.sim.world import World


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    config = load_config()
    bm = new_map(config)
    bm.update(observe(World(default_scenario()), 0, config))
    path = tmp_path_factory.mktemp("map") / "map.json"
    bm.save(path)
    return path


def rewrite(saved, tmp_path, change) -> os.PathLike:
    """The saved map changed by ``change`` and written again with a valid checksum (as a careful forger would)."""
    data = json.loads(saved.read_text())
    del data["checksum"]
    change(data)
    path = tmp_path / "map.json"
    text = json.dumps(data, separators=(",", ":")).encode()
    digest = hashlib.sha256(text).hexdigest().encode()
    path.write_bytes(text[:-1] + b"," + map_format.CHECKSUM_KEY + digest + b'"}')
    return path


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda d: d["graph"].update(frame=["noise", "real"]), r"graph.config: its frame \['real', 'noise'\]"),
        (lambda d: d["graph"]["segments"]["mass"][0].update(real=15.0), r"segments.mass\[0\].*sum to 1"),
        (lambda d: d["graph"]["segments"]["truth"].__setitem__(0, "banana"), r"segments.truth\[0\]: must be one of"),
        (lambda d: d["graph"].update(config="garbage"), r"graph.config"),
        (lambda d: d["graph"].update(next_id="x"), r"graph.next_id: must map id prefixes"),
        (lambda d: d["graph"].update(next_id={"L": 0}), r"graph.next_id"),
        (lambda d: d["graph"].update(poses=[0, 0]), r"graph.poses: must be distinct"),
        (lambda d: d["graph"].update(corners_deferred="yes"), r"graph.corners_deferred: must be true where present"),
        (lambda d: d["nodes"][0].update(mass={"": 0.5, "real": 0.5}), r"nodes\[0\].mass: .*no mass on the empty set"),
        (lambda d: d["graph"]["segments"]["mass"][1].update({"": 0.1, "noise": 0.9}), r"segments.mass\[1\]"),
        (lambda d: d["graph"]["segments"]["p"].__setitem__(2, [None, 0.0]), r"segments"),
        (lambda d: d["graph"]["segments"]["pose"].__setitem__(0, -1), r"segments.pose\[0\]"),
        (lambda d: d["graph"]["segments"]["line"].__setitem__(0, "L999"), r"segments.line\[0\]: names line 'L999'"),
        (lambda d: d["nodes"][1].update(xy=[1e300, 1.0]), r"nodes\[1\].xy: must be within 2e\+07 m of the origin"),
    ],
)
def test_garbage_is_refused_naming_the_place(saved, tmp_path, change, match):
    with pytest.raises(MapFileError, match=match):
        BeliefMap.load(rewrite(saved, tmp_path, change))


def test_every_single_bit_flip_is_refused_or_changes_nothing(saved, tmp_path):
    raw = saved.read_bytes()
    original = BeliefMap.load(saved).to_data()
    rng = np.random.default_rng(3)
    path = tmp_path / "flipped.json"
    for position in rng.integers(0, len(raw), 120).tolist():
        flipped = bytearray(raw)
        flipped[position] ^= 1 << int(rng.integers(0, 8))
        path.write_bytes(bytes(flipped))
        try:
            loaded = BeliefMap.load(path)
        except MapFileError:
            continue
        assert loaded.to_data() == original  # a flip in white space, say


def test_the_checksum_is_required_and_a_hand_edit_is_caught(saved, tmp_path):
    data = json.loads(saved.read_text())
    data["nodes"][0]["xy"][0] += 1.0
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(data))
    with pytest.raises(MapFileError, match="checksum does not match"):
        BeliefMap.load(path)
    del data["checksum"]
    path.write_text(json.dumps(data))
    with pytest.raises(MapFileError, match="checksum is missing"):
        BeliefMap.load(path)


@pytest.mark.parametrize("layout", [{}, {"indent": 1}, {"separators": (", ", ": ")}])
def test_a_checksum_written_as_the_contract_says_is_accepted_whatever_the_whitespace(saved, tmp_path, layout):
    """Another tool writes the map with its own JSON layout, the checksum the SHA-256 of the bytes up to the comma
    before it, closed by '}' (docs/SCENARIO.md): evmap reads it; a wrong digest is still refused."""
    data = json.loads(saved.read_text())
    del data["checksum"]
    body = json.dumps(data, **layout).encode()
    head = body[: body.rindex(b"}")]
    digest = hashlib.sha256(head + b"}").hexdigest()
    path = tmp_path / "other.json"
    path.write_bytes(head + b', "checksum": "' + digest.encode() + b'"\n}\n')
    assert BeliefMap.load(path).to_data() == BeliefMap.load(saved).to_data()
    path.write_bytes(head + b', "checksum": "' + digest[::-1].encode() + b'"\n}\n')
    with pytest.raises(MapFileError, match="checksum does not match"):
        BeliefMap.load(path)


def test_size_limit_and_files_that_are_not_regular(saved, tmp_path, monkeypatch):
    bm = BeliefMap.load(saved)
    monkeypatch.setattr(map_format, "MAX_MAP_BYTES", 1000)
    with pytest.raises(MapFileError, match="larger than the limit of 1000 bytes"):
        BeliefMap.load(saved)
    kept = tmp_path / "kept.json"
    kept.write_bytes(b"not evmap's")
    with pytest.raises(ValueError, match=r"kept.json: \d+ bytes, more than the 1000 a map file may have"):
        bm.save(kept)  # evmap writes no map it would refuse to read
    assert kept.read_bytes() == b"not evmap's"  # nothing written over it
    monkeypatch.undo()
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    fd = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)  # a writer, so that opening it does not wait
    try:
        with pytest.raises(MapFileError, match="not a regular file"):
            BeliefMap.load(fifo)
    finally:
        os.close(fd)
    with pytest.raises(MapFileError, match="not a regular file|cannot read"):
        BeliefMap.load(tmp_path)


def test_non_finite_ends_are_never_written_as_null(saved, tmp_path):
    bm = BeliefMap.load(saved)
    store = bm.segments
    (row,) = store.append([[np.nan, 0.0]], [[1.0, 0.0]], [0], [""], {k: v[:1] for k, v in store.features.items()})
    with pytest.raises(ValueError, match=rf"segment {row} has a non-finite end \(p\)"):
        bm.save(tmp_path / "nan.json")
    assert not (tmp_path / "nan.json").exists()


def test_networkx_reads_map_json_with_its_defaults(saved):
    import networkx as nx

    g = nx.node_link_graph(json.loads(saved.read_text()))
    loaded = BeliefMap.load(saved)
    assert set(g.nodes) == set(loaded.graph.nodes) and g.number_of_edges() == loaded.graph.number_of_edges()
