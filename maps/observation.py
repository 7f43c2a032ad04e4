"""What the robot senses from one pose: a rotational sonar scan and the LSL segments.

An :class:`Observation` is the input of :meth:`evmap.maps.BeliefMap.update`. It comes
from the simulated world (:func:`observe`) or from real sensors: build a
:class:`~evmap.sources.readings.SonarScan` with :meth:`~evmap.sources.readings.SonarScan.from_readings`
and an :class:`~evmap.sources.readings.LslSegments` from the extracted line segments.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.maps.noise import COMPUTED
from evmap.sources.config import Config
from evmap.sources.readings import LslSegments, SonarScan
from evmap.sources.sim.lsl import observe_lsl
from evmap.sources.sim.sensor_models import simulate_features
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.world import World

__all__ = ["SONAR_STREAM", "Observation", "observe"]

SONAR_STREAM = 1
"""Stream number of the sonar range noise: ``default_rng([seed, pose_index, 1])``."""


@dataclass(frozen=True, eq=False)
class Observation:
    """One pose's sensing: the sonar scan (which holds the pose) and the LSL segments.

    Attributes
    ----------
    pose_index : index of the pose in the run (0, 1, ...); evidence records name it.
    sonar : the actual rotational sonar scan.
    lsl : the LSL line segments seen from the same pose.
    features : further per-segment features for the config's noise-elimination
        sources, name -> one value per LSL segment (a new sensor's reading of
        each segment, say ``{"ir_return": [...]}``); the pipeline computes
        :data:`evmap.maps.noise.COMPUTED` itself.
    """

    pose_index: int
    sonar: SonarScan
    lsl: LslSegments
    features: Mapping[str, ArrayLike] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.pose_index, int | np.integer) or self.pose_index < 0:
            raise ValueError(f"pose_index must be an integer >= 0, got {self.pose_index!r}")
        for name, values in self.features.items():
            if name in COMPUTED:
                raise ValueError(f"feature {name!r} is computed by the pipeline; an observation cannot bring it")
            if np.shape(values) != (len(self.lsl),):
                raise ValueError(
                    f"feature {name!r} needs one value per LSL segment ({len(self.lsl)}), got shape {np.shape(values)}"
                )

    @property
    def pose(self) -> NDArray[np.float64]:
        """(3,) x, y (m) and heading (rad) of the robot."""
        return self.sonar.pose


def observe(world: World, pose_index: int, config: Config) -> Observation:
    """Simulate both sensors of the world from one of its poses.

    The scenario's ``sensors`` section overrides the config's sensor parameters;
    all noise comes from the scenario's seed (sonar: stream :data:`SONAR_STREAM`).
    The config's ``extra_sensors`` are simulated too and bring their features.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> obs = observe(World(default_scenario()), 0, load_config())
    >>> len(obs.sonar), int((obs.lsl.truth == "noise").sum())
    (360, 28)
    """
    sonar, lsl = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    rng = np.random.default_rng([world.seed, pose_index, SONAR_STREAM])
    scan = simulate_scan(world.surfaces(), world.poses[pose_index], sonar, rng=rng)
    segments = observe_lsl(world, pose_index, lsl)
    return Observation(pose_index, scan, segments, simulate_features(world, pose_index, config.extra_sensors, segments))
