"""Product frames (vacuous extension, marginalisation), refinement and coarsening."""

import pytest
from engine_fixtures import assert_same, masses
from hypothesis import given, settings
from hypothesis import strategies as st

from evidential import Frame, FrameError, MassFunction, combine
from evidential.product import marginalize, product_frame, vacuous_extension
from evidential.refinement import coarsen, refine

X, Y, Z = Frame(["x1", "x2"]), Frame(["y1", "y2"]), Frame(["z1", "z2", "z3"])
COARSE, FINE = Frame(["car", "person"]), Frame(["sedan", "truck", "adult", "child"])
RHO = {"car": "sedan|truck", "person": "adult|child"}


def test_product_frame_elements_in_row_major_order():
    assert product_frame(X, Z).elements == ("x1,z1", "x1,z2", "x1,z3", "x2,z1", "x2,z2", "x2,z3")
    with pytest.raises(FrameError, match="at most 63"):
        product_frame(*[X] * 6)


def test_marginal_and_extension_known_answer():
    # Shafer (1976), ch. 6 / Kohlas & Monney (1995): the marginal of a focal set is its
    # projection; the vacuous extension is the cylinder.
    xy = product_frame(X, Y)
    m = MassFunction(xy, {"x1,y1|x2,y2": 0.6, "x1,y1|x1,y2": 0.4})
    assert marginalize(m, [X, Y], 0).to_dict() == {"x1": 0.4, "x1|x2": 0.6}
    assert marginalize(m, [X, Y], 1).to_dict() == {"y1|y2": 1.0}
    assert vacuous_extension(MassFunction(X, {"x1": 1.0}), [X, Y], 0).to_dict() == {"x1,y1|x1,y2": 1.0}


@settings(max_examples=30)
@given(m=masses(3), axis=st.integers(0, 2))
def test_marginal_of_the_vacuous_extension_is_the_mass_function(m, axis):
    frames = [X, Y, Z]
    frames[axis] = m.frame
    assert_same(marginalize(vacuous_extension(m, frames, axis), frames, axis), m)


@settings(max_examples=30)
@given(a=masses(2), b=masses(2))
def test_combining_extensions_of_independent_variables_is_their_product(a, b):
    # on X × Y, the extensions of a (on X) and b (on Y) combine to a × b; its marginals are a and b.
    x, y = a.frame, Frame(["v0", "v1"])
    b = MassFunction(y, dict(zip(b.masks.tolist(), b.masses.tolist())))
    joint = combine(vacuous_extension(a, [x, y], 0), vacuous_extension(b, [x, y], 1))
    assert_same(marginalize(joint, [x, y], 0), a)
    assert_same(marginalize(joint, [x, y], 1), b)
    assert len(joint) == len(a) * len(b)


def test_several_axes():
    xyz = product_frame(X, Y, Z)
    m = MassFunction(product_frame(X, Z), {"x1,z1": 0.5, "x2,z3|x1,z1": 0.5})
    ext = vacuous_extension(m, [X, Y, Z], (0, 2))
    assert ext.frame == xyz and ext["x1,y1,z1|x1,y2,z1"] == 0.5
    assert_same(marginalize(ext, [X, Y, Z], (0, 2)), m)
    with pytest.raises(FrameError, match="axes must be distinct"):
        marginalize(ext, [X, Y, Z], (0, 0))
    with pytest.raises(FrameError, match="expected Frame"):
        marginalize(m, [X, Y, Z], 0)


def test_refine_and_coarsen_known_answers():
    # Shafer (1976), ch. 6: the restriction of bel to the coarse frame is bel(ρ(A)) (outer
    # reduction); Denœux & Ben Yaghlane (2002): the inner reduction is more committed.
    m = MassFunction(FINE, {"sedan": 0.5, "truck|adult|child": 0.5})
    assert coarsen(m, COARSE, RHO).to_dict() == {"car": 0.5, "car|person": 0.5}
    assert coarsen(m, COARSE, RHO, outer=False).to_dict() == {"": 0.5, "person": 0.5}
    for a in range(1, 4):
        rho_a = int(refine(MassFunction(COARSE, {a: 1.0}), FINE, RHO).masks[0])
        assert coarsen(m, COARSE, RHO).belief(a) == pytest.approx(m.belief(rho_a))


@settings(max_examples=30)
@given(m=masses(2))
def test_coarsening_the_refinement_gives_back_the_mass_function(m):
    coarse = Frame(["car", "person"])
    m = MassFunction(coarse, dict(zip(m.masks.tolist(), m.masses.tolist())))
    fine = refine(m, FINE, RHO)
    assert_same(coarsen(fine, coarse, RHO), m)
    assert_same(coarsen(fine, coarse, RHO, outer=False), m)


def test_refining_is_checked():
    with pytest.raises(FrameError, match="every element"):
        refine(MassFunction(COARSE, {"car": 1.0}), FINE, {"car": "sedan"})
    with pytest.raises(FrameError, match="disjoint"):
        refine(MassFunction(COARSE, {"car": 1.0}), FINE, {"car": "sedan|truck", "person": "truck|adult|child"})
    with pytest.raises(FrameError, match="cover.*'child'"):
        refine(MassFunction(COARSE, {"car": 1.0}), FINE, {"car": "sedan|truck", "person": "adult"})
