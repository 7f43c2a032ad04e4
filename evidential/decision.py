"""Decisions under belief functions: lower, upper and pignistic expected utilities, the
Hurwicz criterion, interval dominance, maximality, and a reject option.

``utility`` is an (acts, n) array: ``utility[a, i]`` is the utility of act ``a``
when the truth is element ``i`` of the frame (Denœux 2019, "Decision-making with
belief functions: a review", IJAR 109).
"""

from __future__ import annotations

import math
from numbers import Real
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evidential.errors import MassError
from evidential.mass import MassFunction

CRITERIA = ("lower", "upper", "pignistic", "hurwicz")
"""The criteria :func:`choose` ranks acts by."""

TOLERANCE = 1e-12
"""An act beats another by more than this (round-off below it is a tie)."""


class ExpectedUtilities(NamedTuple):
    """Per act: E_* = sum m(A) min over A of u, E^* = sum m(A) max over A of u, and E under BetP."""

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    pignistic: NDArray[np.float64]


def _utility(m: MassFunction, utility: ArrayLike) -> NDArray[np.float64]:
    u = np.asarray(utility, dtype=np.float64)
    if u.ndim != 2 or u.shape[1] != len(m.frame) or not np.isfinite(u).all() or not u.size:
        raise MassError(f"utility must be a finite (acts, {len(m.frame)}) array, got shape {u.shape}")
    if m[""] > 0:
        raise MassError(f"decisions need a normal mass function, got m(∅) = {m['']!r}; normalise it first")
    return u


def _lower(m: MassFunction, u: NDArray[np.float64]) -> NDArray[np.float64]:
    """E_*(u) for every row of u (..., n)."""
    member = (m.masks[:, None] >> np.arange(len(m.frame)) & 1).astype(bool)  # (K, n)
    worst = np.where(member, u[..., None, :], np.inf).min(axis=-1)  # (..., K)
    return worst @ m.masses


def expected_utilities(m: MassFunction, utility: ArrayLike) -> ExpectedUtilities:
    """The lower, upper and pignistic expected utility of every act.

    Examples
    --------
    >>> from evidential import Frame
    >>> urn = MassFunction(Frame(["red", "black", "yellow"]), {"red": 1 / 3, "black|yellow": 2 / 3})
    >>> e = expected_utilities(urn, [[100, 0, 0], [0, 100, 0]])  # Ellsberg: bet on red, on black
    >>> e.lower.round(2).tolist(), e.upper.round(2).tolist(), e.pignistic.round(2).tolist()
    ([33.33, 0.0], [33.33, 66.67], [33.33, 33.33])
    """
    u = _utility(m, utility)
    betp = np.array(list(m.pignistic().values()))
    return ExpectedUtilities(_lower(m, u), -_lower(m, -u), u @ betp)


def hurwicz(m: MassFunction, utility: ArrayLike, pessimism: float) -> NDArray[np.float64]:
    """Hurwicz's criterion pessimism * E_* + (1 - pessimism) * E^* per act (Jaffray 1989).

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b"]), {"a": 0.5, "a|b": 0.5})
    >>> hurwicz(m, [[1.0, 0.0]], 0.25).tolist()
    [0.875]
    """
    if isinstance(pessimism, bool) or not isinstance(pessimism, Real) or not 0 <= pessimism <= 1:
        raise MassError(f"pessimism must be a number in [0, 1], got {pessimism!r}")
    e = expected_utilities(m, utility)
    return pessimism * e.lower + (1 - pessimism) * e.upper


def interval_dominance(m: MassFunction, utility: ArrayLike) -> list[int]:
    """The acts not interval-dominated: no act b with E_*(b) > E^*(a) (Troffaes 2007,
    "Decision making under uncertainty using imprecise probabilities", IJAR 45).

    Examples
    --------
    >>> from evidential import Frame
    >>> urn = MassFunction(Frame(["red", "black", "yellow"]), {"red": 1 / 3, "black|yellow": 2 / 3})
    >>> interval_dominance(urn, [[100, 0, 0], [0, 100, 0], [0, 0, 0]])
    [0, 1]
    """
    e = expected_utilities(m, utility)
    return np.flatnonzero(e.upper >= e.lower.max() - TOLERANCE).tolist()


def maximality(m: MassFunction, utility: ArrayLike) -> list[int]:
    """The maximal acts: no act b with E_*(u_b - u_a) > 0 (Walley 1991; Troffaes 2007).

    A subset of :func:`interval_dominance`; holds the act of best pignistic utility.

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b"]), {"a|b": 1.0})
    >>> maximality(m, [[1, 0], [2, 1], [0, 3]])  # act 0 is beaten by act 1 in every state
    [1, 2]
    """
    u = _utility(m, utility)
    gain = _lower(m, u[:, None, :] - u[None, :, :])  # gain[b, a] = E_*(u_b - u_a)
    return np.flatnonzero(~(gain > TOLERANCE).any(axis=0)).tolist()


def choose(
    m: MassFunction,
    utility: ArrayLike,
    *,
    criterion: str = "pignistic",
    pessimism: float = 0.5,
    reject: float | None = None,
) -> int | None:
    """The act of highest expected utility by ``criterion``, or ``None`` (abstain) when that
    utility is below ``reject``, the utility of rejection (Denœux 1997, "Analysis of
    evidence-theoretic decision rules for pattern classification", Pattern Recognition 30).

    Parameters
    ----------
    criterion : {"lower", "upper", "pignistic", "hurwicz"}
    pessimism : float
        For ``"hurwicz"``.
    reject : float, optional
        Abstain when the best act's value is below it.

    Examples
    --------
    >>> from evidential import Frame
    >>> m = MassFunction(Frame(["a", "b"]), {"a": 0.5, "a|b": 0.5})
    >>> u = [[1, 0], [0, 1]]
    >>> choose(m, u), choose(m, u, criterion="lower", reject=0.6), choose(m, u, criterion="upper")
    (0, None, 0)
    """
    if criterion not in CRITERIA:
        raise MassError(f"criterion must be one of {CRITERIA}, got {criterion!r}")
    if reject is not None and not (isinstance(reject, Real) and not isinstance(reject, bool) and math.isfinite(reject)):
        raise MassError(f"reject (the utility of abstaining) must be a finite number or None, got {reject!r}")
    if criterion == "hurwicz":
        value = hurwicz(m, utility, pessimism)
    else:
        value = getattr(expected_utilities(m, utility), criterion)
    best = int(np.argmax(value))
    return None if reject is not None and value[best] < reject else best
