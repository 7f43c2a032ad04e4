"""New rules (n-ary PCR5, bold), every rule's declared behaviour on m(∅) > 0, and the
checks on rules registered from outside the engine."""

import numpy as np
import pytest
from engine_fixtures import FRAMES, PAPER, assert_same, masses, needs
from hypothesis import given, reject, settings
from hypothesis import strategies as st

from evidential import RULES, MassError, MassFunction, TotalConflictError, combine, combine_batch, register_rule
from evidential.registry import EMPTY_SET
from evidential.stack import Stack

ALL = sorted(RULES)
ABC = FRAMES[3]


def close(m, expected, tol=1e-12):
    assert m.to_dict().keys() == expected.keys()
    for k, v in expected.items():
        assert m[k] == pytest.approx(v, abs=tol)


# --- m(∅) > 0 in a source: every rule declares what it does, and does it ----------------------


def test_pcr6_refuses_a_source_with_mass_on_the_empty_set():
    # the known defect: PCR6 gave m(∅) = 0.033 for a source holding m(∅) = 0.2
    open_source = MassFunction(PAPER, {"": 0.2, "real": 0.8}, open_world=True)
    other = MassFunction(PAPER, {"noise": 0.5, "real|noise": 0.5})
    with pytest.raises(MassError, match="'pcr6'.*empty set.*0.2"):
        combine(open_source, other, rule="pcr6")
    with pytest.raises(MassError, match="'pcr6'.*batch row 1"):
        combine_batch([[0, 0, 0, 1.0], [0.2, 0.8, 0, 0]], [[0, 0, 0.5, 0.5]] * 2, rule="pcr6")


def test_every_rule_declares_its_behaviour_on_the_empty_set():
    assert {RULES[name].empty_set for name in ALL} <= EMPTY_SET.keys()
    assert RULES["pcr5"].empty_set == RULES["pcr6"].empty_set == RULES["dubois_prade"].empty_set == "refuse"
    assert RULES["conjunctive"].empty_set == "as_set" and RULES["dempster"].empty_set == "conflict"
    assert RULES["bold"].empty_set == "required" and RULES["bold"].open_world


@pytest.mark.parametrize("name", ALL)
@settings(max_examples=25)
@given(data=st.data())
def test_rule_does_on_the_empty_set_what_it_declares(name, data):
    rule = RULES[name]
    n = data.draw(st.integers(1, 4))
    need = needs(rule) | {"subnormal": True}
    ms = [data.draw(masses(n, **need)) for _ in range(2)]
    if rule.empty_set == "refuse":
        with pytest.raises(MassError, match=f"rule {name!r}.*m\\(∅\\)"):
            combine(*ms, rule=name)
        return
    try:
        m = combine(*ms, rule=name)
    except TotalConflictError:
        reject()
    assert np.all(m.masses > 0) and abs(m.masses.sum() - 1) < 1e-9
    if rule.empty_set == "conflict" and not rule.open_world:
        assert m[""] == 0.0
    if rule.empty_set == "as_set":  # ∅ ∩ A = ∅ and ∅ ∪ A = A: the conjunctive keeps K, the disjunctive prod m_i(∅)
        k = combine(*ms, rule="conjunctive")[""] if name == "conjunctive" else ms[0][""] * ms[1][""]
        assert m[""] == pytest.approx(k, abs=1e-12)


@pytest.mark.parametrize("name", [name for name in ALL if RULES[name].empty_set == "required"])
def test_rule_requiring_mass_on_the_empty_set_refuses_a_normal_source(name):
    normal = MassFunction(PAPER, {"real": 1.0})
    with pytest.raises(MassError, match=f"rule {name!r} needs every source with mass on the empty set"):
        combine(MassFunction(PAPER, {"": 0.5, "noise": 0.5}, open_world=True), normal, rule=name)


# --- n-ary PCR5 ---------------------------------------------------------------------------


def test_pcr5_zadeh_example():
    # Smarandache & Dezert (2005), "Information fusion based on new proportional conflict
    # redistribution rules" (Fusion 2005), Zadeh's example: m1(A) = .9, m1(C) = .1,
    # m2(B) = .9, m2(C) = .1 -> PCR5: A = B = .486, C = .028 (Dempster gives C = 1).
    m1 = MassFunction(ABC, {"w0": 0.9, "w2": 0.1})
    m2 = MassFunction(ABC, {"w1": 0.9, "w2": 0.1})
    close(combine(m1, m2, rule="pcr5"), {"w0": 0.486, "w1": 0.486, "w2": 0.028})
    close(combine(m1, m2, rule="pcr6"), {"w0": 0.486, "w1": 0.486, "w2": 0.028})


def test_pcr5_three_sources_differs_from_pcr6():
    # DSmT vol. 2 (Smarandache & Dezert 2006), ch. 1, eq. (1.32): a conflicting product goes to
    # the distinct sets in proportion to the product of the masses the sources give each;
    # PCR6 (Martin & Osswald 2006) uses the sum over sources instead. Hand-computed:
    # m1 = {A: .6, B: .4}, m2 = {A: .7, B: .3}, m3 = {B: 1}; m∩(B) = .12, and the clashes
    # (A, A, B) .42 -> A: .42 * .42 / 1.42; (A, B, B) .18 -> A: .18 * .6 / .9; (B, A, B) .28 -> A: .28 * .7 / 1.1.
    ab = FRAMES[2]
    ms = [
        MassFunction(ab, {"w0": 0.6, "w1": 0.4}),
        MassFunction(ab, {"w0": 0.7, "w1": 0.3}),
        MassFunction(ab, {"w1": 1.0}),
    ]
    a5 = 0.42 * 0.42 / 1.42 + 0.18 * 0.6 / 0.9 + 0.28 * 0.7 / 1.1
    a6 = 0.42 * 1.3 / 2.3 + 0.18 * 0.6 / 1.9 + 0.28 * 0.7 / 2.1
    close(combine(*ms, rule="pcr5"), {"w0": a5, "w1": 1 - a5})
    close(combine(*ms, rule="pcr6"), {"w0": a6, "w1": 1 - a6})


@settings(max_examples=40)
@given(a=masses(3), b=masses(3))
def test_pcr5_equals_pcr6_for_two_sources(a, b):
    assert_same(combine(a, b, rule="pcr5"), combine(a, b, rule="pcr6"))


# --- bold ---------------------------------------------------------------------------------


def test_bold_keeps_the_minimum_disjunctive_weights():
    # Denœux (2008), "Conjunctive and disjunctive combination of belief functions induced by
    # nondistinct bodies of evidence", AI 172, sec. 5: negative simple masses A_v (m(∅) = v,
    # m(A) = 1 - v) combine by v = min(v1, v2); on distinct sets the bold rule is the disjunctive one.
    a = MassFunction(ABC, {"": 0.3, "w0": 0.7}, open_world=True)
    a2 = MassFunction(ABC, {"": 0.6, "w0": 0.4}, open_world=True)
    close(combine(a, a2, rule="bold"), {"": 0.3, "w0": 0.7})
    b = MassFunction(ABC, {"": 0.5, "w1": 0.5}, open_world=True)
    a4 = MassFunction(ABC, {"": 0.4, "w0": 0.6}, open_world=True)
    close(combine(a4, b, rule="bold"), {"": 0.2, "w0": 0.3, "w1": 0.2, "w0|w1": 0.3})
    assert_same(combine(a4, b, rule="bold"), combine(a4, b, rule="disjunctive"))


def test_bold_needs_a_dense_frame():
    big = MassFunction.from_dict(
        __import__("evidential").Frame([f"e{i}" for i in range(21)]), {"": 1.0}, open_world=True
    )
    with pytest.raises(MassError, match="at most 20"):
        combine(big, big, rule="bold")


# --- rules registered from outside: results checked on every path --------------------------


@pytest.fixture
def plugin():
    names = []

    def register(name, result, **claims):
        register_rule(name, **claims)(lambda sources, n: result(sources[0]))
        names.append(name)
        return name

    yield register
    for name in names:
        del RULES[name]


BAD = {
    "negative": lambda s: Stack(s.masks, np.where(np.arange(s.masks.size)[:, None] == 0, -0.5, s.masses) * 1.0),
    "nan": lambda s: Stack(s.masks, np.full_like(s.masses, np.nan)),
    "sum": lambda s: Stack(s.masks, s.masses * 1.01),
    "empty_closed": lambda s: Stack(np.array([0, 3]), np.tile([[0.5], [0.5]], (1, s.masses.shape[1]))),
}


@pytest.mark.parametrize("defect", sorted(BAD))
def test_plugin_rule_returning_no_mass_function_is_refused_by_name(plugin, defect):
    name = plugin(f"plugin_{defect}", BAD[defect], empty_set="conflict")
    m = MassFunction(PAPER, {"real": 0.5, "noise": 0.3, "real|noise": 0.2})
    with pytest.raises(MassError, match=f"rule {name!r}"):
        combine(m, m, rule=name)
    with pytest.raises(MassError, match=f"rule {name!r}"):
        combine_batch([m.dense()] * 3, [m.dense()] * 3, rule=name)


def test_plugin_open_world_rule_may_return_mass_on_the_empty_set(plugin):
    name = plugin("plugin_open", BAD["empty_closed"], open_world=True, empty_set="as_set")
    m = MassFunction(PAPER, {"real": 1.0})
    assert combine(m, rule=name).to_dict() == {"": 0.5, "real|noise": 0.5}
    assert RULES[name].builtin is False


def test_plugin_rule_within_tolerance_passes(plugin):
    name = plugin("plugin_roundoff", lambda s: Stack(s.masks, s.masses * (1 + 1e-12)))
    m = MassFunction(PAPER, {"real": 0.5, "real|noise": 0.5})
    assert combine(m, rule=name)["real"] == pytest.approx(0.5)


def test_builtin_rules_run_without_result_checks():
    from evidential import rules

    for name in ALL:
        rule = RULES[name]
        assert rule.builtin
        raw = getattr(rule.function, "__wrapped__", rule.function)  # at most the ∅ guard around it
        assert not hasattr(raw, "__wrapped__") and getattr(rules, name) is rule.function
