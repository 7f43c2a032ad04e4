"""evidential: the Dempster–Shafer engine (frames, mass functions, combination rules).

Examples
--------
>>> from evidential import Frame, MassFunction, combine
>>> frame = Frame(["real", "noise"])
>>> m = combine(MassFunction(frame, {"real": 0.6, "real|noise": 0.4}),
...             MassFunction(frame, {"noise": 0.5, "real|noise": 0.5}), rule="yager")
>>> {k: round(v, 12) for k, v in m.to_dict().items()}
{'real': 0.3, 'noise': 0.2, 'real|noise': 0.5}
"""

from evidential.combination import combine, combine_batch, conflict
from evidential.distance import jousselme_distance
from evidential.errors import EvidentialError, FrameError, MassError, TotalConflictError, UndefinedTransformError
from evidential.frame import Frame
from evidential.mass import MassFunction
from evidential.rules import PROPERTIES, RULES, Rule, register_rule
from evidential.stack import Stack

__all__ = [
    "PROPERTIES",
    "RULES",
    "EvidentialError",
    "Frame",
    "FrameError",
    "MassError",
    "MassFunction",
    "Rule",
    "Stack",
    "TotalConflictError",
    "UndefinedTransformError",
    "combine",
    "combine_batch",
    "conflict",
    "jousselme_distance",
    "register_rule",
]
