"""Views of a mass function for notebooks: a text table and a matplotlib chart."""

from __future__ import annotations

from typing import Any

import numpy as np

from evidential.mass import MassFunction


def _rows(m: MassFunction) -> list[tuple[str, float, float, float, float]]:
    betp = np.array(list(m.pignistic().values())) if m[""] < 1 else np.zeros(len(m.frame))
    member = m.masks[:, None] >> np.arange(len(m.frame)) & 1
    label = m.frame.label
    return [
        (label(int(a)) or "∅", float(v), m.belief(int(a)), m.plausibility(int(a)), float(row @ betp))
        for a, v, row in zip(m.masks, m.masses, member)
    ]


def table(m: MassFunction, digits: int = 4) -> str:
    """A table of the focal sets with their m, bel, pl and BetP (sum of BetP over the set).

    Examples
    --------
    >>> from evidential import Frame
    >>> print(table(MassFunction(Frame(["a", "b"]), {"a": 0.5, "a|b": 0.5}), digits=2))
    focal set     m   bel    pl  BetP
    a          0.50  0.50  1.00  0.75
    a|b        0.50  1.00  1.00  1.00
    """
    rows = _rows(m)
    width = max(len("focal set"), *(len(r[0]) for r in rows))
    cell = digits + 2
    head = f"{'focal set':<{width}}" + "".join(f"{h:>{cell + 2}}" for h in ("m", "bel", "pl", "BetP"))
    body = [f"{r[0]:<{width}}" + "".join(f"{x:>{cell + 2}.{digits}f}" for x in r[1:]) for r in rows]
    return "\n".join([head, *body])


def plot(m: MassFunction, ax: Any = None) -> Any:
    """Draw each focal set's [bel, pl] interval (bar), its mass (dot) and BetP (tick) on ``ax``
    (a new figure if None); matplotlib is imported on the first call only. Returns the axes.
    """
    if ax is None:
        from matplotlib.figure import Figure

        ax = Figure(figsize=(6, 0.4 * len(m) + 1)).subplots()
    rows = _rows(m)
    y = np.arange(len(rows))
    _, mass, bel, pl, betp = (np.array(c) for c in zip(*rows))
    ax.barh(y, pl - bel, left=bel, height=0.5, color="lightsteelblue", label="[bel, pl]")
    ax.plot(mass, y, "o", color="tab:blue", label="m")
    ax.plot(betp, y, "|", color="black", markersize=14, label="BetP")
    ax.set_yticks(y, [r[0] for r in rows])
    ax.set_xlim(0, 1)
    ax.legend(loc="lower right", fontsize="small")
    return ax
