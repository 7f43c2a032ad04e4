"""BeliefMap as the pipeline builds it: points, lines, folding evidence, attributes, open space."""

import networkx as nx
import numpy as np
import pytest
import shapely

from evidential import Frame, MassFunction, TotalConflictError, combine, conflict
from evmap.maps import BeliefMap, Line, Point
from evmap.maps.map_graph import MapGraph
from evmap.maps.planner import belief_plausibility

FRAME = Frame(["real", "noise"])


def mass(real: float, noise: float = 0.0) -> MassFunction:
    return MassFunction(FRAME, {"real": real, "noise": noise, "real|noise": 1 - real - noise})


@pytest.fixture
def bm() -> BeliefMap:
    bm = BeliefMap(FRAME)
    bm.add_point("C1", (0, 0), "corner", mass(0.7), shape="concave")
    bm.add_point("E1", (2, 0), "endpoint", mass(0.6))
    bm.add_point("U1", (1, 1), "unidentified", mass(0.5), [{"pose": 0, "sensor": "sonar"}])
    bm.add_line("L1", "C1", "E1", mass(0.8, 0.1), members=[1, 2], reinforced=True)
    return bm


def test_points_and_lines_are_nodes_and_edges_with_their_attributes(bm):
    g = bm.graph
    assert isinstance(g, MapGraph) and set(g.nodes) == {"C1", "E1", "U1"}
    corner = dict(g.nodes["C1"])
    assert corner.pop("mass").to_dict() == {"real": 0.7, "real|noise": 0.30000000000000004}
    assert corner == {"id": "C1", "xy": (0.0, 0.0), "kind": "corner", "history": [], "shape": "concave"}
    assert type(g.nodes["C1"]["xy"][0]) is float
    edge = g.edge("C1", "E1")
    assert edge["id"] == "L1" and edge["kind"] == "line" and edge["members"] == [1, 2] and edge["reinforced"] is True
    assert edge["mass"].to_dict() == mass(0.8, 0.1).to_dict()
    assert g.nodes["U1"]["history"] == [{"pose": 0, "sensor": "sonar"}]
    assert g.graph["schema_version"] == 2 and g.graph["frame"] == ["real", "noise"] and g.graph["rule"] == "dempster"


def test_networkx_sees_the_map_as_the_map_holds_it(bm):
    copy = bm.graph.to_networkx()
    assert isinstance(copy, nx.Graph) and copy.graph == bm.graph.graph
    assert list(copy.nodes(data=True)) == list(bm.graph.nodes.items())
    assert list(copy.edges(data=True)) == list(bm.graph.edges())
    assert nx.shortest_path(copy, "C1", "E1") == ["C1", "E1"] and nx.number_connected_components(copy) == 2
    bm.remove_line("L1")
    assert copy.has_edge("C1", "E1") and not bm.graph.has_edge("C1", "E1")  # a copy: the map's later changes not in it


def test_lookup_by_id_gives_line_and_point_views(bm):
    line, point = bm["L1"], bm["U1"]
    assert isinstance(line, Line) and (line.u, line.v, line.p, line.q) == ("C1", "E1", (0.0, 0.0), (2.0, 0.0))
    assert line.belief == pytest.approx(0.8) and line.plausibility == pytest.approx(0.9)
    assert isinstance(point, Point) and (point.xy, point.kind, point.belief) == ((1.0, 1.0), "unidentified", 0.5)
    assert "L1" in bm and "C1" in bm and "X" not in bm
    with pytest.raises(KeyError, match="'X'"):
        bm["X"]


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda bm: bm.add_point("L1", (0, 0), "corner", mass(0.5)), ValueError, "already used"),
        (lambda bm: bm.add_point("C1", (0, 0), "corner", mass(0.5)), ValueError, "already used"),
        (lambda bm: bm.add_point("", (0, 0), "corner", mass(0.5)), ValueError, "non-empty string"),
        (lambda bm: bm.add_point("C2", (0, 0), "wall", mass(0.5)), ValueError, "kind must be one of"),
        (lambda bm: bm.add_point("C2", (0, np.nan), "corner", mass(0.5)), ValueError, "finite"),
        (lambda bm: bm.add_point("C2", (0, 1, 2), "corner", mass(0.5)), ValueError, r"must be \(x, y\)"),
        (lambda bm: bm.add_point("C2", (1e300, 1), "corner", mass(0.5)), ValueError, "C2: .*within 2e\\+07 m"),
        (lambda bm: bm.set_attrs("C1", xy=(0, -3e7)), ValueError, "C1: .*within 2e\\+07 m"),
        (lambda bm: bm.add_point("C2", (0, 0), "corner", {"real": 1.0}), TypeError, "MassFunction"),
        (lambda bm: bm.add_point("C2", (0, 0), "corner", MassFunction(Frame(["a"]), {"a": 1})), ValueError, "frame"),
        (lambda bm: bm.add_point("C2", (0, 0), "corner", mass(0.5), shape=np.float64(1)), ValueError, "C2.*float64"),
        (lambda bm: bm.add_point("C2", (0, 0), "corner", mass(0.5), score=-np.inf), ValueError, "score.*not finite"),
        (lambda bm: bm.add_point("C2", (0, 0), "corner", mass(0.5), info={1: "a"}), ValueError, "not a string"),
        (lambda bm: bm.add_point("C2", (0, 0), "corner", mass(0.5), [{"pose": {0, 1}}]), ValueError, "history"),
        (lambda bm: bm.add_line("L2", "C1", "Z", mass(0.5)), KeyError, "'Z'"),
        (lambda bm: bm.add_line("L2", "C1", "C1", mass(0.5)), ValueError, "two different end points"),
        (lambda bm: bm.add_line("L2", "E1", "C1", mass(0.5)), ValueError, "already joined by 'L1'"),
        (lambda bm: bm.add_line("L2", "C1", "U1", mass(0.5), source="x"), ValueError, "reserved"),
        (lambda bm: bm.remove_line("C1"), KeyError, "not a line"),
        (lambda bm: bm.remove_point("L1"), KeyError, "not a point"),
        (lambda bm: bm.remove_point("C1"), ValueError, r"still ends lines \['L1'\]"),
        (lambda bm: bm.fold("X", mass(0.5), {}), KeyError, "'X'"),
        (lambda bm: bm.set_attrs("L1", kind="corner"), ValueError, "fixed"),
        (lambda bm: bm.set_attrs("C1", id="C9"), ValueError, "fixed"),
        (lambda bm: bm.set_attrs("C1", kind="door"), ValueError, "kind"),
    ],
)
def test_bad_building_calls_are_refused_with_a_clear_error(bm, call, error, match):
    before = bm.to_data()
    with pytest.raises(error, match=match):
        call(bm)
    assert bm.to_data() == before


def test_map_parameters_are_checked():
    with pytest.raises(ValueError, match="'real'"):
        BeliefMap(["a", "b"])
    with pytest.raises(ValueError, match="rule must be one of"):
        BeliefMap(FRAME, rule="nope")
    with pytest.raises(ValueError, match="reserved"):
        BeliefMap(FRAME, "dempster", open_space=None)
    assert BeliefMap(["real", "noise"], "yager", config={"a": 1}).graph.graph["config"] == {"a": 1}


def test_near_finds_the_objects_whose_boxes_meet_a_box():
    bm = BeliefMap(FRAME)
    bm.add_point("A", (0, 0), "corner", mass(1.0))
    bm.add_point("B", (4, 0), "endpoint", mass(1.0))
    bm.add_line("L1", "A", "B", mass(1.0))
    assert sorted(bm.near((3.5, -0.5, 4.5, 0.5))) == ["B", "L1"]
    assert sorted(bm.near((3.5, -0.5, 4.5, 0.5), "lines")) == ["L1"]
    boxes = np.array([(3.5, -0.5, 4.5, 0.5), (-0.5, -0.5, 0.5, 0.5), (9, 9, 10, 10)])
    assert bm.near(boxes, "points") == {"A", "B"} and bm.near(boxes) == {"A", "B", "L1"}  # any of the boxes
    assert bm.near(boxes[2:]) == set() and bm.near(np.zeros((0, 4)), "lines") == set()


def test_remove_line_then_point(bm):
    bm.remove_line("L1")
    assert "L1" not in bm and bm.graph.number_of_edges() == 0 and bm.lines(0.0) == []
    bm.remove_point("C1")
    assert "C1" not in bm and [p.id for p in bm.corners(0.0)] == []


@pytest.mark.parametrize("rule", ["dempster", "yager", "pcr6", "disjunctive"])
def test_fold_combines_by_the_map_rule_and_logs_the_evidence(rule):
    bm = BeliefMap(FRAME, rule=rule)
    bm.add_point("U1", (1, 1), "unidentified", mass(0.6, 0.2))
    new = mass(0.3, 0.5)
    expected = combine(mass(0.6, 0.2), new, rule=rule)
    result = bm.fold("U1", new, {"pose": 1, "sensor": "sonar", "source": "rcd_match"})
    assert result.to_dict() == expected.to_dict() == bm.graph.nodes["U1"]["mass"].to_dict()
    assert bm.graph.nodes["U1"]["history"] == [
        {"pose": 1, "sensor": "sonar", "source": "rcd_match", "rule": rule,
         "conflict": conflict(mass(0.6, 0.2), new), "mass": new.to_dict()}
    ]  # fmt: skip


def test_fold_in_total_conflict_changes_nothing():
    bm = BeliefMap(FRAME)
    bm.add_point("U1", (1, 1), "unidentified", MassFunction(FRAME, {"real": 1.0}))
    with pytest.raises(TotalConflictError):
        bm.fold("U1", MassFunction(FRAME, {"noise": 1.0}), {"pose": 0})
    assert bm.graph.nodes["U1"]["history"] == [] and bm["U1"].belief == 1.0


def test_fold_refuses_a_record_json_cannot_carry(bm):
    with pytest.raises(ValueError, match="pose"):
        bm.fold("L1", mass(0.5), {"pose": np.int64(3)})
    assert bm.graph.edge("C1", "E1")["history"] == []


def test_set_attrs_changes_mass_position_kind_and_extras(bm):
    bm.set_attrs("E1", xy=(2, 1), kind="corner", shape="convex", reinforced=True)
    bm.set_attrs("L1", mass=mass(0.2), reinforced=False)
    assert bm["E1"].xy == (2.0, 1.0) and bm["E1"].kind == "corner" and bm.graph.nodes["E1"]["shape"] == "convex"
    assert bm["L1"].q == (2.0, 1.0) and bm["L1"].belief == pytest.approx(0.2)
    assert [c.id for c in bm.corners(0.5)] == ["C1", "E1"] and bm.landmarks()[0].id == "E1"


def test_a_history_grown_by_a_bad_record_is_refused_naming_it(bm):
    """Records the map holds are not checked again; a new one that JSON cannot carry is named by its place."""
    bm.set_attrs("L1", history=[{"pose": 0}, {"pose": 1}])
    kept = bm.graph.edge(*bm.ends("L1"))["history"]
    with pytest.raises(ValueError, match=r"history: \[2\]\.pose: nan is not finite"):
        bm.set_attrs("L1", history=[*kept, {"pose": float("nan")}])
    bm.set_attrs("L1", history=[*kept, {"pose": 2}])
    assert [r["pose"] for r in bm.graph.edge(*bm.ends("L1"))["history"]] == [0, 1, 2]


def test_open_space_is_a_multipolygon_stored_as_coordinates(bm):
    assert bm.open_space.is_empty and bm.graph.graph["open_space"] == {"type": "MultiPolygon", "coordinates": []}
    room = shapely.box(0, 0, 2, 1).difference(shapely.box(0.5, 0.25, 1, 0.5))
    bm.open_space = room
    assert isinstance(bm.open_space, shapely.MultiPolygon) and bm.open_space.equals(room)
    stored = bm.graph.graph["open_space"]
    assert stored["type"] == "MultiPolygon" and len(stored["coordinates"][0]) == 2  # exterior and one hole
    assert shapely.geometry.shape(stored).equals(room)
    bm.open_space = None
    assert bm.open_space.is_empty
    with pytest.raises(ValueError, match="not a valid geometry"):
        bm.open_space = shapely.Polygon([(0, 0), (1, 1), (1, 0), (0, 1)])
    with pytest.raises(ValueError, match="Polygon or MultiPolygon"):
        bm.open_space = shapely.LineString([(0, 0), (1, 1)])


def test_batch_beliefs_equal_the_engine_beliefs():
    rng = np.random.default_rng(3)
    for frame in (FRAME, Frame(["real", "noise", "glass"])):
        masses = []
        for _ in range(200):
            w = rng.dirichlet(np.ones(1 << len(frame)) * 0.5)
            w[0] = 0.0
            w /= w.sum()
            masses.append(MassFunction.from_dense(frame, w))
        bel, pl = belief_plausibility(masses, frame.mask("real"))
        assert bel.tolist() == pytest.approx([m.belief("real") for m in masses], abs=1e-15)
        assert pl.tolist() == pytest.approx([m.plausibility("real") for m in masses], abs=1e-15)
        if len(frame) == 2:
            assert bel.tolist() == [m.belief("real") for m in masses]
    assert belief_plausibility([], 1)[0].shape == (0,)


def test_open_space_near_a_place_seen_many_times_is_read_from_tiles_and_is_the_same():
    """Beyond MANY pieces in a box the tiles answer; they follow the pieces that come later, and a roll-back."""
    from evmap.maps.open_space_pieces import MANY, OpenSpacePieces

    rng = np.random.default_rng(3)
    corners = rng.uniform(0, 9, (3 * MANY, 2))
    pieces = [shapely.box(x, y, x + 2.5, y + 1.5) for x, y in corners.tolist()]
    space = OpenSpacePieces(MapGraph())
    box = (2.0, 2.0, 7.0, 6.0)

    def same_as_union(count):
        near = shapely.clip_by_rect(space.near(box), *box)
        whole = shapely.clip_by_rect(shapely.union_all(pieces[:count]), *box)
        return shapely.symmetric_difference(near, whole).area < 1e-9

    for piece in pieces[: 2 * MANY]:
        space.add(piece)
    assert same_as_union(2 * MANY)
    for piece in pieces[2 * MANY :]:  # the tiles read above follow the new pieces
        space.add(piece)
    assert same_as_union(3 * MANY)
    space.truncate(MANY + 1, None)
    assert same_as_union(MANY + 1)
