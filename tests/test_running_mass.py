"""A line's or corner's running mass of its sonar records against the full fold of its history."""

import numpy as np
import pytest

from evidential import MassFunction, combine
from evmap import configs
from evmap.maps.app.run import run_scenario
from evmap.maps.running_mass import NOISE_STAGE, running_of
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import load_scenario


def full_fold(bm, history):
    """The history folded record by record, as maps did before running masses."""
    masses = [MassFunction.from_dict(bm.frame, r["mass"], open_world=True) for r in history]
    mass = masses[0]
    for m in masses[1:]:
        mass = combine(mass, m, rule=bm.rule)
    return mass


@pytest.fixture(scope="module", params=["dempster", "yager"])
def patrol(request):
    scenario = load_scenario(configs.path("scenarios/patrol.yaml"))
    return run_scenario(scenario, load_config().with_rule(request.param))


def test_the_kept_running_mass_is_the_one_made_from_the_history(patrol):
    bm = patrol.map
    ids = [*bm.line_ids(), *bm.graph.nodes]
    kept = {i: bm.running_mass(i) for i in ids}
    reinforced = [i for i in ids if kept[i] is not None]
    assert len(reinforced) > 10  # the patrol's sonar reinforced many objects
    for i in ids:
        evidence = (
            [r for r in bm.graph.nodes[i]["history"] if r.get("stage") != NOISE_STAGE]
            if i in bm.graph
            else [r for r in bm.graph.edge(*bm.ends(i))["history"] if r.get("stage") != NOISE_STAGE]
        )
        made = running_of(bm.frame, evidence, bm.rule)
        if made is None:
            assert kept[i] is None
        else:
            np.testing.assert_allclose(kept[i].dense(), made.dense(), atol=1e-12)


def test_under_an_associative_rule_a_line_s_mass_is_its_history_folded(patrol):
    bm = patrol.map
    lines = [i for i in bm.line_ids() if len(bm.graph.edge(*bm.ends(i))["history"]) > 1]
    assert lines
    gaps = [
        np.abs(bm.mass(i).dense() - full_fold(bm, bm.graph.edge(*bm.ends(i))["history"]).dense()).max() for i in lines
    ]
    if bm.rule == "dempster":
        assert max(gaps) < 1e-12
    else:  # not associative: first + (r1 + ... + rn) is the mass; the record-by-record fold stays close
        assert max(gaps) < 0.01
