"""Noise elimination (paper, section III, Table 1): sonar open space and LSL length, fused.

Each segment gets a mass function from every source of the config's
``noise_elimination`` stage (by default Table 1: the sonar's judgement from the
segment's relation to the open space, and the LSL's from its length), combined
by the config's rule; a segment whose fused mass of ``{noise}`` is strictly
above ``noise.threshold`` is eliminated.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from evidential import combine_batch
from sources.config import Config
from sources.relation import relation

__all__ = ["NoiseEvidence", "noise_evidence"]


@dataclass(frozen=True, eq=False)
class NoiseEvidence:
    """The noise-elimination stage's verdict on N segments.

    Attributes
    ----------
    relation : (N,) ``outside | partly_inside | inside``.
    length : (N,) segment lengths (m).
    fused : (N, 2**n) the combined mass functions (columns by bitmask).
    conflict : (N,) K, the conjunctive mass on the empty set between the stage's sources.
    eliminated : (N,) fused mass of ``{noise}`` above the threshold.
    """

    relation: NDArray[np.str_]
    length: NDArray[np.float64]
    fused: NDArray[np.float64]
    conflict: NDArray[np.float64]
    eliminated: NDArray[np.bool_]


def noise_evidence(
    p: NDArray[np.float64],
    q: NDArray[np.float64],
    open_space: shapely.Geometry,
    config: Config,
    features: Mapping[str, ArrayLike] | None = None,
) -> NoiseEvidence:
    """Judge segments p-q against the sonar open space with the config's noise-elimination sources.

    The sources read the features ``relation`` and ``length`` (computed here) and
    any others given in ``features`` (one value per segment).

    >>> from sources.config import load_config
    >>> room = shapely.box(0, 0, 4, 4)
    >>> ev = noise_evidence(np.array([[1.0, 1.0], [5.0, 0.0]]), np.array([[1.2, 1.0], [5.0, 2.0]]), room, load_config())
    >>> ev.relation.tolist(), ev.eliminated.tolist()
    (['inside', 'outside'], [True, False])
    >>> ev.fused[0].round(3).tolist()  # empty, real, noise, real|noise
    [0.0, 0.171, 0.737, 0.092]
    """
    frame = config.frame
    if "noise" not in frame.elements:
        raise ValueError(f"{config.name}: noise elimination needs an element 'noise' in the frame {frame!r}")
    features = {
        **(features or {}),
        "relation": relation(p, q, open_space, config.noise),
        "length": np.hypot(*(q - p).T),
    }
    batches = [source.masses(features) for source in config.stage_sources("noise_elimination")]
    fused = np.ascontiguousarray(combine_batch(*batches, rule=config.rule))
    k = combine_batch(*batches, rule="conjunctive")[:, 0] if len(batches) > 1 else np.zeros(len(p))
    eliminated = fused[:, frame.mask("noise")] > config.noise.threshold
    return NoiseEvidence(features["relation"], features["length"], fused, np.ascontiguousarray(k), eliminated)
