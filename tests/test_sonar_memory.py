"""The sonar model's bounded-memory computation gives exactly what the dense one (every path against every
surface, every source against every target) gave, on random worlds; and its memory does not grow with the
square of the surfaces in range.

The dense computation is kept here only, as the reference: it is the model as it was before the spatial
indexes and the chunks (issue 16), written with the module's unchanged helpers.
"""

from __future__ import annotations

import itertools
import tracemalloc

import numpy as np
import pytest

from evmap.sources.geometry import crossings, perpendicular_feet, ray_circle_distances
from evmap.sources.params import SonarParams
from evmap.sources.readings import SonarScan
from evmap.sources.sim import sonar, sonar_near
from evmap.sources.sim.sonar import echo_halfwidth, target_strength
from evmap.sources.sim.sonar_near import EPS, PARALLEL, TOUCH, path_crossings, probe_rays, surfaces_near
from evmap.sources.sim.surfaces import Surfaces

# ---------------------------------------------------------------- the dense reference


def _dense_blocked(a, b, near):
    u, v = path_crossings(a[:, None], b[:, None], near.p[None], near.q[None])
    hit = np.any((u > EPS) & (u < 1 - EPS) & (v >= -EPS) & (v <= 1 + EPS), axis=1)
    if len(near.occ_c):
        t, foot = perpendicular_feet(near.occ_c[None], a[:, None], b[:, None])
        d = np.hypot(foot[..., 0] - near.occ_c[:, 0], foot[..., 1] - near.occ_c[:, 1])
        hit |= np.any((t > EPS) & (t < 1 - EPS) & (d < near.occ_r[None] * (1 - EPS)), axis=1)
    return hit


def _dense_candidates(near, src):
    t, foot = perpendicular_feet(src[:, None], near.p[None], near.q[None])
    vert = np.broadcast_to(near.v[None], (len(src), len(near.v), 2))
    rel = src[:, None] - near.c[None]
    dist = np.linalg.norm(rel, axis=-1)
    outside = dist > near.radius[None]
    cyl = near.c[None] + near.radius[None, :, None] * rel / np.where(outside, dist, 1.0)[..., None]
    point = np.concatenate([foot, vert, cyl], axis=1)
    on_segment = near.reflective[None] & (t >= -TOUCH) & (t <= 1 + TOUCH)
    can = np.concatenate([on_segment, np.ones(vert.shape[:2], dtype=bool), outside], axis=1)
    return point, can


def _dense_first_echo(angles, bearing, halfwidth, r):
    off = np.abs(np.mod(bearing[None] - angles[:, None] + np.pi, 2 * np.pi) - np.pi)
    cand = np.where(off <= halfwidth[None] + TOUCH, r[None], np.inf)
    if cand.shape[1] == 0:
        return np.full(len(angles), np.inf), np.zeros(len(angles), dtype=np.intp)
    best = cand.min(axis=1)
    return best, np.argmax(cand <= best[:, None] + TOUCH, axis=1)


def _dense_echoes(near, s, params):
    point, can = _dense_candidates(near, s[None])
    point, can = point[0], can[0]
    r = np.hypot(*(point - s).T)
    cand = np.flatnonzero(can & (r > EPS) & (r <= params.max_range))
    w = echo_halfwidth(target_strength(near, cand, np.broadcast_to(s, (len(cand), 2)), params), r[cand], params)
    cand, w = cand[w >= 0], w[w >= 0]
    seen = ~_dense_blocked(np.broadcast_to(s, (len(cand), 2)), point[cand], near)
    cand, w = cand[seen], w[seen]
    rel = point[cand] - s
    return np.arctan2(rel[:, 1], rel[:, 0]), w, r[cand], cand


def _dense_visible_segments(near, s):
    _, u = probe_rays(near, s)
    t, v = crossings(s, u[:, None], near.p, near.q - near.p, parallel=PARALLEL)
    dist = np.where((t > 0) & (v >= 0) & (v <= 1), t, np.inf)
    if len(near.occ_c):
        dist = np.concatenate([dist, ray_circle_distances(s, u, near.occ_c, near.occ_r)], axis=1)
    first = np.argmin(dist, axis=1)[np.isfinite(dist.min(axis=1))]
    return np.isin(np.arange(len(near.p)), first)


def _dense_double_echoes(near, s, params, angles, first):
    mir = np.flatnonzero(near.reflective & _dense_visible_segments(near, s))
    pa, qa = near.p[mir], near.q[mir]
    d = qa - pa
    normal = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1, keepdims=True)
    h = np.einsum("ij,ij->i", s - pa, normal)
    mir, pa, qa, normal, h = (x[np.abs(h) > EPS] for x in (mir, pa, qa, normal, h))
    image = s - 2 * h[:, None] * normal
    point, can = _dense_candidates(near, image)
    u, v = path_crossings(image[:, None], point, pa[:, None], qa[:, None])
    r = np.linalg.norm(point - image[:, None], axis=-1)
    ok = can & (u > EPS) & (u < 1 - EPS) & (v >= 0) & (v <= 1) & (r <= min(params.max_range, params.detection_range))
    ia, ic = np.nonzero(ok)
    r, u = r[ia, ic], u[ia, ic]
    w = echo_halfwidth(target_strength(near, ic, image[ia], params), r, params)
    step = 2 * np.pi / len(angles)
    reach = int(np.ceil(np.radians(params.beam_width_deg) / 2 / step)) + 1
    window = (np.arange(len(first))[:, None] + np.arange(-reach, reach + 1)) % len(first)
    later = first[window].max(axis=1)
    x = image[ia] + u[:, None] * (point[ia, ic] - image[ia])
    rel = x - s
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    j = np.round((bearing - angles[0]) / step).astype(np.intp) % len(angles)
    keep = (w >= 0) & (later[j] > r)
    ia, ic, r, w, x, bearing = (a[keep] for a in (ia, ic, r, w, x, bearing))
    seen = ~_dense_blocked(np.broadcast_to(s, x.shape), x, near)
    seen[seen] = ~_dense_blocked(x[seen], point[ia[seen], ic[seen]], near)
    return bearing[seen], w[seen], r[seen], mir[ia[seen]]


def dense_scan(surfaces: Surfaces, pose, params: SonarParams, max_order: int = 2) -> SonarScan:
    """The noise-free scan as the dense computation made it."""
    pose = np.asarray(pose, dtype=float)
    s = pose[:2]
    m = max(1, round(360 / params.step_deg))
    angles = pose[2] + np.arange(m) * (2 * np.pi / m)
    near, labels = surfaces_near(surfaces, s, params.max_range)
    bearing, w, r, label = _dense_echoes(near, s, params)
    best, idx = _dense_first_echo(angles, bearing, w, r)
    target = np.where(np.isfinite(best), label[idx] if len(label) else -1, -1)
    order = np.where(np.isfinite(best), 1, 0)
    if max_order == 2 and len(near.p):
        bearing2, w2, r2, label2 = _dense_double_echoes(near, s, params, angles, best)
        best2, idx2 = _dense_first_echo(angles, bearing2, w2, r2)
        later = best2 < best - TOUCH
        best = np.where(later, best2, best)
        target = np.where(later, label2[idx2] if len(label2) else -1, target)
        order = np.where(later, 2, order)
    ranges = np.where(np.isfinite(best), best, params.max_range)
    return SonarScan(pose, angles, ranges, labels[target], order, params)


# ---------------------------------------------------------------- random worlds


def random_world(rng: np.random.Generator, polylines: int, cylinders: int, size: float) -> Surfaces:
    """Random polylines (some closed, some sharing vertices, some axis-aligned) and cylinders in a square."""
    vertices: list[np.ndarray] = []
    segments: list[tuple[int, int]] = []
    for _ in range(polylines):
        count = int(rng.integers(2, 7))
        start = len(vertices)
        if vertices and rng.random() < 0.3:  # continue from an existing vertex: a corner of degree 3 or more
            first = int(rng.integers(len(vertices)))
            points = [first]
        else:
            vertices.append(rng.uniform(-size, size, 2))
            points = [start]
            start += 1
        for _ in range(count - 1):
            prev = vertices[points[-1]]
            step = rng.normal(0, size / 3, 2)
            if rng.random() < 0.4:
                step[rng.integers(2)] = 0.0
            vertices.append(prev + step)
            points.append(len(vertices) - 1)
        if count > 3 and rng.random() < 0.3:
            points.append(points[0])
        segments += [(a, b) for a, b in itertools.pairwise(points) if a != b]
    v = np.array(vertices, dtype=float).reshape(-1, 2)
    seg = np.array(segments, dtype=np.intp).reshape(-1, 2)
    centers = rng.uniform(-size, size, (cylinders, 2))
    return Surfaces(
        vertices=v,
        vertex_ids=np.array([f"v{i}" for i in range(len(v))], dtype=str),
        segments=seg,
        segment_ids=np.array([f"s{i}" for i in range(len(seg))], dtype=str),
        lsl_opaque=np.ones(len(seg), dtype=bool),
        sonar_reflective=rng.random(len(seg)) < 0.85,
        cylinder_centers=centers,
        cylinder_radii=rng.uniform(0.05, 0.4, cylinders),
        cylinder_ids=np.array([f"c{i}" for i in range(cylinders)], dtype=str),
        cylinder_lsl_opaque=np.ones(cylinders, dtype=bool),
        cylinder_sonar_reflective=rng.random(cylinders) < 0.8,
    )


def ring(n: int, radius: float = 5.0) -> Surfaces:
    """One closed wall: a regular polygon of ``n`` segments."""
    a = 2 * np.pi * np.arange(n) / n
    v = radius * np.stack([np.cos(a), np.sin(a)], axis=1)
    return Surfaces(
        vertices=v,
        vertex_ids=np.array([f"v{i}" for i in range(n)], dtype=str),
        segments=np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1),
        segment_ids=np.array([f"s{i}" for i in range(n)], dtype=str),
        lsl_opaque=np.ones(n, dtype=bool),
        sonar_reflective=np.ones(n, dtype=bool),
    )


def assert_same(surfaces: Surfaces, pose, params: SonarParams) -> None:
    new = sonar.simulate_scan(surfaces, pose, params)
    old = dense_scan(surfaces, pose, params)
    np.testing.assert_array_equal(new.ranges, old.ranges)
    np.testing.assert_array_equal(new.target, old.target)
    np.testing.assert_array_equal(new.order, old.order)


@pytest.mark.parametrize("seed", range(24))
def test_random_worlds_give_the_dense_computations_scans(seed):
    rng = np.random.default_rng([16, seed])
    size = float(rng.choice([3.0, 8.0, 20.0]))
    world = random_world(rng, int(rng.integers(1, 40)), int(rng.integers(0, 8)), size)
    params = SonarParams(
        beam_width_deg=float(rng.choice([10.0, 25.0, 60.0, 90.0])),
        step_deg=float(rng.choice([0.5, 1.0, 3.0])),
        max_range=float(rng.choice([5.0, 10.0, 30.0])),
        detection_range=float(rng.choice([8.0, 12.0, 40.0])),
    )
    for _ in range(3):
        pose = (*rng.uniform(-size, size, 2), rng.uniform(-np.pi, np.pi))
        assert_same(world, pose, params)


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (1.2, 0.3, 0.4), (-3.9, 2.1, 2.0), (4.2, -2.5, -1.0)])
def test_inside_a_ring_of_many_segments_the_same_scans(pose):
    assert_same(ring(700), pose, SonarParams())
    assert_same(ring(700), pose, SonarParams(beam_width_deg=90, step_deg=0.5, max_range=100.0))


def test_far_from_the_origin_the_same_scans():
    rng = np.random.default_rng(161)
    world = random_world(rng, 30, 5, 8.0)
    shifted = Surfaces(**{**world.__dict__, "vertices": world.vertices + (5e6, -5e6)})
    shifted = Surfaces(**{**shifted.__dict__, "cylinder_centers": world.cylinder_centers + (5e6, -5e6)})
    for _ in range(4):
        x, y, heading = *rng.uniform(-8, 8, 2), rng.uniform(-np.pi, np.pi)
        assert_same(shifted, (x + 5e6, y - 5e6, heading), SonarParams())


def test_memory_grows_with_the_segments_not_their_square():
    """A ring of 6,000 segments around the sensor: the dense computation held (mirror images x targets) and
    (paths x segments) arrays, over 1 GB here; the bounded one stays under 200 MB."""
    world = ring(6000)
    tracemalloc.start()
    try:
        scan = sonar.simulate_scan(world, (1.2, 0.3, 0.0), SonarParams())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert np.all(scan.order == 1)
    assert peak < 200e6


@pytest.mark.parametrize("seed", range(6))
def test_small_chunks_give_the_same_scans(seed, monkeypatch):
    """Chunks of a few pairs (every loop over chunks runs many times) change nothing."""
    for module in (sonar, sonar_near):  # the model and its spatial pairing both chunk by PAIRS
        monkeypatch.setattr(module, "PAIRS", 7 + 13 * seed)
    rng = np.random.default_rng([16, 100 + seed])
    world = random_world(rng, 25, 4, 6.0)
    for _ in range(3):
        assert_same(world, (*rng.uniform(-6, 6, 2), rng.uniform(-np.pi, np.pi)), SonarParams(step_deg=2.0))
