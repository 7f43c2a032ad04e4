"""Frames and mass functions: construction, access, and the errors on bad input."""

import math
import pickle

import numpy as np
import pytest
from engine_fixtures import masses
from hypothesis import given
from hypothesis import strategies as st

from evidential import Frame, FrameError, MassError, MassFunction, combine, combine_batch
from evidential.frame import LABEL_CACHE_SIZE

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


def test_a_label_read_again_has_the_same_mask_and_a_bad_one_the_same_error():
    """Labels are parsed once and kept; a bad label is not kept: it fails each time with the same error."""
    frame = Frame(["a", "b", "c"])
    bad = "a|x"
    errors = []
    for _ in range(2):
        assert [frame.mask(s) for s in ("a", "c|a", " b | a ", "", "a|b|c")] == [1, 5, 3, 0, 7]
        with pytest.raises(FrameError) as caught:
            frame.mask(bad)
        errors.append(str(caught.value))
    assert errors == [f"focal set 'a|x': element 'x' is not in {frame!r}"] * 2
    for focal, match in [(True, "got a bool"), (8, "outside 0..7"), (-1, "outside 0..7"), (1.0, "got a float")]:
        with pytest.raises(FrameError, match=match):
            frame.mask(focal)
    assert Frame(["c", "b", "a"]).mask("c|a") == 5 and Frame(["b", "a"]).mask("a") == 2  # a frame's own labels
    assert pickle.loads(pickle.dumps(frame)).mask("c|a") == 5


def test_labels_beyond_the_kept_ones_are_still_read():
    frame = Frame(["a", "b"])
    spellings = [" " * i + "b|a" for i in range(LABEL_CACHE_SIZE + 10)]  # all different labels
    assert {frame.mask(s) for s in spellings} == {3} and {frame.mask(s) for s in spellings} == {3}
    with pytest.raises(FrameError, match="element 'c' is not in"):
        frame.mask("a|c")


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


@given(st.integers(1, 4).flatmap(lambda n: st.lists(masses(n), min_size=1, max_size=5)))
def test_from_rows_makes_what_the_constructor_makes(ms):
    frame = ms[0].frame
    rows = np.array([m.dense() for m in ms])
    for made, m in zip(MassFunction.from_rows(frame, np.arange(1 << len(frame)), rows), ms, strict=True):
        assert made.to_dict() == m.to_dict() and made.masks.tolist() == m.masks.tolist()


def test_from_rows_takes_a_combine_batch_result_and_any_spelling_of_focal_sets():
    M1 = np.array([[0, 0.8, 0.1, 0.1], [0, 0.5, 0.5, 0]])
    M2 = np.array([[0, 0.3, 0, 0.7], [0, 0, 0, 1.0]])
    rows = MassFunction.from_rows(FRAME, np.arange(4), combine_batch(M1, M2))
    objects = [combine(*(MassFunction.from_dense(FRAME, M[j]) for M in (M1, M2))) for j in range(2)]
    assert [m.to_dict() for m in rows] == [m.to_dict() for m in objects]
    spelled = MassFunction.from_rows(FRAME, ["real|noise", ("real",), np.int64(2)], [[0.5, 0.25, 0.25]])
    assert spelled[0].to_dict() == {"real": 0.25, "noise": 0.25, "real|noise": 0.5}


def test_mass_function_arrays_are_read_only():
    for m in (MassFunction(FRAME, {"real": 1.0}), MassFunction.from_rows(FRAME, [1], [[1.0]])[0]):
        for array in (m.masks, m.masses):
            with pytest.raises(ValueError, match="read-only"):
                array[0] = 0


@pytest.mark.parametrize(
    "masks, rows, match",
    [
        ([1, 3], [[0.5, 0.5], [1.5, -0.5]], r"row 1: mass of focal set 'real\|noise' must be .* got -0\.5"),
        ([1, 3], [[0.5, 0.5], [np.nan, 1.0]], "row 1: mass of focal set 'real' must be a finite number >= 0, got nan"),
        ([1, 3], [[np.inf, 0.0]], "row 0: .* got inf"),
        ([1, 3], [[0.5, 0.5], [0.5, 0.6]], r"row 1: masses must sum to 1 \(within 1e-09\), got 1\.1"),
        ([0, 1], [[0.0, 1.0], [0.2, 0.8]], "row 1: mass on the empty set '' needs open_world=True"),
        ([1, "real"], [[0.5, 0.5]], "focal set 'real' is given twice"),
        ([1, 3], [[0.5, 0.25, 0.25]], r"rows must have shape \(N, 2\) for 2 focal sets, got \(1, 3\)"),
        ([1, 3], [["a", "b"]], "rows must be real numbers, got an array of <U1"),
        ([1, 3], [["0.5", "0.5"]], "rows must be real numbers"),  # as a mapping's masses: a string is no number
        ([1, 3], [[True, False]], "rows must be real numbers, got an array of bool"),
        ([1, 3], [[0.5 + 0j, 0.5]], "rows must be real numbers, got an array of complex128"),
        ([1, 3], [[0.5, [0.5]]], "rows must be an .* array of numbers"),
        (np.array([1, 4]), [[0.5, 0.5]], "focal set 4 is not a subset of"),
        (["real", "wall"], [[0.5, 0.5]], "element 'wall' is not in"),
    ],
)
def test_from_rows_errors_name_the_row_and_the_focal_set(masks, rows, match):
    with pytest.raises(ValueError, match=match):
        MassFunction.from_rows(FRAME, masks, rows)
    assert MassFunction.from_rows(FRAME, [0, 1], [[0.2, 0.8]], open_world=True)[0].to_dict() == {"": 0.2, "real": 0.8}


def test_a_frame_needs_an_order_and_a_focal_set_a_bitmask_or_names():
    with pytest.raises(FrameError, match="must be in an order \\(a list or tuple\\), got a set"):
        Frame({"a", "b"})  # bit i would depend on the hash seed
    frame = Frame(["a", "b"])
    for focal in (1.0, None):
        with pytest.raises(FrameError, match=f"focal set {focal!r} must be a bitmask, a name or names"):
            MassFunction(frame, {focal: 1.0})
    assert Frame(name for name in ("a", "b")) == frame  # any ordered iterable
