"""What the robot senses from one pose: a rotational sonar scan (if any) and the contour segments.

An :class:`Observation` is the input of :meth:`evmap.maps.BeliefMap.update`. It comes
from the simulated world (:func:`observe`), from a robot log
(:func:`evmap.maps.log_observation.observation_from_log`: the laser's segments as the
contour, the log's sonar readings where it has them), or
from plain arrays measured by any robot (:func:`observation_from_arrays`: the pose, the
contour's line segments, optionally a rotating sonar's readings and the readings of
the config's YAML sensors).
Without a sonar scan the pipeline skips its sonar stages (open space, simulated
sonar, matching, reinforcement, unidentified objects).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evmap.maps.noise import COMPUTED
from evmap.sources.config_model import Config, SensorsParams
from evmap.sources.readings import LslSegments, ScanError, SonarScan
from evmap.sources.sensor_kinds import features_from_arrays
from evmap.sources.sim.lsl import observe_stripe
from evmap.sources.sim.sensor_models import simulate_features
from evmap.sources.sim.sonar import simulate_scan
from evmap.sources.sim.world import World

__all__ = ["SONAR_STREAM", "Observation", "observation_from_arrays", "observe", "sensing_config"]

SONAR_STREAM = 1
"""Stream number of the sonar range noise: ``default_rng([seed, pose_index, 1])``."""


@dataclass(frozen=True, eq=False)
class Observation:
    """One pose's sensing: the sonar scan (which holds the pose) and the contour (LSL or laser) segments.

    Attributes
    ----------
    pose_index : index of the pose in the run (0, 1, ...); evidence records name it.
    sonar : the actual rotational sonar scan; None if the robot had no sonar
        there (then ``robot_pose`` gives the pose).
    lsl : the contour line segments seen from the same pose (LSL or laser).
    features : further per-segment features for the config's noise-elimination
        sources, name -> one value per LSL segment (a new sensor's reading of
        each segment, say ``{"ir_return": [...]}``); the pipeline computes
        :data:`evmap.maps.noise.COMPUTED` itself.
    rays : (K, 2) the contour sensor's rays, if it gives them: world bearing (rad)
        from the pose and measured range (m, NaN for no return) of every ray;
        the free space of the contour and its evidence are made from them.
    all_returns : the contour sensor reports every surface a ray lit within its range, not only one (a
        camera that keeps every stripe pixel above its threshold): the farthest point of a bearing is
        then the last thing the ray met, and beyond it the ray returned nothing.
    robot_pose : (3,) x, y (m), heading (rad) of the robot; needed without a
        sonar scan, else it must be the scan's pose.
    """

    pose_index: int
    sonar: SonarScan | None
    lsl: LslSegments
    features: Mapping[str, ArrayLike] = field(default_factory=dict)
    rays: NDArray[np.float64] | None = None
    robot_pose: ArrayLike | None = None
    all_returns: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.pose_index, int | np.integer) or self.pose_index < 0:
            raise ValueError(f"pose_index must be an integer >= 0, got {self.pose_index!r}")
        if self.robot_pose is None:
            if self.sonar is None:
                raise ValueError("an observation without a sonar scan needs robot_pose")
        else:
            pose = np.array(self.robot_pose, dtype=float)
            if pose.shape != (3,) or not np.isfinite(pose).all():
                raise ValueError(f"robot_pose must be three finite numbers (x, y, heading), got {self.robot_pose!r}")
            if self.sonar is not None and not np.array_equal(pose, self.sonar.pose):
                raise ValueError(f"robot_pose {pose.tolist()} is not the sonar scan's pose {self.sonar.pose.tolist()}")
            object.__setattr__(self, "robot_pose", pose)
        if self.rays is not None:
            object.__setattr__(self, "rays", _checked_rays(self.rays))
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
        return self.sonar.pose if self.sonar is not None else self.robot_pose


def _checked_rays(rays: ArrayLike) -> NDArray[np.float64]:
    """The contour sensor's rays as a (K, 2) float array of finite bearings and ranges >= 0 or NaN (no return),
    or a ValueError naming the first bad ray."""
    given = np.asarray(rays, dtype=float)
    if given.size == 0:
        return given.reshape(0, 2)
    if given.ndim != 2 or given.shape[1] != 2:
        raise ValueError(f"rays must be a (K, 2) array of [bearing (rad), range (m)], got shape {given.shape}")
    bearing, distance = given.T
    bad = np.flatnonzero(~np.isfinite(bearing) | ~((distance >= 0) & np.isfinite(distance) | np.isnan(distance)))
    if len(bad):
        raise ValueError(
            f"rays[{bad[0]}] = {given[bad[0]].tolist()}: a finite bearing and a range >= 0 m, or NaN for no return"
        )
    return given


def sensing_config(world: World, config: Config) -> Config:
    """The config with the scenario's sensors: the parameters the world's observations are sensed with.

    A map of the world is made with it, so that its evidence reads the scans with the
    sensors that made them (a stripe's range noise and range, a sonar's beam), not the
    config's defaults; ``map.json`` keeps them.

    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import parse_scenario
    >>> s = parse_scenario('''
    ... {version: 1, name: t, world: {walls: []}, robot: {poses: [[0, 0, 0]]}, sensors: {lsl: {max_range: 5}}}''', "t")
    >>> sensing_config(World(s), load_config()).sensors.lsl.max_range
    5.0
    """
    sonar, lsl = world.scenario.sensor_params(config.sensors.sonar, config.sensors.lsl)
    return replace(config, sensors=SensorsParams(sonar=sonar, lsl=lsl))


def observe(world: World, pose_index: int, config: Config) -> Observation:
    """Simulate both sensors of the world from one of its poses.

    The scenario's ``sensors`` section overrides the config's sensor parameters;
    all noise comes from the scenario's seed (sonar: stream :data:`SONAR_STREAM`).
    The stripe's camera reports all returns under the scenario's ``sensors.lsl.detector``
    ``threshold`` (every pixel above it), one per column under ``column_max``.
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
    segments, rays = observe_stripe(world, pose_index, lsl)
    features = simulate_features(world, pose_index, config.extra_sensors, segments, config.name)
    all_returns = world.scenario.sensors.lsl.detector == "threshold"
    return Observation(pose_index, scan, segments, features, rays=rays, all_returns=all_returns)


def observation_from_arrays(
    config: Config,
    pose_index: int,
    pose: ArrayLike,
    segments: ArrayLike,
    *,
    sensors: Mapping[str, Mapping[str, ArrayLike]] | None = None,
    sonar: tuple[ArrayLike, ArrayLike] | None = None,
    rays: ArrayLike | None = None,
    all_returns: bool = False,
) -> Observation:
    """One pose's sensing from plain arrays: the one call that brings a robot's readings into a map.

    Parameters
    ----------
    config : the config of the map; its ``extra_sensors`` (YAML sensors) need their readings.
    pose_index : the pose's place in the run (0, 1, ...).
    pose : (3,) x, y (m) and heading (rad) of the robot, world frame.
    segments : (N, 2, 2) the contour sensor's line segments, ``[[x1, y1], [x2, y2]]`` each (m, world frame).
    sensors : the readings of every sensor the config declares, ``{sensor: {array: values}}``, in the array
        form of its kind (``evmap sources`` lists it; e.g. ``range``: ``pose``, ``angles``, ``ranges``).
    sonar : ``(angles, ranges)`` of a rotating sonar at the pose, world bearings (rad) and ranges (m, the
        sonar model's ``max_range`` or more for no echo); ``None`` skips the sonar stages.
    rays : (K, 2) the contour sensor's rays, world bearing (rad) and range (m, NaN for no return), if known.
    all_returns : the rays hold every surface each bearing lit within range, not only the first
        (:class:`Observation`); a laser range finder gives one return a beam: False.

    Raises
    ------
    ValueError
        naming the array that is wrong (a sensor's readings name the sensor).

    >>> from evmap import configs
    >>> from evmap.sources.config import load_config
    >>> cfg = load_config(configs.path("examples/radar.yaml"))
    >>> obs = observation_from_arrays(cfg, 0, [0, 0, 0], [[[1, -1], [1, 1]], [[3, 3], [3, 4]]],
    ...                               sensors={"radar": {"pose": [0, 0, 0], "points": [[1.0, 0.2]]}})
    >>> obs.features["radar_detection"].tolist(), obs.sonar is None
    (['detected', 'out_of_view'], True)
    """
    robot = np.asarray(pose, dtype=float)
    ends = np.asarray(segments, dtype=float)
    if ends.size == 0:
        ends = ends.reshape(0, 2, 2)
    if ends.ndim != 3 or ends.shape[1:] != (2, 2):
        raise ScanError(f"segments must be an (N, 2, 2) array of [[x1, y1], [x2, y2]], got shape {ends.shape}")
    n = len(ends)
    lsl = LslSegments(
        ends[:, 0].copy(),
        ends[:, 1].copy(),
        np.full(n, ""),
        np.zeros(n, np.intp),
        np.full(n, ""),
        np.full(n, pose_index, np.intp),
    )
    scan = None
    if sonar is not None:
        angles, ranges = (np.asarray(a, dtype=float).reshape(-1) for a in sonar)
        if angles.shape != ranges.shape:
            raise ScanError(f"sonar: angles {angles.shape} and ranges {ranges.shape} must have the same shape")
        scan = SonarScan.from_readings(angles, ranges, config.sensors.sonar, pose=robot)
    features = features_from_arrays(config.extra_sensors, sensors or {}, lsl.p, lsl.q)
    return Observation(pose_index, scan, lsl, features, rays=rays, robot_pose=robot, all_returns=bool(all_returns))
