"""Geometry that the sensor models see: segments joined at vertices, and cylinders.

Both the simulated world (built from a scenario) and the line-corner map (built by
the fusion pipeline) are handed to the sonar and LSL models as :class:`Surfaces`,
so the same physics measures the world and predicts a scan from the map
(paper, section III). Arrays, not objects: the models are vectorised over them.

A vertex is a point where segment ends sit: a vertex of degree 1 is a free end
point (a convex edge to sonar), a vertex of degree 2 or more is a corner, concave
or convex depending on where the sensor stands.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["Surfaces"]


@dataclass(frozen=True, eq=False)
class Surfaces:
    """Segments, vertices and cylinders as arrays, each object named by an id.

    Attributes
    ----------
    vertices : (V, 2) float array of vertex coordinates.
    vertex_ids : (V,) ids of the vertices (strings).
    segments : (N, 2) int array: indices into ``vertices`` of each segment's two ends.
    segment_ids : (N,) ids of the segments.
    lsl_opaque : (N,) bool: the laser stripe is seen on (and stopped by) the segment.
    sonar_reflective : (N,) bool: the segment reflects sound (specular), else it absorbs it.
    cylinder_centers : (K, 2) float; cylinder_radii : (K,) float; cylinder_ids : (K,).
    cylinder_lsl_opaque, cylinder_sonar_reflective : (K,) bool.
    """

    vertices: NDArray[np.float64]
    vertex_ids: NDArray[np.str_]
    segments: NDArray[np.intp]
    segment_ids: NDArray[np.str_]
    lsl_opaque: NDArray[np.bool_]
    sonar_reflective: NDArray[np.bool_]
    cylinder_centers: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    cylinder_radii: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    cylinder_ids: NDArray[np.str_] = field(default_factory=lambda: np.zeros(0, dtype=str))
    cylinder_lsl_opaque: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    cylinder_sonar_reflective: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))

    @property
    def p(self) -> NDArray[np.float64]:
        """(N, 2) first end point of every segment."""
        return self.vertices[self.segments[:, 0]]

    @property
    def q(self) -> NDArray[np.float64]:
        """(N, 2) second end point of every segment."""
        return self.vertices[self.segments[:, 1]]

    def vertex_degree(self) -> NDArray[np.intp]:
        """(V,) number of segments ending at each vertex."""
        return np.bincount(self.segments.ravel(), minlength=len(self.vertices))
