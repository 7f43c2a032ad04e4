"""Canonical decompositions (conjunctive weights w, disjunctive weights v) and decombination.

A non-dogmatic mass function (m(Θ) > 0) is the conjunctive combination of the
generalized simple mass functions A^w(A), A ≠ Θ (m(A) = 1 - w, m(Θ) = w);
a subnormal one (m(∅) > 0) is the disjunctive combination of the A_v(A), A ≠ ∅
(m(∅) = v, m(A) = 1 - v) (Smets 1995, "The canonical decomposition of a
weighted belief", IJCAI; Denœux 2008, AI 172). Weights are dense vectors of
length 2**n by bitmask, with the neutral w(Θ) = 1 and v(∅) = 1.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential.errors import MassError
from evidential.frame import Frame
from evidential.mass import MassFunction
from evidential.transforms import commonality, implicability, mass_from_commonality, mass_from_implicability
from evidential.validation import SUM_TOLERANCE


def conjunctive_weights(m: MassFunction) -> NDArray[np.float64]:
    """The conjunctive weights w(A) = prod over B ⊇ A of q(B)^((-1)^(|B| - |A| + 1)), A ≠ Θ.

    Parameters
    ----------
    m : MassFunction
        Non-dogmatic (m(Θ) > 0).

    Examples
    --------
    >>> frame = Frame(["a", "b"])
    >>> conjunctive_weights(MassFunction(frame, {"a": 0.3, "b": 0.3, "a|b": 0.4})).round(4).tolist()
    [1.225, 0.5714, 0.5714, 1.0]
    """
    q = commonality(m.dense())
    if not q[-1] > 0:
        raise MassError(
            f"conjunctive weights need a non-dogmatic mass function (m(Θ) > 0), got m(Θ) = {float(q[-1])!r}"
        )
    log_w = -mass_from_commonality(np.log(q))
    log_w[-1] = 0.0
    return np.exp(log_w)


def disjunctive_weights(m: MassFunction) -> NDArray[np.float64]:
    """The disjunctive weights v(A) = prod over B ⊆ A of b(B)^((-1)^(|A| - |B| + 1)), A ≠ ∅.

    Parameters
    ----------
    m : MassFunction
        Subnormal (m(∅) > 0).

    Examples
    --------
    >>> frame = Frame(["a", "b"])
    >>> disjunctive_weights(MassFunction(frame, {"": 0.4, "a": 0.6}, open_world=True)).round(12).tolist()
    [1.0, 0.4, 1.0, 1.0]
    """
    b = implicability(m.dense())
    if not b[0] > 0:
        raise MassError(f"disjunctive weights need a subnormal mass function (m(∅) > 0), got m(∅) = {float(b[0])!r}")
    log_v = -mass_from_implicability(np.log(b))
    log_v[0] = 0.0
    return np.exp(log_v)


def _weights(frame: Frame, weights: ArrayLike, name: str) -> NDArray[np.float64]:
    w = np.array(weights, dtype=np.float64)
    if w.shape != (1 << len(frame),) or not w.min() > 0 or not w.max() < np.inf:
        raise MassError(f"{name} must be {1 << len(frame)} finite positive weights over {frame!r}, got {weights!r}")
    return w


def _checked(frame: Frame, m: NDArray[np.float64], what: str) -> MassFunction:
    """The open-world mass function of a dense vector from a transform, round-off removed."""
    if m.min() < -SUM_TOLERANCE:
        k = int(np.argmin(m))
        raise MassError(f"{what} gives m({frame.label(k)!r}) = {float(m[k])!r} < 0: not a mass function")
    m[np.abs(m) <= SUM_TOLERANCE * 1e-3] = 0.0
    return MassFunction.from_dense(frame, np.clip(m, 0.0, None), open_world=True)


def from_conjunctive_weights(frame: Frame, weights: ArrayLike) -> MassFunction:
    """The mass function whose conjunctive weights are ``weights`` (w(Θ) is ignored).

    Raises :class:`MassError` when the weights define no mass function (some m(A) < 0).

    Examples
    --------
    >>> frame = Frame(["a", "b", "c"])
    >>> w = np.ones(8); w[1], w[3] = 0.3, 0.6  # {a}^0.3 ∩ {a, b}^0.6
    >>> {k: round(v, 12) for k, v in from_conjunctive_weights(frame, w).to_dict().items()}
    {'a': 0.7, 'a|b': 0.12, 'a|b|c': 0.18}
    """
    log_w = np.log(_weights(frame, weights, "weights"))
    log_w[-1] = -log_w[:-1].sum()  # so that ln q(A) = -(sum of ln w over B ⊇ A)
    return _checked(frame, mass_from_commonality(np.exp(-commonality(log_w))), "these conjunctive weights")


def from_disjunctive_weights(frame: Frame, weights: ArrayLike) -> MassFunction:
    """The mass function whose disjunctive weights are ``weights`` (v(∅) is ignored).

    Examples
    --------
    >>> frame = Frame(["a", "b"])
    >>> v = np.ones(4); v[1], v[2] = 0.4, 0.5  # {a}_0.4 ∪ {b}_0.5
    >>> {k: round(x, 12) for k, x in from_disjunctive_weights(frame, v).to_dict().items()}
    {'': 0.2, 'a': 0.3, 'b': 0.2, 'a|b': 0.3}
    """
    log_v = np.log(_weights(frame, weights, "weights"))
    log_v[0] = -log_v[1:].sum()  # so that ln b(A) = -(sum of ln v over B ⊆ A)
    return _checked(frame, mass_from_implicability(np.exp(-implicability(log_v))), "these disjunctive weights")


def decombine(m12: MassFunction, m2: MassFunction) -> MassFunction:
    """The inverse of the conjunctive rule: m1 such that m1 ∩ m2 = m12, q1 = q12 / q2 (Smets 1995).

    Parameters
    ----------
    m12 : MassFunction
        The combination.
    m2 : MassFunction
        The removed source; non-dogmatic (q2 > 0 everywhere), else m1 is not unique.

    Raises
    ------
    MassError
        When m2 is dogmatic, or when no mass function m1 gives m12 (q12 / q2 is
        not a commonality function).

    Examples
    --------
    >>> frame = Frame(["a", "b"])
    >>> m1, m2 = MassFunction(frame, {"a": 0.6, "a|b": 0.4}), MassFunction(frame, {"b": 0.5, "a|b": 0.5})
    >>> from evidential import combine
    >>> {k: round(v, 12) for k, v in decombine(combine(m1, m2, rule="conjunctive"), m2).to_dict().items()}
    {'a': 0.6, 'a|b': 0.4}
    """
    if m12.frame != m2.frame:
        raise MassError(f"decombine needs masses on one frame: m12 is on {m12.frame!r}, m2 on {m2.frame!r}")
    q2 = commonality(m2.dense())
    if not q2[-1] > 0:
        raise MassError(f"decombine needs a non-dogmatic m2 (m(Θ) > 0, so q2 > 0), got m2(Θ) = {float(q2[-1])!r}")
    return _checked(m12.frame, mass_from_commonality(commonality(m12.dense()) / q2), "decombining m2 from m12")
