"""Known answers from the literature, to 1e-9, for every rule."""

import pytest
from engine_fixtures import total_conflict

from evidential import Frame, MassError, MassFunction, TotalConflictError, combine, conflict

ZADEH = Frame(["M", "C", "T"])  # meningitis, concussion, tumour


@pytest.fixture
def zadeh():
    return MassFunction(ZADEH, {"M": 0.99, "T": 0.01}), MassFunction(ZADEH, {"C": 0.99, "T": 0.01})


def close(m, expected):
    got = m.to_dict()
    assert got.keys() == expected.keys()
    for k, v in expected.items():
        assert got[k] == pytest.approx(v, abs=1e-9), k


# Zadeh (1986): the classic counter-example, as the issue states it.
EXPECTED_ZADEH = {
    "dempster": {"T": 1.0},
    "conjunctive": {"": 0.9999, "T": 0.0001},
    "yager": {"T": 0.0001, "M|C|T": 0.9999},
    "dubois_prade": {"M|C": 0.9801, "T": 0.0001, "M|T": 0.0099, "C|T": 0.0099},
    "disjunctive": {"M|C": 0.9801, "T": 0.0001, "M|T": 0.0099, "C|T": 0.0099},
    # Smarandache & Dezert, DSmT vol. 2 (2006), PCR5 on Zadeh's example.
    "pcr6": {"M": 0.499851, "C": 0.499851, "T": 0.000298},
    # Murphy (2000): average {M: .495, C: .495, T: .01} combined with itself.
    "murphy": {"M": 0.245025 / 0.49015, "C": 0.245025 / 0.49015, "T": 0.0001 / 0.49015},
    "bayes": {"T": 1.0},
}


@pytest.mark.parametrize("rule", sorted(EXPECTED_ZADEH))
def test_zadeh(zadeh, rule):
    close(combine(*zadeh, rule=rule), EXPECTED_ZADEH[rule])


def test_zadeh_conflict(zadeh):
    assert conflict(*zadeh) == pytest.approx(0.9999, abs=1e-12)


def test_pcr5_two_sources_dsmt_book():
    # Smarandache & Dezert (2006), DSmT vol. 2, ch. 1: m1(A) = .6, m1(A∪B) = .4;
    # m2(B) = .3, m2(A∪B) = .7; the partial conflict .18 goes back .12 to A, .06 to B.
    frame = Frame(["A", "B"])
    m1 = MassFunction(frame, {"A": 0.6, "A|B": 0.4})
    m2 = MassFunction(frame, {"B": 0.3, "A|B": 0.7})
    close(combine(m1, m2, rule="pcr6"), {"A": 0.54, "B": 0.18, "A|B": 0.28})


def test_pcr6_three_sources_martin_osswald():
    # Martin & Osswald (2006): for three Bayesian sources on {A, B} the product
    # m1(A) m2(B) m3(B) goes back to A and to B in proportion to m1(A) and m2(B) + m3(B).
    frame = Frame(["A", "B"])
    m1 = MassFunction(frame, {"A": 0.6, "B": 0.4})
    m2 = MassFunction(frame, {"A": 0.2, "B": 0.8})
    m3 = MassFunction(frame, {"A": 0.5, "B": 0.5})
    a, b = [0.6, 0.2, 0.5], [0.4, 0.8, 0.5]
    mass = {"A": a[0] * a[1] * a[2], "B": b[0] * b[1] * b[2]}
    for combo in [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (1, 0, 1), (1, 1, 0)]:
        xs = [a[i] if c == 0 else b[i] for i, c in enumerate(combo)]
        w = xs[0] * xs[1] * xs[2]
        for i, c in enumerate(combo):
            mass["AB"[c]] += w * xs[i] / sum(xs)
    close(combine(m1, m2, m3, rule="pcr6"), mass)


def test_cautious_denoeux_separable():
    # Denœux (2008): for separable masses the cautious rule takes the minimum of the
    # canonical weights. m1 = {a,b}^.3 ∧ {b,c}^.6 and m2 = {a,b}^.5 ∧ {b,c}^.4 give
    # {a,b}^.3 ∧ {b,c}^.4.
    frame = Frame(["a", "b", "c"])
    m1 = MassFunction(frame, {"b": 0.28, "a|b": 0.42, "b|c": 0.12, frame.full: 0.18})
    m2 = MassFunction(frame, {"b": 0.30, "a|b": 0.20, "b|c": 0.30, frame.full: 0.20})
    close(combine(m1, m2, rule="cautious"), {"b": 0.42, "a|b": 0.28, "b|c": 0.18, "a|b|c": 0.12})


def test_cautious_simple_masses_with_one_focus_keep_the_more_committed():
    frame = Frame(["a", "b"])
    m1 = MassFunction(frame, {"a": 0.7, "a|b": 0.3})
    m2 = MassFunction(frame, {"a": 0.4, "a|b": 0.6})
    close(combine(m1, m2, rule="cautious"), {"a": 0.7, "a|b": 0.3})


def test_cautious_rejects_dogmatic_sources():
    frame = Frame(["a", "b"])
    with pytest.raises(MassError, match="non-dogmatic.*source 1"):
        combine(MassFunction(frame, {"a|b": 1.0}), MassFunction(frame, {"a": 1.0}), rule="cautious")


def test_dempster_textbook_two_sources():
    # Shafer-style example: m1 = {r: .8, n: .1, Θ: .1}, m2 = {r: .3, Θ: .7}; K = .03.
    frame = Frame(["real", "noise"])
    m1 = MassFunction(frame, {"real": 0.8, "noise": 0.1, "real|noise": 0.1})
    m2 = MassFunction(frame, {("real",): 0.3, frame.full: 0.7})
    close(combine(m1, m2), {"real": 0.83 / 0.97, "noise": 0.07 / 0.97, "real|noise": 0.07 / 0.97})
    assert conflict(m1, m2) == pytest.approx(0.03, abs=1e-12)


def test_total_conflict_raises_with_k_in_message():
    with pytest.raises(TotalConflictError, match=r"K = 1\.0"):
        combine(*total_conflict())
    with pytest.raises(TotalConflictError):
        combine(*total_conflict(), rule="bayes")
    assert issubclass(TotalConflictError, ValueError)


def test_near_total_conflict_combines_exactly():
    # K = 1 - 2e-10: no tolerance turns it into an error, no small mass is dropped.
    eps = 1e-10
    frame = Frame(["a", "b"])
    m1 = MassFunction(frame, {"a": 1 - eps, "a|b": eps})
    m2 = MassFunction(frame, {"b": 1 - eps, "a|b": eps})
    z = 2 * eps * (1 - eps) + eps * eps  # the non-conflicting mass
    assert conflict(m1, m2) == pytest.approx(1 - z, abs=1e-16)
    close(combine(m1, m2), {"a": (1 - eps) * eps / z, "b": eps * (1 - eps) / z, "a|b": eps * eps / z})
