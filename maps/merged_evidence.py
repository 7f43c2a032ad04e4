"""The noise-elimination evidence of merged lines (:mod:`evmap.maps.rebuild`): each line judged as one segment.

A merged line is judged by its merged length and its relation to the open
space, its other features taken from its longest member; its pieces are not
independent evidence. How many poses saw it is counted from its raw segments
and the poses its consolidated supports stand for.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import shapely
from numpy.typing import NDArray

from evidential import MassFunction
from evmap.maps.map_json import MassCodec
from evmap.maps.merging import Merged
from evmap.maps.noise import NoiseEvidence, noise_evidence
from evmap.maps.segments import SegmentStore
from evmap.maps.sensed import kept_features
from evmap.sources.config_model import Config

if TYPE_CHECKING:
    from evmap.maps.belief_map import BeliefMap

__all__ = ["MergedEvidence", "merged_evidence"]


@dataclass(frozen=True, eq=False)
class MergedEvidence:
    """The noise-elimination evidence of the merged lines: the verdicts, their fused masses as mass functions
    and as ``{FOCAL: float}`` (:meth:`MassFunction.to_dict`, encoded in bulk), and how many poses saw each line."""

    base: NoiseEvidence
    masses: list[MassFunction]
    dicts: list[dict[str, float]]
    seen: NDArray[np.intp]


def merged_evidence(bm: BeliefMap, pool: NDArray[np.intp], merged: Merged, config: Config) -> MergedEvidence:
    """The noise-elimination evidence of the ``merged`` lines of the map's segment rows ``pool``, from their
    merged length and relation (other features from their longest member), and how many poses saw each."""
    store = bm.segments
    length = np.hypot(*(store.q[pool] - store.p[pool]).T)
    order = np.lexsort((np.arange(len(pool)), -length, merged.line_of))  # by line, the longest member first
    first = np.flatnonzero(np.diff(merged.line_of[order], prepend=-1))
    longest = pool[order[first]]
    features = {name: column[longest] for name, column in store.features.items()}
    seen = _poses_seen(store, pool, merged.line_of, len(merged.groups))
    features["lsl_other_poses"] = seen - 1
    features |= kept_features(bm, longest)
    ends = np.concatenate([store.p[pool], store.q[pool]])
    space = bm.open_space_parts_near((*ends.min(axis=0), *ends.max(axis=0))) if len(pool) else shapely.MultiPolygon()
    base = noise_evidence(merged.p, merged.q, space, config, features)
    masses = MassFunction.from_rows(bm.frame, range(1 << len(bm.frame)), base.fused, open_world=True)  # in bulk
    return MergedEvidence(base, masses, MassCodec(bm.frame).encode(masses), seen)


def _poses_seen(store: SegmentStore, pool: NDArray[np.intp], line_of: NDArray[np.intp], lines: int) -> NDArray[np.intp]:
    """How many poses saw each of the ``lines`` merged lines (``line_of`` each row of ``pool``): the distinct
    poses of its raw rows, and the poses behind each of its supports.

    A support's poses are counted apart from the raw segments' (after a
    consolidation, the poses that saw a line again are new ones).
    """
    support = store.role[pool] == "support"
    raw = np.unique(np.column_stack([line_of[~support], store.pose[pool[~support]]]), axis=0)
    behind = np.bincount(line_of[support], weights=store.seen[pool[support]], minlength=lines)
    return np.bincount(raw[:, 0], minlength=lines) + behind.astype(np.intp)
