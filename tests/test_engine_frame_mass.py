"""Frames and mass functions: construction, access, and the errors on bad input."""

import math

import pytest

from evidential import Frame, FrameError, MassError, MassFunction, combine

FRAME = Frame(["real", "noise"])


def test_frame_is_ordered_and_compares_by_value():
    assert Frame(["a", "b"]) == Frame(("a", "b")) and Frame(["a", "b"]) != Frame(["b", "a"])
    assert hash(Frame(["a", "b"])) == hash(Frame(["a", "b"]))
    assert FRAME.elements == ("real", "noise") and len(FRAME) == 2 and FRAME.full == 3


@pytest.mark.parametrize(
    "elements, match",
    [
        ([], "at least one"),
        (["a", "a"], "'a' is given twice"),
        (["a|b"], "'a|b'"),
        ([""], "''"),
        ("ab", "string"),
        ([f"e{i}" for i in range(64)], "at most 63"),
    ],
)
def test_bad_frames(elements, match):
    with pytest.raises(FrameError, match=match):
        Frame(elements)


@pytest.mark.parametrize(
    "focal, mask", [("real", 1), ("noise|real", 3), (("noise",), 2), ("", 0), (3, 3), ({"real"}, 1)]
)
def test_focal_set_spellings(focal, mask):
    assert FRAME.mask(focal) == mask


def test_issue_example_access_and_to_dict():
    m1 = MassFunction(FRAME, {"real": 0.8, "noise": 0.1, "real|noise": 0.1})
    m2 = MassFunction(FRAME, {("real",): 0.3, FRAME.full: 0.7})
    assert m2["real"] == 0.3 and m2[FRAME.full] == 0.7 and m2["noise"] == 0.0
    assert m1.to_dict() == {"real": 0.8, "noise": 0.1, "real|noise": 0.1}
    assert MassFunction.from_dict(FRAME, m1.to_dict()).to_dict() == m1.to_dict()
    assert set(m1.pignistic()) == {"real", "noise"}


def test_open_world_mass_written_as_empty_string():
    m = combine(
        MassFunction(FRAME, {"real": 1.0}), MassFunction(FRAME, {"noise": 0.5, "real|noise": 0.5}), rule="conjunctive"
    )
    assert m.to_dict() == {"": 0.5, "real": 0.5}
    assert MassFunction(FRAME, m.to_dict(), open_world=True).to_dict() == m.to_dict()


@pytest.mark.parametrize(
    "masses, match",
    [
        ({"real": -0.1, "noise": 1.1}, r"'real' must be a finite number >= 0, got -0\.1"),
        ({"real": math.nan, "noise": 1.0}, "'real'.*nan"),
        ({"real": math.inf}, "'real'.*inf"),
        ({"real": 0.5, "noise": 0.6}, r"sum to 1.*1\.1"),
        ({"real": 0.5, "noise": 0.5 - 2e-9}, "sum to 1"),
        ({"": 0.2, "real": 0.8}, r"empty set '' is 0\.2"),
        ({"real|noise": 0.5, "noise|real": 0.5}, "given twice"),
        ({"real": "0.5", "noise": 0.5}, "'real'"),
    ],
)
def test_bad_masses_name_the_focal_set_and_value(masses, match):
    with pytest.raises(MassError, match=match):
        MassFunction(FRAME, masses)


def test_sum_within_tolerance_is_accepted():
    assert len(MassFunction(FRAME, {"real": 0.5, "noise": 0.5 - 5e-10})) == 2


def test_element_not_in_frame():
    with pytest.raises(FrameError, match="'sonar'.*not in"):
        MassFunction(FRAME, {"sonar": 1.0})
    with pytest.raises(FrameError, match="bitmask 4"):
        MassFunction(FRAME, {4: 1.0})


def test_masses_on_different_frames_refused():
    other = Frame(["real", "noise", "ghost"])
    with pytest.raises(FrameError, match="different frames"):
        combine(MassFunction(FRAME, {"real": 1.0}), MassFunction(other, {"real": 1.0}))


def test_errors_are_value_errors():
    for error in (FrameError, MassError):
        assert issubclass(error, ValueError)


def test_unknown_rule_and_bad_rule():
    m = MassFunction(FRAME, {"real": 1.0})
    with pytest.raises(ValueError, match="'nope' is not registered"):
        combine(m, m, rule="nope")
    with pytest.raises(ValueError, match="at least one"):
        combine(rule="dempster")


def test_dense_round_trip_and_zero_masses_dropped():
    m = MassFunction(FRAME, {"real": 0.25, "noise": 0.0, "real|noise": 0.75})
    assert len(m) == 2 and m.dense().tolist() == [0.0, 0.25, 0.0, 0.75]
    assert MassFunction.from_dense(FRAME, m.dense()).to_dict() == m.to_dict()
    with pytest.raises(MassError, match="shape"):
        MassFunction.from_dense(FRAME, [1.0, 0.0])
