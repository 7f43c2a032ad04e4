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

from evidential.approximation import Estimate, Summary, monte_carlo_combine, summarize
from evidential.combination import combine, combine_batch, conflict
from evidential.conditioning import condition, decondition, generalized_bayes
from evidential.construction import (
    consonant_from_possibility,
    consonant_from_samples,
    from_focal_sets,
    imprecise_dirichlet,
)
from evidential.decision import ExpectedUtilities, choose, expected_utilities, hurwicz, interval_dominance, maximality
from evidential.decomposition import (
    conjunctive_weights,
    decombine,
    disjunctive_weights,
    from_conjunctive_weights,
    from_disjunctive_weights,
)
from evidential.discounting import contextual_discount, contextual_reinforcement, negation
from evidential.distance import jousselme_distance
from evidential.errors import EvidentialError, FrameError, MassError, TotalConflictError, UndefinedTransformError
from evidential.frame import Frame
from evidential.mass import MassFunction
from evidential.measures import (
    LiuConflict,
    belief_distance,
    discord,
    liu_conflict,
    nonspecificity,
    plausibility_distance,
    strife,
    total_uncertainty,
)
from evidential.product import marginalize, product_frame, vacuous_extension
from evidential.refinement import coarsen, refine
from evidential.registry import PROPERTIES, RULES, Rule, register_rule
from evidential.stack import Stack
from evidential.view import plot, table

__all__ = [
    "PROPERTIES",
    "RULES",
    "Estimate",
    "EvidentialError",
    "ExpectedUtilities",
    "Frame",
    "FrameError",
    "LiuConflict",
    "MassError",
    "MassFunction",
    "Rule",
    "Stack",
    "Summary",
    "TotalConflictError",
    "UndefinedTransformError",
    "belief_distance",
    "choose",
    "coarsen",
    "combine",
    "combine_batch",
    "condition",
    "conflict",
    "conjunctive_weights",
    "consonant_from_possibility",
    "consonant_from_samples",
    "contextual_discount",
    "contextual_reinforcement",
    "decombine",
    "decondition",
    "discord",
    "disjunctive_weights",
    "expected_utilities",
    "from_conjunctive_weights",
    "from_disjunctive_weights",
    "from_focal_sets",
    "generalized_bayes",
    "hurwicz",
    "imprecise_dirichlet",
    "interval_dominance",
    "jousselme_distance",
    "liu_conflict",
    "marginalize",
    "maximality",
    "monte_carlo_combine",
    "negation",
    "nonspecificity",
    "plausibility_distance",
    "plot",
    "product_frame",
    "refine",
    "register_rule",
    "strife",
    "summarize",
    "table",
    "total_uncertainty",
    "vacuous_extension",
]
