"""Updates rebuild only the part of the map an observation touches: the result is the whole rebuild's."""

import numpy as np
import pytest

from evmap import configs
from evmap.maps.app.run import run_scenario
from evmap.maps.corners import find_corners
from evmap.maps.merging import merge_segments
from evmap.sources.config import load_config
from evmap.sources.relation import relation
from evmap.sources.sim.scenario import load_scenario


@pytest.fixture(scope="module")
def patrol():
    return run_scenario(load_scenario(configs.path("scenarios/patrol.yaml")), load_config())


def test_lines_are_the_merge_of_every_surviving_segment(patrol):
    store, config = patrol.map.segments, patrol.config
    assert relation(store.p, store.q, patrol.map.open_space, config.noise).tolist() == store.relation.tolist()
    keep = np.flatnonzero(~store.eliminated)
    merged = merge_segments(store.p[keep], store.q[keep], config.merge)
    whole = sorted(tuple(keep[g].tolist()) for g in merged.groups)
    local = sorted(tuple(sorted(d["members"])) for _, _, d in patrol.map.graph.edges(data=True))
    assert local == whole
    for _, _, d in patrol.map.graph.edges(data=True):
        assert (store.line[d["members"]] == d["id"]).all()
    assert (store.line[store.eliminated] == "").all()


def test_corners_are_those_of_every_line(patrol):
    g = patrol.map.graph
    fits = np.array([d["fit"] for _, _, d in g.edges(data=True)])
    whole = find_corners(fits[:, 0], fits[:, 1], patrol.config.corners)
    local = np.array(sorted(tuple(d["xy"]) for _, d in g.nodes(data=True) if d["kind"] == "corner"))
    np.testing.assert_allclose(local, np.array(sorted(map(tuple, whole.xy))), atol=1e-12)
    for n, d in g.nodes(data=True):  # an end point ends one line, a corner two or more
        if d["kind"] == "endpoint":
            assert g.degree(n) == 1
        elif d["kind"] == "corner":
            assert g.degree(n) >= 2
