"""Evidence sources: the table and ramp kinds, the kind registry, the open-space relation."""

from __future__ import annotations

from functools import partial
from typing import Literal

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from evidential import Frame, combine_batch
from evmap import configs
from evmap.sources.config import load_config
from evmap.sources.evidence import (
    KINDS,
    BoundSource,
    EvidenceSource,
    SourceSpec,
    SpecError,
    mass_row,
    ramp_masses,
    register_kind,
    table_masses,
)
from evmap.sources.params import NoiseParams
from evmap.sources.relation import RELATIONS, inside_fraction, relation

FRAME = Frame(["real", "noise"])
LSL = partial(ramp_masses, x=np.array([0.0, 0.4]), y=np.array([0.0, 0.6]), focal=1, rest=np.array([0, 0, 0, 1.0]))


# ---- table --------------------------------------------------------------------------------------


def table_rows() -> tuple[np.ndarray, np.ndarray]:
    categories = np.array(["inside", "outside", "partly_inside"])  # sorted
    rows = np.array([[0, 0.1, 0.8, 0.1], [0, 0.8, 0.1, 0.1], [0, 0.1, 0.1, 0.8]])
    return categories, rows


def test_table_masses_picks_the_row_of_each_category():
    categories, rows = table_rows()
    got = table_masses(["partly_inside", "inside", "outside", "inside"], categories=categories, rows=rows)
    np.testing.assert_array_equal(got, rows[[2, 0, 1, 0]])


def test_table_masses_of_no_objects_is_an_empty_batch():
    categories, rows = table_rows()
    assert table_masses([], categories=categories, rows=rows).shape == (0, 4)


@pytest.mark.parametrize("value", ["nowhere", "", "insidex", "zzz", "a"])
def test_table_masses_refuses_an_unknown_category(value):
    categories, rows = table_rows()
    with pytest.raises(ValueError, match=f"unknown category '{value}'"):
        table_masses(["inside", value], categories=categories, rows=rows)


def test_table_masses_refuses_a_2d_array():
    categories, rows = table_rows()
    with pytest.raises(ValueError, match="1-D"):
        table_masses([["inside"]], categories=categories, rows=rows)


# ---- ramp ---------------------------------------------------------------------------------------


@given(st.lists(st.floats(0, 10), max_size=20))
def test_ramp_is_the_papers_lsl_bpa(lengths):
    # equation (2): m(real) = c * min(l / L, 1), m(unknown) = 1 - m(real), c = 0.6, L = 0.4 m
    m = LSL(np.array(lengths))
    expected = 0.6 * np.minimum(np.array(lengths) / 0.4, 1.0)
    np.testing.assert_allclose(m[:, 1], expected, atol=1e-12)
    np.testing.assert_allclose(m[:, 3], 1 - expected, atol=1e-12)
    assert not m[:, [0, 2]].any()


def test_ramp_is_constant_beyond_its_ends():
    m = ramp_masses(
        [-5.0, 1.0, 2.0, 3.0, 9.0],
        x=np.array([1.0, 3.0]),
        y=np.array([0.2, 0.6]),
        focal=2,
        rest=np.array([0, 0.5, 0, 0.5]),
    )
    np.testing.assert_allclose(m[:, 2], [0.2, 0.2, 0.4, 0.6, 0.6])
    np.testing.assert_allclose(m[:, 1], (1 - m[:, 2]) / 2)
    np.testing.assert_allclose(m.sum(axis=1), 1.0)


def test_ramp_with_one_break_point_is_constant():
    m = ramp_masses([0.0, 100.0], x=np.array([1.0]), y=np.array([0.3]), focal=1, rest=np.array([0, 0, 0, 1.0]))
    np.testing.assert_allclose(m, [[0, 0.3, 0, 0.7]] * 2)


@pytest.mark.parametrize(
    ("values", "problem"),
    [(["long"], "expected numbers"), ([np.nan], "finite"), ([np.inf], "finite"), ([[0.1]], "1-D")],
)
def test_ramp_refuses_bad_values(values, problem):
    with pytest.raises(ValueError, match=problem):
        LSL(values)


# ---- mass rows ----------------------------------------------------------------------------------


def test_mass_row_accepts_every_way_of_writing_a_focal_set():
    focal = {"unknown": "real|noise", "nothing": ""}
    row = mass_row(
        {"noise|real": 0.5, "noise": 0.25, "nothing": 0.0, "real": 0.25},
        FRAME,
        lambda w: FRAME.mask(focal.get(w, w)),
    )
    np.testing.assert_array_equal(row, [0, 0.25, 0.25, 0.5])


@pytest.mark.parametrize(
    ("entries", "at", "problem"),
    [
        ({"real": 0.5, "noise": 0.4}, (), "sum to 0.9, not 1"),
        ({"real": 1.1, "noise": -0.1}, ("noise",), "negative"),
        ({"real": 0.5, "ghost": 0.5}, ("ghost",), "'ghost' is not in"),
        ({"real": 0.5, "real|noise": 0.25, "noise|real": 0.25}, ("noise|real",), "same focal set as 'real|noise'"),
        ({"real": 0.9, "": 0.1}, ("",), "empty set"),
    ],
)
def test_mass_row_names_the_bad_key(entries, at, problem):
    with pytest.raises(SpecError, match=problem) as err:
        mass_row(entries, FRAME, FRAME.mask, ("table", "inside"))
    assert err.value.at == ("table", "inside", *at)


def test_mass_row_tolerates_rounding_within_1e_9_only():
    assert mass_row({"real": 0.5, "noise": 0.5 + 1e-10}, FRAME, FRAME.mask).sum() == pytest.approx(1)
    with pytest.raises(SpecError, match="sum to"):
        mass_row({"real": 0.5, "noise": 0.5 + 1e-8}, FRAME, FRAME.mask)


# ---- sources and the registry -------------------------------------------------------------------


def test_built_sources_satisfy_the_protocol():
    cfg = load_config()
    for source in cfg.sources.values():
        assert isinstance(source, EvidenceSource)
        assert source.frame == FRAME


def test_a_source_says_which_feature_is_missing():
    source = load_config().sources["lsl_length"]
    with pytest.raises(ValueError, match="reads feature 'length'.*given: \\['relation'\\]"):
        source.masses({"relation": ["inside"]})


def test_a_source_names_itself_in_a_bad_value_error():
    source = load_config().sources["sonar_open_space"]
    with pytest.raises(ValueError, match="source 'sonar_open_space', feature 'relation': unknown category 'near'"):
        source.masses({"relation": ["inside", "near"]})


class ConstantSpec(SourceSpec):
    kind: Literal["constant"]
    masses: dict[str, float]


def build_constant(name, spec, frame, focal):
    row = mass_row(spec.masses, frame, focal, ("masses",))
    return BoundSource(name, frame, spec.feature, "constant", lambda v: np.tile(row, (len(v), 1)), (), "constant")


@pytest.fixture
def constant_kind():
    register_kind("constant", ConstantSpec)(build_constant)
    yield
    del KINDS["constant"]


def test_a_kind_registered_in_python_is_usable_from_yaml(tmp_path, constant_kind):
    # a new kind is one spec model and one builder; YAML then names it as `kind:`
    text = (
        configs.path("paper.yaml")
        .read_text()
        .replace(
            "sources:\n",
            "sources:\n  prior:\n    kind: constant\n    frame: existence\n    feature: length\n"
            "    masses: {real: 0.5, unknown: 0.5}\n",
            1,
        )
    )
    (tmp_path / "c.yaml").write_text(text)
    cfg = load_config(tmp_path / "c.yaml")
    np.testing.assert_array_equal(cfg.sources["prior"].masses({"length": [1, 2]}), [[0, 0.5, 0, 0.5]] * 2)
    with pytest.raises(ValueError, match="already registered"):
        register_kind("constant", ConstantSpec)(build_constant)


# ---- the example sensor next to the paper's sources ---------------------------------------------


def test_the_example_infrared_sensor_combines_with_the_papers_sources():
    cfg = load_config(configs.path("examples/infrared.yaml"))
    sources = cfg.stage_sources("noise_elimination")
    assert [s.name for s in sources] == ["sonar_open_space", "lsl_length", "infrared"]
    features = {
        "relation": ["partly_inside", "partly_inside", "inside"],
        "length": [0.2, 0.2, 1.0],
        "ir_return": ["no_return", "beyond", "echo"],
    }
    fused = combine_batch(*(s.masses(features) for s in sources), rule=cfg.rule)

    # By hand, on {real, noise}: the conjunctive product of masses (r_i, n_i, u_i) gives
    # m(real) = prod(r_i + u_i) - prod(u_i), m(noise) = prod(n_i + u_i) - prod(u_i),
    # m(real|noise) = prod(u_i); Dempster divides by their sum 1 - K.
    # Row 0, IR vacuous: sonar (.1, .1, .8), LSL (.3, 0, .7):
    #   real .9 * 1 - .56 = .34, noise .9 * .7 - .56 = .07, unknown .56; 1 - K = .97.
    # Row 1, IR "beyond" (0, .7, .3):
    #   real .9 * 1 * .3 - .168 = .102, noise .9 * .7 * 1 - .168 = .462, unknown .168; 1 - K = .732.
    # Row 2: sonar (.1, .8, .1), LSL (.6, 0, .4), IR "echo" (.7, 0, .3):
    #   real .2 * 1 * 1 - .012 = .188, noise .9 * .4 * .3 - .012 = .096, unknown .012; 1 - K = .296.
    expected = np.array(
        [
            [0, 0.34 / 0.97, 0.07 / 0.97, 0.56 / 0.97],
            [0, 0.102 / 0.732, 0.462 / 0.732, 0.168 / 0.732],
            [0, 0.188 / 0.296, 0.096 / 0.296, 0.012 / 0.296],
        ]
    )
    np.testing.assert_allclose(fused, expected, atol=1e-12)
    # the IR beam passing through a short, partly-inside phantom gets it removed
    removed = fused[:, 2] > cfg.noise.threshold
    assert removed.tolist() == [False, True, False]


def test_the_example_differs_from_the_paper_only_by_its_new_sensor():
    paper, example = load_config(), load_config(configs.path("examples/infrared.yaml"))
    assert set(example.sources) - set(paper.sources) == {"infrared"}
    for name, source in paper.sources.items():
        values = np.array(source.examples)
        np.testing.assert_array_equal(
            example.sources[name].masses({source.feature: values}), source.masses({source.feature: values})
        )
    assert example.stages["noise_elimination"] == (*paper.stages["noise_elimination"], "infrared")
    assert {k: v for k, v in example.stages.items() if k != "noise_elimination"} == {
        k: v for k, v in paper.stages.items() if k != "noise_elimination"
    }


# ---- relation to the open space -----------------------------------------------------------------


ROOM = shapely.box(0, 0, 2, 2)


def test_inside_fraction_known_values():
    p = [[0.5, 0.5], [1, 1], [3, 3], [-1, 1], [1, 1]]
    q = [[1.5, 0.5], [3, 1], [4, 4], [3, 1], [1, 1]]  # inside, half, outside, half (both ends out), a point
    np.testing.assert_allclose(inside_fraction(p, q, ROOM), [1, 0.5, 0, 0.5, 1])


def test_relation_thresholds_are_inclusive():
    params = NoiseParams(inside_fraction=0.75, outside_fraction=0.25)
    # shares inside: 1, 0.75, 0.5, 0.25, 0
    p = np.array([[1.0, 1.0], [0.5, 1.0], [1.0, 1.0], [1.5, 1.0], [3.0, 1.0]])
    q = np.array([[1.5, 1.0], [2.5, 1.0], [3.0, 1.0], [3.5, 1.0], [4.0, 1.0]])
    assert relation(p, q, ROOM, params).tolist() == [
        "inside", "inside", "partly_inside", "outside", "outside",
    ]  # fmt: skip


def test_relation_categories_are_the_papers_table_categories():
    spec = load_config().sources["sonar_open_space"]
    assert spec.feature == "relation"
    assert set(spec.examples) == set(RELATIONS)


def test_relation_of_a_zero_length_segment_is_whether_the_point_is_covered():
    p = [[1, 1], [2, 1], [5, 5]]
    assert relation(p, p, ROOM).tolist() == ["inside", "inside", "outside"]


def test_relation_with_no_segments_or_no_open_space():
    assert relation(np.zeros((0, 2)), np.zeros((0, 2)), ROOM).shape == (0,)
    assert relation([[0, 0]], [[1, 1]], shapely.Polygon()).tolist() == ["outside"]


def test_relation_on_a_multipolygon_open_space():
    space = shapely.union(shapely.box(0, 0, 1, 1), shapely.box(2, 0, 3, 1))
    np.testing.assert_allclose(inside_fraction([[0, 0.5]], [[3, 0.5]], space), [2 / 3])


def shapely_fraction(coords, space) -> list[float]:
    """The reference: the length of shapely's intersection, one segment at a time."""
    lines = [shapely.LineString([(x0, y0), (x1, y1)]) for x0, y0, x1, y1 in coords]
    return [line.intersection(space).length / line.length for line in lines]


def test_inside_fraction_along_the_boundary_and_through_vertices():
    coords = [(0, 0, 2, 0), (-1, 0, 3, 0), (-1, -1, 3, 3), (0, 2, 2, 0), (2, -1, 2, 3), (-1, 1, 0, 1)]
    c = np.array(coords, dtype=float)
    np.testing.assert_allclose(inside_fraction(c[:, :2], c[:, 2:], ROOM), [1, 0.5, 0.5, 1, 0.5, 0], atol=1e-12)
    np.testing.assert_allclose(inside_fraction(c[:, :2], c[:, 2:], ROOM), shapely_fraction(coords, ROOM), atol=1e-12)


SPACE = shapely.union(ROOM, shapely.Point(3, 3).buffer(1)).difference(shapely.box(0.5, 0.5, 1, 1))  # a hole


NANOMETRES = st.floats(-3, 5, allow_nan=False).map(lambda v: round(v, 9))
"""Coordinates in metres to the nanometre: on subnormal ones (1e-308) GEOS, the reference, errs (it put a
segment from (1e-163, 1e-308) to (-1, 1) wholly inside SPACE, which it leaves at once)."""


@given(st.lists(st.tuples(*(NANOMETRES for _ in range(4))), min_size=1, max_size=30))
def test_inside_fraction_is_shapelys_intersection_length(coords):
    c = np.array(coords)
    got = inside_fraction(c[:, :2], c[:, 2:], SPACE)
    assert ((got >= 0) & (got <= 1)).all()
    long = np.hypot(c[:, 2] - c[:, 0], c[:, 3] - c[:, 1]) > 1e-9
    expected = shapely_fraction(c[long], SPACE)
    np.testing.assert_allclose(got[long], expected, atol=1e-9)


@given(st.lists(st.tuples(*(st.integers(-1, 3) for _ in range(4))), min_size=1, max_size=30))
def test_inside_fraction_on_grid_points_where_segments_run_along_edges(coords):
    # integer end points against a polygon with integer vertices: collinear edges, vertex hits
    space = shapely.box(0, 0, 2, 2).difference(shapely.box(1, 1, 2, 2))  # an L shape
    c = np.array(coords, dtype=float)
    long = (c[:, :2] != c[:, 2:]).any(axis=1)
    got = inside_fraction(c[:, :2], c[:, 2:], space)
    np.testing.assert_allclose(got[long], shapely_fraction(c[long], space), atol=1e-9)


PARTS = [ROOM, shapely.Point(3, 3).buffer(1), shapely.box(1, 1, 3.5, 2.5), shapely.box(-0.5, 0.5, 0.5, 1.5)]
"""Overlapping polygons: a collection of them is the open space their union is."""


@given(st.lists(st.tuples(*(NANOMETRES for _ in range(4))), min_size=1, max_size=30))
def test_inside_fraction_of_overlapping_parts_is_that_of_their_union(coords):
    c = np.array(coords)
    parts = inside_fraction(c[:, :2], c[:, 2:], shapely.GeometryCollection(PARTS))
    np.testing.assert_allclose(parts, inside_fraction(c[:, :2], c[:, 2:], shapely.union_all(PARTS)), atol=1e-9)


@pytest.mark.parametrize(
    ("p", "q", "problem"),
    [
        ([[0, 0, 0]], [[1, 1, 1]], "shape"),
        ([[0, 0]], [[1, 1], [2, 2]], "same shape"),
        ([[0, np.nan]], [[1, 1]], "finite"),
    ],
)
def test_relation_refuses_bad_segments(p, q, problem):
    with pytest.raises(ValueError, match=problem):
        relation(p, q, ROOM)


def test_crossed_fractions_are_refused():
    with pytest.raises(ValueError, match=r"outside_fraction \(0.5\) must be below inside_fraction \(0.3\)"):
        NoiseParams(inside_fraction=0.3, outside_fraction=0.5)
