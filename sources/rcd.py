"""Regions of constant depth (RCDs) of a rotational sonar scan, and their types (paper, II.A).

An RCD (Leonard & Durrant-Whyte 1992) is a run of consecutive readings of about the
same range. Extraction (``docs/METHOD.md``): a run grows while
every one of its readings stays within ``range_tolerance`` of the run's median.
Runs are cut greedily along the scan; a closed (full-turn) scan wraps around and is
cut first at its largest range jump, so a run may cross the end of the scan.
*Primitive* RCDs have no minimum width (a single reading is one); RCDs used for
matching and counts are at least ``min_width_deg`` wide.

Types, from the single readings just outside the run (its neighbours; wrapping):

- IV (multiple reflection): the mean range is at max range (within the tolerance),
  or longer than a neighbour by more than ``jump_threshold``. Tested first.
- I: both neighbours longer (the echo point lies within the RCD; open all over).
- II: one neighbour shorter, the other longer (small corners and edges).
- III: both neighbours shorter (a passage to open space, or a multiple reflection).

A neighbour is *shorter* when its range is below the RCD's mean range, else longer.
An RCD without neighbours (a scan that is one run) is Type I unless at max range;
at the ends of a scan that is not closed, the missing neighbour is ignored.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.sources.geometry import wrapped
from evmap.sources.params import RcdParams
from evmap.sources.readings import SonarScan

__all__ = ["TYPE_I", "TYPE_II", "TYPE_III", "TYPE_IV", "TYPE_NAMES", "Rcds", "extract_rcds", "wide_rcds"]

TYPE_I, TYPE_II, TYPE_III, TYPE_IV = 1, 2, 3, 4
"""The values of :attr:`Rcds.type`."""

TYPE_NAMES = {TYPE_I: "I", TYPE_II: "II", TYPE_III: "III", TYPE_IV: "IV"}
"""The paper's names of the RCD types (the ``rcd_type`` feature of the evidence sources)."""


@dataclass(frozen=True, eq=False)
class Rcds:
    """The RCDs of one scan as arrays, one entry per RCD, ordered by first reading.

    Attributes
    ----------
    start, end : (K,) int: index of the first and the last reading (inclusive). An
        RCD that wraps past the end of a closed scan has ``end < start``.
    count : (K,) int: number of readings.
    width : (K,) float: angular extent (rad): from the first to the last beam axis,
        plus one step (so a single reading is one step wide).
    direction : (K,) float: mean beam-axis angle along the run (rad, in (-pi, pi]).
    range, min_range : (K,) float: mean and shortest range of the readings (m).
    type : (K,) int: 1, 2, 3 or 4 (Types I-IV).
    prev_range, next_range : (K,) float: the neighbouring readings before the first
        and after the last reading (m); NaN where there is none.
    target : (K,) str: the target id most of the readings share ("" for none).
    order : (K,) int: the reflection order most of the readings share.
    """

    start: NDArray[np.intp]
    end: NDArray[np.intp]
    count: NDArray[np.intp]
    width: NDArray[np.float64]
    direction: NDArray[np.float64]
    range: NDArray[np.float64]
    min_range: NDArray[np.float64]
    type: NDArray[np.int_]
    prev_range: NDArray[np.float64]
    next_range: NDArray[np.float64]
    target: NDArray[np.str_]
    order: NDArray[np.int_]

    def __len__(self) -> int:
        return len(self.start)

    def select(self, which: ArrayLike) -> Rcds:
        """The RCDs picked by a boolean mask or an index array.

        >>> from evmap.sources.params import SonarParams
        >>> rcds = extract_rcds(SonarScan.from_readings(np.radians([0, 1, 2, 3]), [1, 1, 2, 2], SonarParams()),
        ...                     RcdParams(), primitive=True)
        >>> len(rcds), len(rcds.select(rcds.type == 1))
        (2, 1)
        """
        return Rcds(**{f.name: getattr(self, f.name)[which] for f in fields(self)})


def _runs(r: NDArray[np.float64], tol: float) -> list[tuple[int, int]]:
    """Greedy runs ``[i, j)`` of readings each within ``tol`` of the run's median."""
    runs = []
    i, m = 0, len(r)
    while i < m:
        ordered = [float(r[i])]
        j = i + 1
        while j < m:
            bisect.insort(ordered, float(r[j]))
            k = len(ordered)
            median = (ordered[(k - 1) // 2] + ordered[k // 2]) / 2
            if ordered[-1] - median > tol or median - ordered[0] > tol:
                break
            j += 1
        runs.append((i, j))
        i = j
    return runs


def _majorities(values: NDArray[Any], i: NDArray[np.intp], j: NDArray[np.intp]) -> NDArray[Any]:
    """The most frequent of ``values[i:j]`` for each run (the smallest among ties)."""
    out = values[i] if len(i) else values[:0]
    changes = np.r_[0, np.cumsum(values[1:] != values[:-1])]
    for k in np.flatnonzero(changes[j - 1] != changes[i]):  # runs of more than one value
        uniq, counts = np.unique(values[i[k] : j[k]], return_counts=True)
        out[k] = uniq[np.argmax(counts)]
    return out


def extract_rcds(scan: SonarScan, params: RcdParams, *, primitive: bool = False) -> Rcds:
    """Extract and type the RCDs of a scan (paper, section II.A).

    Parameters
    ----------
    scan : a validated scan (simulated, or from :meth:`SonarScan.from_readings`).
    params : range tolerance, minimum width and the Type IV jump threshold.
    primitive : True: every run, whatever its width (for the open space). False: only
        RCDs at least ``min_width_deg`` wide and not at max range (for matching and
        counts: a run of readings that returned no echo is no target's region of
        constant depth). Types come from the neighbouring readings either way.

    Returns
    -------
    Rcds; empty for an empty scan.

    Examples
    --------
    A wall at 1 m seen over 25 deg, longer readings around it:

    >>> from evmap.sources.params import SonarParams
    >>> ranges = np.r_[np.full(5, 1.5), np.full(25, 1.0), np.full(5, 1.5)]
    >>> scan = SonarScan.from_readings(np.radians(np.arange(35.0)), ranges, SonarParams())
    >>> rcds = extract_rcds(scan, RcdParams())
    >>> rcds.type.tolist(), rcds.start.tolist(), rcds.count.tolist(), round(float(np.degrees(rcds.width[0])))
    ([1], [5], [25], 25)
    >>> extract_rcds(scan, RcdParams(), primitive=True).type.tolist()
    [3, 1, 3]
    """
    r, m = scan.ranges, len(scan)
    tol = params.range_tolerance
    closed = scan.closed
    first = int(np.argmax(np.abs(r - np.roll(r, 1)))) if closed else 0
    idx = (first + np.arange(m)) % m
    rr = r[idx]
    along = scan.angles[idx] + np.where(idx < first, 2 * np.pi, 0.0)  # unwrapped in run order
    runs = _runs(rr, tol)
    i = np.array([run[0] for run in runs], dtype=np.intp)
    j = np.array([run[1] for run in runs], dtype=np.intp)
    wrap = (rr[-1], rr[0]) if closed and len(runs) > 1 else (np.nan, np.nan)
    prev = np.where(i > 0, rr[i - 1], wrap[0])
    nxt = np.where(j < m, rr[np.minimum(j, m - 1)], wrap[1])
    mean = np.array([rr[a:b].mean() for a, b in runs])  # as each run's own mean: to the last bit
    nb = np.stack([prev, nxt], axis=1)
    seen = np.isfinite(nb)
    jump = np.any(seen & (mean[:, None] - nb > params.jump_threshold), axis=1)
    longer = np.all(~seen | (nb >= mean[:, None]), axis=1)
    shorter = np.all(~seen | (nb < mean[:, None]), axis=1)
    kind = np.where(
        (mean >= scan.params.max_range - tol) | jump,
        TYPE_IV,
        np.where(longer, TYPE_I, np.where(shorter, TYPE_III, TYPE_II)),
    )
    direction = wrapped([along[a:b].mean() for a, b in runs])
    order = np.argsort(idx[i])
    columns = (
        idx[i],
        idx[j - 1],
        j - i,
        along[j - 1] - along[i] + scan.step,
        direction,
        mean,
        np.minimum.reduceat(rr, i) if m else np.empty(0),
        kind,
        prev,
        nxt,
        np.array(_majorities(scan.target[idx], i, j).tolist(), dtype=str),
        _majorities(scan.order[idx], i, j),
    )
    dtypes = [np.intp, np.intp, np.intp, float, float, float, float, int, float, float, str, int]
    rcds = Rcds(*(np.asarray(column, dtype=dt)[order] for column, dt in zip(columns, dtypes)))
    return rcds if primitive else wide_rcds(rcds, scan.params.max_range, params)


def wide_rcds(runs: Rcds, max_range: float, params: RcdParams) -> Rcds:
    """The RCDs of a scan's primitive ones ``runs`` that feed matching and counts: at least ``min_width_deg`` wide
    and not at the scan's ``max_range`` (within the range tolerance); :func:`extract_rcds` without ``primitive``.

    >>> from evmap.sources.params import SonarParams
    >>> scan = SonarScan.from_readings(np.radians(np.arange(20.0)), np.r_[np.full(15, 1.0), np.full(5, 2.0)],
    ...                                SonarParams())
    >>> wide_rcds(extract_rcds(scan, RcdParams(), primitive=True), 10.0, RcdParams()).count.tolist()
    [15]
    """
    echo = runs.range < max_range - params.range_tolerance
    return runs.select(echo & (runs.width >= np.radians(params.min_width_deg) - 1e-9))
