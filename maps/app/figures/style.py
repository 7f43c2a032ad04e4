"""Colours, line styles and names the figures share (no matplotlib).

Colours are Okabe-Ito: distinguishable with every common colour-vision deficiency.
"""

from __future__ import annotations

__all__ = [
    "ABSORBING",
    "BLACK",
    "BLUE",
    "DASH",
    "FAINT",
    "GLASS",
    "GREEN",
    "OPEN",
    "ORANGE",
    "PURPLE",
    "STATUS_EDGE",
    "TYPE_COLOURS",
    "TYPE_MEANING",
    "VERMILION",
    "WALL",
]

BLACK, ORANGE, GREEN, BLUE, VERMILION, PURPLE = "#000000", "#E69F00", "#009E73", "#0072B2", "#D55E00", "#CC79A7"
WALL, GLASS, ABSORBING, FAINT = "#6e6e6e", "#3a8fd0", "#a0522d", "#9a9a9a"
OPEN = "#8cc8ec"
"""The sonar open space."""
DASH = (0, (4, 2.5))
"""The true walls of a simulated world."""
TYPE_COLOURS = {1: BLUE, 2: GREEN, 3: ORANGE, 4: PURPLE}
"""RCD type -> colour."""
TYPE_MEANING = {
    1: "I: both neighbours farther",
    2: "II: one neighbour nearer",
    3: "III: both neighbours nearer",
    4: "IV: multiple reflection",
}
STATUS_EDGE = {"matched": GREEN, "unmatched": VERMILION, "ignored": FAINT, "": "none"}
"""Frame of an RCD label by its matching status."""
