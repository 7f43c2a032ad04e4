"""Matching actual and simulated RCDs by direction and range (paper, section III).

An RCD is summarised by its direction and its mean range. The cost of pairing
actual RCD i with simulated RCD j is

    ((theta_i - theta_j) / angle_scale)^2 + ((r_i - r_j) / range_scale)^2,

with the circular direction difference. A pair further apart than either gate
(direction or range) can never match, nor, with ``width_gate_deg``, a pair whose
actual RCD is wider than the simulated one by more than that: the sonar model
gives a target's echo a width by its strength and range, and a much wider one
came from a stronger target than the map's (a glass pane heard at normal
incidence beside a wall end, from which the map predicts only a weak edge's
echo). The matching is a global assignment (Kuhn–Munkres, with the potentials
and shortest augmenting paths of Jonker and Volgenant, as
``scipy.optimize.linear_sum_assignment`` solves it), not greedy first-come: it
matches as many gated pairs as possible and, among those assignments, the one
of least total cost. Gated-out pairs carry a finite cost
larger than any sum of admissible costs, so one more admissible pair always
wins, and they are dropped from the result. A pair exactly at a gate is
admissible.

The assignment is written here, over numpy rows, rather than imported from
scipy: importing ``scipy.optimize`` takes longer than a whole small run
computes, and a scan holds tens of RCDs, so the O(n^3) method costs well under
a millisecond (tests check it against scipy).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.geometry import wrapped
from evmap.sources.params import MatchParams

__all__ = ["match_rcds"]

# Slack on the gates, so that a pair exactly at a gate passes despite rounding.
_EPS = 1e-9


def match_rcds(
    actual_dir: ArrayLike,
    actual_range: ArrayLike,
    sim_dir: ArrayLike,
    sim_range: ArrayLike,
    params: MatchParams | None = None,
    widths: tuple[ArrayLike, ArrayLike] | None = None,
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Pair actual RCDs with simulated ones: gated, one-to-one, least total cost.

    Parameters
    ----------
    actual_dir, actual_range : (A,) directions (radians) and mean ranges (metres) of the actual RCDs.
    sim_dir, sim_range : (S,) the same for the simulated RCDs.
    params : scales and gates; ``MatchParams()`` (10 deg, 5 cm; gates 12.5 deg, 10 cm) if omitted.
    widths : (A,) and (S,) angular widths (radians) of the actual and simulated RCDs, for
        ``params.width_gate_deg`` (without them, or with that gate 0, widths are not compared).

    Returns
    -------
    ai, si : int arrays of equal length, the matched pairs (actual ai[k] with
        simulated si[k]), by increasing ai.

    Examples
    --------
    Greedy would pair actual 1 with simulated 0 (closest, 1 deg) and leave
    actual 0 with a 12 deg, costlier partner; the assignment does better:

    >>> deg = np.radians
    >>> match_rcds(deg([0, 5]), [2.0, 2.0], deg([4, 12]), [2.0, 2.0])
    (array([0, 1]), array([0, 1]))

    Outside a gate (here 20 cm in range) nothing matches:

    >>> match_rcds(deg([0]), [2.0], deg([0]), [2.2])
    (array([], dtype=int64), array([], dtype=int64))
    """
    params = MatchParams() if params is None else params
    a_dir, a_rng = _rcds(actual_dir, actual_range, "actual")
    s_dir, s_rng = _rcds(sim_dir, sim_range, "sim")
    dtheta = wrapped(a_dir[:, None] - s_dir[None, :])  # circular difference
    drange = a_rng[:, None] - s_rng[None, :]
    gate_a, scale_a = np.radians(params.angle_gate_deg), np.radians(params.angle_scale_deg)
    admissible = (np.abs(dtheta) <= gate_a + _EPS) & (np.abs(drange) <= params.range_gate + _EPS)
    if widths is not None and params.width_gate_deg > 0:
        a_width, s_width = (np.asarray(w, dtype=float) for w in widths)
        admissible &= a_width[:, None] <= s_width[None, :] + np.radians(params.width_gate_deg) + _EPS
    cost = (dtheta / scale_a) ** 2 + (drange / params.range_scale) ** 2
    # Larger than the total cost of any assignment of admissible pairs.
    worst = (gate_a / scale_a) ** 2 + (params.range_gate / params.range_scale) ** 2
    cost[~admissible] = (min(cost.shape) + 1) * (worst + 1)
    ai, si = _assign(cost)
    ok = admissible[ai, si]
    return ai[ok].astype(np.intp), si[ok].astype(np.intp)


def _rcds(direction: ArrayLike, rng: ArrayLike, name: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    d = np.asarray(direction, dtype=float)
    r = np.asarray(rng, dtype=float)
    if d.ndim != 1 or d.shape != r.shape:
        raise ValueError(f"{name}_dir and {name}_range must be 1-D of one length: got {d.shape} and {r.shape}")
    if not (np.isfinite(d).all() and np.isfinite(r).all()):
        raise ValueError(f"{name}_dir and {name}_range must be finite: found NaN or infinity")
    return d, r


def _assign(cost: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """A least-cost assignment of min(A, S) pairs, by increasing row: rows ``r[k]`` to columns ``c[k]``."""
    if cost.shape[0] > cost.shape[1]:
        c, r = _assign(cost.T)
        order = np.argsort(r)
        return r[order], c[order]
    n, m = cost.shape
    u, v = np.zeros(n + 1), np.zeros(m + 1)
    row_of = np.zeros(m + 1, dtype=np.intp)  # 1-based row holding each column; column 0 is the root
    for i in range(1, n + 1):
        row_of[0], j0 = i, 0
        slack, way = np.full(m + 1, np.inf), np.zeros(m + 1, dtype=np.intp)
        used = np.zeros(m + 1, dtype=bool)
        while True:  # grow the tree of shortest alternating paths until it reaches a free column
            used[j0] = True
            i0 = row_of[j0]
            reduced = cost[i0 - 1] - u[i0] - v[1:]
            better = ~used[1:] & (reduced < slack[1:])
            slack[1:][better] = reduced[better]
            way[1:][better] = j0
            j1 = int(np.argmin(np.where(used[1:], np.inf, slack[1:]))) + 1
            delta = slack[j1]
            u[row_of[used]] += delta
            v[used] -= delta
            slack[~used] -= delta
            j0 = j1
            if row_of[j0] == 0:
                break
        while j0:  # augment along the path
            j1 = way[j0]
            row_of[j0] = row_of[j1]
            j0 = j1
    cols = np.flatnonzero(row_of[1:])
    rows = row_of[1:][cols] - 1
    order = np.argsort(rows)
    return rows[order], cols[order]
