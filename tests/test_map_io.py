"""map.json: lossless, atomic save and load, with clear refusals of bad files."""

import importlib.metadata
import json
import math
import os
import re
import stat
import subprocess
import sys
from copy import deepcopy

import networkx as nx
import numpy as np
import pytest
import shapely

from evidential import Frame, MassFunction
from evmap.maps import BeliefMap, MapFileError
from evmap.maps.occupancy import OccupancyParams
from evmap.sources.loading import InputError

FRAME = Frame(["real", "noise"])


def awkward_mass(rng: np.random.Generator) -> MassFunction:
    """Masses whose decimal forms are long: the round trip must keep every bit."""
    w = rng.dirichlet([0.7, 0.7, 0.7])
    return MassFunction(FRAME, {"real": w[0], "noise": w[1], "real|noise": 1.0 - w[0] - w[1]})


@pytest.fixture
def bm() -> BeliefMap:
    rng = np.random.default_rng(5)
    bm = BeliefMap(FRAME, "dempster", settings={"noise": {"threshold": 0.5}}, notes=[{"id": 0, "p": [0.1, 1 / 3]}])
    bm.add_point("E2", (4 / 3, 1e-300), "endpoint", awkward_mass(rng))  # added first: u -> v order must survive
    bm.add_point("C1", (0.1 + 0.2, -2 / 7), "corner", awkward_mass(rng), shape="concave", reinforced=True)
    bm.add_point("U1", (3.25, math.pi), "unidentified", awkward_mass(rng),
                 [{"pose": 0, "sensor": "sonar", "rcd": {"range": 1.2345678901234567, "width_deg": 9}}])  # fmt: skip
    bm.add_line("L1", "C1", "E2", awkward_mass(rng), [{"pose": 0, "source": "lsl_length"}], members=[3, 7], tag=None)
    bm.fold("L1", awkward_mass(rng), {"pose": 1, "sensor": "sonar"})
    bm.fold("U1", awkward_mass(rng), {"pose": 1, "sensor": "sonar"})
    bm.open_space = shapely.MultiPolygon(
        [shapely.box(0.1, 0.1, 3.3, 2 / 3).difference(shapely.Point(1, 0.4).buffer(0.1)), shapely.box(4, 0, 5, 1)]
    )
    return bm


def bits(data: dict) -> dict:
    """Every float of the map data as its exact hex form, so that equality is bit-exact."""
    return json.loads(json.dumps(data), parse_float=lambda text: float(text).hex())


def test_round_trip_is_lossless(bm, tmp_path):
    path = tmp_path / "map.json"
    bm.save(path)
    loaded = BeliefMap.load(path)
    assert bits(loaded.to_data()) == bits(bm.to_data())
    assert loaded.graph.graph == bm.graph.graph and list(loaded.graph.nodes) == ["E2", "C1", "U1"]
    for n, data in bm.graph.nodes.items():
        other = loaded.graph.nodes[n]
        assert {k: v for k, v in other.items() if k != "mass"} == {k: v for k, v in data.items() if k != "mass"}
        assert other["mass"].masks.tolist() == data["mass"].masks.tolist()
        assert [x.hex() for x in other["mass"].masses.tolist()] == [x.hex() for x in data["mass"].masses.tolist()]
        assert type(other["xy"]) is tuple
    line, before = loaded["L1"], bm["L1"]
    assert (line.u, line.v, line.p, line.q, line.belief) == (before.u, before.v, before.p, before.q, before.belief)
    assert loaded.graph.edge("C1", "E2")["history"] == bm.graph.edge("C1", "E2")["history"]
    assert len(loaded.graph.edge("C1", "E2")["history"]) == 2
    assert loaded.open_space.equals_exact(bm.open_space, tolerance=0)
    assert loaded.nearest_obstacle((2, 2), 0.0) == bm.nearest_obstacle((2, 2), 0.0)
    loaded.save(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_bytes() == path.read_bytes()


def test_saved_files_get_ordinary_permissions_and_keep_their_own(bm, tmp_path):
    umask = os.umask(0o022)
    os.umask(umask)
    path = tmp_path / "map.json"
    bm.save(path)
    pgm, meta = bm.save_ros_map(tmp_path / "room", 0.05)
    for written in (path, pgm, meta):  # what open() gives a new file, not the temporary file's 0600
        assert stat.S_IMODE(written.stat().st_mode) == 0o666 & ~umask, written
    path.chmod(0o600)  # the user's choice for a file written over stays
    bm.save(path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.json", "room.pgm", "room.yaml"]  # no temporary left
    (tmp_path / "link.json").symlink_to("map.json")
    path.write_text("old")
    bm.save(tmp_path / "link.json")  # the link stays; the file it points to is the map
    assert (tmp_path / "link.json").is_symlink() and BeliefMap.load(path).to_data() == bm.to_data()


def test_loaded_map_gives_the_same_occupancy_grid(bm, tmp_path):
    bm.save(tmp_path / "map.json")
    loaded = BeliefMap.load(tmp_path / "map.json")
    params = OccupancyParams(padding=0.1)
    m1, o1 = bm.occupancy_masses(0.05, params)
    m2, o2 = loaded.occupancy_masses(0.05, params)
    assert o1 == o2 and np.array_equal(m1, m2)
    assert np.array_equal(bm.occupancy_grid(0.05), loaded.occupancy_grid(0.05))


def test_the_file_is_the_contracts_node_link_json(bm, tmp_path):
    path = tmp_path / "map.json"
    bm.save(path)
    data = json.loads(path.read_text())  # standard JSON
    checksum = data.pop("checksum")  # the file's last member, the SHA-256 of the rest
    assert len(checksum) == 64 and int(checksum, 16) >= 0
    assert data == json.loads(json.dumps(bm.to_data()))
    assert {"schema_version", "frame", "rule"} <= set(data["graph"]) and data["graph"]["schema_version"] == 2
    assert data["graph"]["frame"] == ["real", "noise"] and data["graph"]["rule"] == "dempster"
    for record in data["nodes"] + data["edges"]:
        assert isinstance(record["id"], str) and math.fsum(record["mass"].values()) == pytest.approx(1, abs=1e-12)
        assert set(record["mass"]) <= {"", "real", "noise", "real|noise"}
    assert all(len(n["xy"]) == 2 and n["kind"] in ("corner", "endpoint", "unidentified") for n in data["nodes"])
    assert all(e["kind"] == "line" for e in data["edges"])
    g = nx.node_link_graph(data, edges="edges")  # what other tools do with it
    assert set(g.nodes) == {"E2", "C1", "U1"} and g.edges["C1", "E2"]["id"] == "L1"
    assert g.edges["C1", "E2"]["mass"] == bm.to_data()["edges"][0]["mass"]


def test_open_world_masses_round_trip(tmp_path):
    bm = BeliefMap(FRAME, "conjunctive")
    bm.add_point("U1", (0, 0), "unidentified", MassFunction(FRAME, {"real": 0.6, "real|noise": 0.4}))
    bm.fold("U1", MassFunction(FRAME, {"noise": 0.5, "real|noise": 0.5}), {"pose": 1})
    assert bm.graph.nodes["U1"]["mass"][""] == pytest.approx(0.3)
    bm.save(tmp_path / "map.json")
    assert BeliefMap.load(tmp_path / "map.json").to_data() == bm.to_data()


def test_save_is_atomic_and_leaves_no_temporary_file(bm, tmp_path, monkeypatch):
    path = tmp_path / "map.json"
    bm.save(path)
    before = path.read_bytes()
    bm.add_point("U2", (9, 9), "unidentified", awkward_mass(np.random.default_rng(1)))

    def crash(*args):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OSError, match="disk full"):
        bm.save(path)
    assert path.read_bytes() == before and list(tmp_path.iterdir()) == [path]
    monkeypatch.undo()
    bm.save(path)
    assert "U2" in BeliefMap.load(path) and list(tmp_path.iterdir()) == [path]


def test_save_refuses_attributes_json_cannot_carry(bm, tmp_path):
    path = tmp_path / "map.json"
    bm.graph.graph["settings"] = {"threshold": float("nan")}
    with pytest.raises(ValueError, match="settings.threshold.*not finite"):
        bm.save(path)
    bm.graph.graph["settings"] = {}
    bm.graph.nodes["C1"]["score"] = np.float32(1)  # changed behind the map's back
    with pytest.raises(ValueError, match="cannot save.*float32"):
        bm.save(path)
    assert not path.exists() and list(tmp_path.iterdir()) == []


def corrupt(data: dict, change) -> dict:
    data = json.loads(json.dumps(data))
    change(data)
    return data


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda d: d["graph"].update(schema_version=3), "graph.schema_version: unknown schema version 3"),
        (lambda d: d["graph"].pop("schema_version"), "graph.schema_version: missing"),
        (lambda d: d["graph"].update(frame="real"), "graph.frame"),
        (lambda d: d["graph"].update(rule="best"), "graph.rule: must be one of"),
        (lambda d: d["graph"].update(open_space={"type": "Point"}), "graph.open_space"),
        (lambda d: d.pop("edges"), "edges: required list is missing"),
        (lambda d: d.update(nodes={}), "nodes: must be a list"),
        (lambda d: d.update(directed=True), "undirected"),
        (lambda d: d["nodes"][1].pop("xy"), r"nodes\[1\]: required keys \['xy'\] are missing"),
        (lambda d: d["nodes"][1].update(xy=[0, "1"]), r"nodes\[1\].xy: must be \[x, y\]"),
        (lambda d: d["nodes"][2].update(kind="window"), r"nodes\[2\].kind"),
        (lambda d: d["nodes"][0].update(mass={"real": 0.5}), r"nodes\[0\].mass: masses must sum to 1"),
        (lambda d: d["nodes"][0].update(mass={"real": True}), r"nodes\[0\].mass: .*finite number"),
        (lambda d: d["nodes"][0].update(mass={"glass": 1.0}), r"nodes\[0\].mass: .*'glass'"),
        (lambda d: d["nodes"][0].update(mass=[1.0]), r"nodes\[0\].mass: must be an object"),
        (lambda d: d["nodes"][1].update(id="E2"), r"nodes\[1\].id: id 'E2' is used twice"),
        (lambda d: d["nodes"][1].update(history={}), r"nodes\[1\].history"),
        (lambda d: d["edges"][0].update(id="C1"), r"edges\[0\].id: id 'C1' is used twice"),
        (lambda d: d["edges"][0].update(target="L1"), r"edges\[0\].target: must be the id of a point"),
        (lambda d: d["edges"][0].update(kind="wall"), r"edges\[0\].kind"),
        (lambda d: d["edges"].append(dict(d["edges"][0], id="L2")), r"edges\[1\]: .*second line"),
    ],
)
def test_load_refuses_a_file_that_is_not_a_map(bm, tmp_path, change, match):
    path = tmp_path / "map.json"
    path.write_text(json.dumps(corrupt(bm.to_data(), change)))
    with pytest.raises(MapFileError, match=match) as info:
        BeliefMap.load(path)
    assert str(info.value).startswith(f"{path}: ")


def test_load_refuses_truncated_empty_missing_and_foreign_files(bm, tmp_path):
    path = tmp_path / "map.json"
    bm.save(path)
    text = path.read_bytes()
    path.write_bytes(text[: len(text) // 2])
    with pytest.raises(MapFileError, match=rf"{path}: not valid JSON \(truncated or corrupt\?\)"):
        BeliefMap.load(path)
    path.write_bytes(b"")
    with pytest.raises(MapFileError, match="not valid JSON"):
        BeliefMap.load(path)
    path.write_text("[1, 2, 3]")
    with pytest.raises(MapFileError, match="not a map file"):
        BeliefMap.load(path)
    with pytest.raises(MapFileError, match="cannot read file"):
        BeliefMap.load(tmp_path / "missing.json")
    assert issubclass(MapFileError, ValueError) and issubclass(MapFileError, InputError)


def test_from_data_leaves_its_input_alone(bm):
    data = bm.to_data()
    copy = deepcopy(data)
    BeliefMap.from_data(data)
    assert data == copy
    bm2 = BeliefMap.from_data(data)
    bm2.fold("L1", awkward_mass(np.random.default_rng(2)), {"pose": 2})
    assert data == copy


def test_the_oldest_networkx_we_allow_reads_the_file(bm, tmp_path):
    """The floor of ``networkx`` in our requirements, installed beside the tests' own, reads map.json with its
    defaults (``node_link_graph`` of networkx 3.2-3.5 looked for ``links``, ours are ``edges``: refused floors)."""
    (floor,) = [
        m.group(1) for r in importlib.metadata.requires("evmap") if (m := re.fullmatch(r"networkx>=([\d.]+)", r))
    ]
    target = tmp_path / "floor"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), f"networkx=={floor}"],
        check=True,
        capture_output=True,
    )
    bm.save(tmp_path / "map.json")
    read = (
        "import json, sys, networkx as nx\n"
        "g = nx.node_link_graph(json.load(open(sys.argv[1])))\n"
        "edges = [sorted((u, v)) + [d['id']] for u, v, d in g.edges(data=True)]\n"
        "print(json.dumps({'version': nx.__version__, 'nodes': sorted(g.nodes), 'edges': edges}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", read, str(tmp_path / "map.json")],
        check=True,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(target)},
    )
    assert json.loads(done.stdout) == {"version": floor, "nodes": ["C1", "E2", "U1"], "edges": [["C1", "E2", "L1"]]}
