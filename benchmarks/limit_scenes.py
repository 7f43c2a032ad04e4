"""The scenarios of ``bench_limits.py``: worst valid inputs at the documented limits, as YAML text.

Each function returns a whole scenario file (``HEADER`` and a name, the world, the poses) or a part of one;
the arrangements are those that cost ``evmap run`` the most found (see ``bench_limits.py``).
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable

from evmap.sources.params import MAX_STRIPE_POINTS
from evmap.sources.sim.spec import (
    MAX_CYLINDERS,
    MAX_PHANTOMS_PER_RUN,
    MAX_POLYGON_VERTICES,
    MAX_POSES,
    MAX_SUNLIGHT_LINES,
    MAX_SUNLIGHT_LINES_PER_REGION,
    MAX_SUNLIGHT_REGIONS,
    MAX_WALL_SEGMENTS,
)

HEADER = "version: 1\nseed: 1\n"


def corridor(length: float, width: float = 2.4) -> str:
    """The walls of a closed corridor ``length`` x ``width``, as YAML flow text."""
    return f"  walls:\n    - {{id: box, points: [[0, 0], [{length}, 0], [{length}, {width}], [0, {width}], [0, 0]]}}\n"


def square(cx: float, cy: float, half: float) -> str:
    """A square polygon around ``(cx, cy)`` as YAML flow text."""
    return f"[[{cx - half}, {cy - half}], [{cx + half}, {cy - half}], [{cx + half}, {cy + half}], [{cx - half}, {cy + half}]]"


def poses_text(poses: list[tuple[float, float, float]]) -> str:
    """The robot section."""
    return "robot:\n  poses:\n" + "".join(f"    - [{x:.3f}, {y:.3f}, {h:.1f}]\n" for x, y, h in poses)


def poses_cluster() -> str:
    """MAX_POSES poses in a 16 m corridor, all within the LSL's range of one region of the most lines they allow."""
    lines = MAX_PHANTOMS_PER_RUN // MAX_POSES
    poses = [(2 + 12 * (k // 3) / 16, 0.6 + 0.6 * (k % 3), (37 * k) % 360) for k in range(MAX_POSES)]
    return (
        HEADER
        + "name: poses-cluster\nworld:\n"
        + corridor(16)
        + f"  sunlight:\n    - {{polygon: {square(8, 1.2, 0.8)}, lines: {lines}, length: [0.05, 0.4]}}\n"
        + poses_text(poses)
    )


def poses_corridor() -> str:
    """MAX_POSES poses 2 m apart along a 102 m corridor, sunlight regions spread along it."""
    regions = min(MAX_SUNLIGHT_REGIONS, MAX_PHANTOMS_PER_RUN // MAX_POSES)
    lines = MAX_PHANTOMS_PER_RUN // MAX_POSES // regions
    length = 2 * MAX_POSES + 2
    sun = "".join(
        f"    - {{polygon: {square(2 + length * (k + 0.5) / regions * 0.96, 1.2, 0.6)}, lines: {lines}, "
        "length: [0.05, 0.4]}\n"
        for k in range(regions)
    )
    poses = [(2 + 2 * k, 0.9 + 0.6 * (k % 2), 0.0) for k in range(MAX_POSES)]
    return HEADER + "name: poses-corridor\nworld:\n" + corridor(length) + "  sunlight:\n" + sun + poses_text(poses)


def phantoms(poses: int) -> Callable[[], str]:
    """``poses`` poses around sunlight regions of the most lines a run allows (MAX_PHANTOMS_PER_RUN)."""

    def build() -> str:
        per_pose = min(MAX_SUNLIGHT_LINES, MAX_PHANTOMS_PER_RUN // poses)
        regions = math.ceil(per_pose / MAX_SUNLIGHT_LINES_PER_REGION)
        sun = "".join(
            f"    - {{polygon: {square(5 + 2 * k, 1.2, 0.8)}, lines: {per_pose // regions}, length: [0.05, 0.4]}}\n"
            for k in range(regions)
        )
        at = [(3 + 8 * k / poses, 0.4 + 1.6 * (k % 2), 90.0 * k % 360) for k in range(poses)]
        return HEADER + f"name: phantoms-{poses}\nworld:\n" + corridor(12) + "  sunlight:\n" + sun + poses_text(at)

    return build


def ring_walls(segments: int) -> str:
    """One wall: a ring of radius 5 m around the origin, of ``segments`` segments."""
    points = ", ".join(
        f"[{5 * math.cos(2 * math.pi * k / segments):.4f}, {5 * math.sin(2 * math.pi * k / segments):.4f}]"
        for k in range(segments)
    )
    return f"  walls:\n    - {{id: ring, points: [{points}, [5.0, 0.0]]}}\n"


def zigzag_walls(segments: int) -> str:
    """One wall: a ring around the origin whose vertices alternate between radius 6 m and 5.8 m, of ``segments``
    segments: short facets nearly edge-on to the poses inside, concave and convex corners alternating, so that
    most sonar readings have no first-order echo and the model tries the longest second-order paths."""
    points = ", ".join(
        f"[{(6 - 0.2 * (k % 2)) * math.cos(2 * math.pi * k / segments):.4f}, "
        f"{(6 - 0.2 * (k % 2)) * math.sin(2 * math.pi * k / segments):.4f}]"
        for k in range(segments)
    )
    return f"  walls:\n    - {{id: zigzag, points: [{points}, [6.0, 0.0]]}}\n"


def scattered_walls(segments: int) -> str:
    """One wall: a random walk (seeded) of ``segments`` steps of 2 m in a 20 m square around the origin, no step
    within 0.3 m of the poses of :func:`inside_ring`: a dense clutter of crossing segments, every one within the
    sonar's range, most hidden behind others (one polyline: the file stays under the size limit)."""
    rng = random.Random(16)
    at = inside_ring(MAX_POSES)
    points = [(8.0, 8.0)]
    while len(points) <= segments:
        a = rng.uniform(0, 2 * math.pi)
        p = points[-1]
        q = (p[0] + 2 * math.cos(a), p[1] + 2 * math.sin(a))
        if max(abs(q[0]), abs(q[1])) <= 10 and all(_point_segment(x, y, p, q) > 0.3 for x, y, _ in at):
            points.append(q)
    text = ", ".join(f"[{x:.3f}, {y:.3f}]" for x, y in points)
    return f"  walls:\n    - {{id: clutter, points: [{text}]}}\n"


def _point_segment(x: float, y: float, p: tuple[float, float], q: tuple[float, float]) -> float:
    """Distance from (x, y) to the segment p-q."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    t = max(0.0, min(1.0, ((x - p[0]) * dx + (y - p[1]) * dy) / (dx * dx + dy * dy)))
    return math.hypot(p[0] + t * dx - x, p[1] + t * dy - y)


def inside_ring(poses: int) -> list[tuple[float, float, float]]:
    """``poses`` poses inside the ring, on two circles."""
    return [
        (
            1.2 * (1 + k % 2) * math.cos(2 * math.pi * k / poses),
            1.2 * (1 + k % 2) * math.sin(2 * math.pi * k / poses),
            (37 * k) % 360,
        )
        for k in range(poses)
    ]


def walls_ring(poses: int) -> Callable[[], str]:
    """A ring of MAX_WALL_SEGMENTS segments, every one in the sensors' range, around ``poses`` poses."""

    def build() -> str:
        return HEADER + f"name: walls-ring\nworld:\n{ring_walls(MAX_WALL_SEGMENTS)}" + poses_text(inside_ring(poses))

    return build


def walls_zigzag() -> str:
    """A zigzag ring of MAX_WALL_SEGMENTS segments around MAX_POSES poses."""
    return (
        HEADER + f"name: walls-zigzag\nworld:\n{zigzag_walls(MAX_WALL_SEGMENTS)}" + poses_text(inside_ring(MAX_POSES))
    )


def walls_scattered() -> str:
    """MAX_WALL_SEGMENTS crossing walls of 2 m around MAX_POSES poses."""
    return (
        HEADER
        + f"name: walls-scattered\nworld:\n{scattered_walls(MAX_WALL_SEGMENTS)}"
        + poses_text(inside_ring(MAX_POSES))
    )


DENSEST_SENSORS = (
    "sensors:\n  sonar: {beam_width_deg: 90, step_deg: 0.1, max_range: 100.0}\n"
    f"  lsl: {{fov_deg: 180, snapshots: {MAX_STRIPE_POINTS // 3601}, step_deg: {360 / (MAX_STRIPE_POINTS // 3601)}, "
    "ray_step_deg: 0.05, max_range: 100.0}\n"
)
"""The densest sensors allowed: an LSL scan of MAX_STRIPE_POINTS points (180-degree snapshots every 0.05 degree),
sonar readings every 0.1 degree over a 90-degree beam, 100 m range."""


def sensors_zigzag() -> str:
    """The zigzag ring of MAX_WALL_SEGMENTS around MAX_POSES poses, seen by the densest sensors allowed."""
    return walls_zigzag() + DENSEST_SENSORS


def sensors() -> str:
    """The ring of MAX_WALL_SEGMENTS around MAX_POSES poses, seen by the densest sensors allowed: an LSL scan of
    MAX_STRIPE_POINTS points (180-degree snapshots every 0.05 degree), sonar readings every 0.1 degree, 100 m range."""
    snapshots = MAX_STRIPE_POINTS // (int(180 / 0.05) + 1)
    return (
        walls_ring(MAX_POSES)()
        + "sensors:\n  sonar: {beam_width_deg: 90, step_deg: 0.1, max_range: 100.0}\n"
        + f"  lsl: {{fov_deg: 180, snapshots: {snapshots}, step_deg: {360 / snapshots}, ray_step_deg: 0.05, "
        "max_range: 100.0}\n"
    )


def cylinder_grid(count: int, skip: list[tuple[float, float, float]]) -> str:
    """``count`` pillars of radius 0.05 m on a 0.4 m grid around the origin, none on a pose of ``skip``."""
    side = math.ceil(math.sqrt(count)) + 4
    spots = [(0.4 * (i - side // 2) + 0.2, 0.4 * (j - side // 2) + 0.2) for i in range(side) for j in range(side)]
    free = [(x, y) for x, y in spots if all(math.hypot(x - px, y - py) > 0.15 for px, py, _ in skip)][:count]
    return "  cylinders:\n" + "".join(
        f"    - {{id: c{k}, center: [{x:.2f}, {y:.2f}], radius: 0.05}}\n" for k, (x, y) in enumerate(free)
    )


def cylinders() -> str:
    """MAX_CYLINDERS pillars on a grid around MAX_POSES poses, all within the sensors' range."""
    at = inside_ring(MAX_POSES)
    return HEADER + "name: cylinders\nworld:\n  walls: []\n" + cylinder_grid(MAX_CYLINDERS, at) + poses_text(at)


def everything() -> str:
    """Every count at its limit at once: ring walls, pillars inside, MAX_POSES poses, a sunlit patch."""
    at = inside_ring(MAX_POSES)
    lines = MAX_PHANTOMS_PER_RUN // MAX_POSES
    return (
        HEADER
        + f"name: everything\nworld:\n{ring_walls(MAX_WALL_SEGMENTS)}"
        + cylinder_grid(MAX_CYLINDERS, at).replace("center: [", "center: [").replace("radius: 0.05", "radius: 0.03")
        + f"  sunlight:\n    - {{polygon: {square(0, 0, 0.5)}, lines: {lines}, length: [0.05, 0.4]}}\n"
        + poses_text(at)
    )


def star(cx: float, cy: float, radius: float, vertices: int) -> str:
    """A star polygon of ``vertices`` vertices (alternately at ``radius`` and half of it)."""
    points = (
        (
            cx + radius * (1 - 0.5 * (k % 2)) * math.cos(2 * math.pi * k / vertices),
            cy + radius * (1 - 0.5 * (k % 2)) * math.sin(2 * math.pi * k / vertices),
        )
        for k in range(vertices)
    )
    return "[" + ",".join(f"[{x:.4f},{y:.4f}]" for x, y in points) + "]"


def sunlight_regions() -> str:
    """MAX_SUNLIGHT_REGIONS star polygons of MAX_POLYGON_VERTICES vertices, in range of MAX_POSES poses among them."""
    per_pose = min(MAX_SUNLIGHT_LINES, MAX_PHANTOMS_PER_RUN // MAX_POSES)
    side = math.ceil(math.sqrt(MAX_SUNLIGHT_REGIONS))
    sun = "".join(
        f"    - {{polygon: {star(1.1 * (k % side), 1.1 * (k // side), 0.5, MAX_POLYGON_VERTICES)}, "
        f"lines: {int(k < per_pose)}, length: [0.02, 0.2]}}\n"
        for k in range(MAX_SUNLIGHT_REGIONS)
    )
    middle = 1.1 * (side // 2 - 0.5)
    at = [(middle + 1.1 * (k % 2), middle + 1.1 * (k // 2 % 2), (37.0 * k) % 360) for k in range(MAX_POSES)]
    return HEADER + "name: sunlight-regions\nworld:\n  walls: []\n  sunlight:\n" + sun + poses_text(at)
