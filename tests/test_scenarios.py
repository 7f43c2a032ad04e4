"""The packaged scenarios beyond the paper's corridor: each one's expectation, from principle.

Each scenario of ``configs/scenarios/`` says in its comment block what it
exercises and what to expect; these tests hold it to that. The expectations
come from the paper's method, not from the numbers of one run: a surface the
sonar hears at normal incidence and the LSL cannot see (glass, a mirror) is
explained by an unidentified object there; a wall both sensors see is
reinforced; a surface only the LSL sees (acoustic foam) gets no sonar
evidence; phantom lines in the sonar's open space are eliminated and real
ones are not; repeated observations make agreeing beliefs grow.

Thresholds, with margin from what was measured (Dempster's rule, paper.yaml):

========  ============  =========  ===============================
scenario  noise recall  real loss  unidentified at the glass/mirror
========  ============  =========  ===============================
office    12/12         1/29       0.00 m
hall      16/16         0/36       0.00 m
lab       13/14         0/19       0.00 m
patrol    24/24         34/72      0.00 m (from each of 3 poses)
========  ============  =========  ===============================
"""

from __future__ import annotations

import numpy as np
import pytest

from evidential import MassFunction, combine
from evmap import configs
from evmap.maps import Line
from evmap.maps.app.run import Run, report, run_scenario
from evmap.sources.config import config_from_data, load_config
from evmap.sources.ray_casting import cast_rays
from evmap.sources.relation import relation
from evmap.sources.sim.scenario import load_scenario
from evmap.sources.sim.world import World

SCENARIOS = ("office", "hall", "lab", "patrol")

MIN_NOISE_RECALL = 0.85
"""Phantom recall must be at least this (lowest measured: 13/14 = 0.93, lab)."""

MAX_REAL_LOSS = 0.10
"""At most one real segment in ten may be lost (highest measured where it holds: 1/29 = 0.034, office)."""

GLASS_RADIUS = 0.3
"""An unidentified object explains a glass or mirror wall within this distance (DESIGN: unidentified.merge_radius)."""

ON_LINE = 0.05
"""A map line lies along a surface when it passes within this (m): the merging and corner tolerance."""

END_MARGIN = 0.1
"""A normal-incidence point closer than this to a wall's end is a corner's, not the wall's."""

SINGLE_POSE = SCENARIOS[:-1]
"""The scenarios observed from one pose; patrol's three poses are judged against their union (below)."""


@pytest.fixture(scope="module")
def runs() -> dict[str, Run]:
    config = load_config()
    return {name: run_scenario(load_scenario(configs.path(f"scenarios/{name}.yaml")), config) for name in SCENARIOS}


def _segment_distance(xy: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance from the point ``xy`` to each segment ``p``-``q`` ((N, 2) arrays)."""
    d = q - p
    t = np.clip(np.einsum("ij,ij->i", xy - p, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
    return np.hypot(*(p + t[:, None] * d - xy).T)


def _normal_points(world: World, select: np.ndarray, reach: float) -> list[tuple[int, int, np.ndarray]]:
    """(pose, wall segment, foot) for each selected wall segment some pose sees at normal incidence.

    The foot of the perpendicular from the pose lies on the segment, at least
    END_MARGIN from its ends, within ``reach``, and is the first surface of any
    kind (wall, glass, foam, cylinder) on the straight line from the pose.
    """
    s = world.surfaces()
    found = []
    for k, pose in enumerate(world.poses):
        for i in np.flatnonzero(select):
            p, q = s.p[i], s.q[i]
            d = q - p
            length = np.hypot(*d)
            t = np.dot(pose[:2] - p, d) / length**2
            if not END_MARGIN <= t * length <= length - END_MARGIN:
                continue
            foot = p + t * d
            distance = np.hypot(*(foot - pose[:2]))
            angle = np.arctan2(*(foot - pose[:2])[::-1])
            _, hit = cast_rays(pose[:2], [angle], s.p, s.q, s.cylinder_centers, s.cylinder_radii, reach)
            if distance <= reach and hit[0] == i:
                found.append((k, int(i), foot))
    return found


def _sensor_reach(run: Run) -> tuple[float, float]:
    sonar, lsl = run.world.scenario.sensor_params(run.config.sensors.sonar, run.config.sensors.lsl)
    return sonar.max_range, lsl.max_range


def _lines_along(run: Run, p: np.ndarray, q: np.ndarray) -> list:
    """The map lines with both ends within ON_LINE of the surface segment p-q."""
    return [
        line
        for line in run.map.lines(min_belief=0.0)
        if _segment_distance(np.array([line.p, line.q]), np.array([p, p]), np.array([q, q])).max() <= ON_LINE
    ]


def _base_mass(run: Run, line_id: str) -> MassFunction:
    """A line's mass from the noise-elimination stage alone (the first record of its history)."""
    line = run.map[line_id]
    first = run.map.graph.edge(line.u, line.v)["history"][0]
    assert first["stage"] == "noise_elimination"
    return MassFunction.from_dict(run.map.frame, first["mass"], open_world=True)


def _sonar_records(run: Run, line_id: str) -> list[dict]:
    line = run.map[line_id]
    return [r for r in run.map.graph.edge(line.u, line.v)["history"] if r.get("stage") == "reinforcement"]


# --------------------------------------------------------------------- every scenario


@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario_file_is_documented_and_named_after_itself(name):
    path = configs.path(f"scenarios/{name}.yaml")
    text = path.read_text()
    assert text.startswith("#") and "What to expect" in text
    assert load_scenario(path).name == name


@pytest.mark.parametrize("name", SCENARIOS)
def test_phantom_lines_are_eliminated(runs, name):
    r = report(runs[name])
    assert r["noise_segments"] >= 10
    assert r["noise_recall"] >= MIN_NOISE_RECALL


@pytest.mark.parametrize("name", SINGLE_POSE)
def test_real_segments_are_kept(runs, name):
    r = report(runs[name])
    assert r["real_loss"] <= MAX_REAL_LOSS


@pytest.mark.parametrize("name", SCENARIOS)
def test_glass_and_mirrors_heard_at_normal_incidence_become_unidentified_objects(runs, name):
    run = runs[name]
    s = run.world.surfaces()
    sonar_reach, _ = _sensor_reach(run)
    seen = _normal_points(run.world, ~s.lsl_opaque & s.sonar_reflective, sonar_reach)
    assert seen, "the scenario has a glass or mirror wall that some pose hears at normal incidence"
    objects = np.array([u.xy for u in run.map.unidentified()]).reshape(-1, 2)
    for pose, wall, foot in seen:
        nearest = np.hypot(*(objects - foot).T).min(initial=np.inf)
        assert nearest <= GLASS_RADIUS, (pose, s.segment_ids[wall], nearest)


@pytest.mark.parametrize("name", SINGLE_POSE)
def test_walls_both_sensors_see_become_landmarks(runs, name):
    run = runs[name]
    s = run.world.surfaces()
    reach = min(_sensor_reach(run))
    seen = _normal_points(run.world, s.lsl_opaque & s.sonar_reflective, reach)
    assert len(seen) >= 3
    landmarks = [o for o in run.map.landmarks() if isinstance(o, Line)]
    p = np.array([line.p for line in landmarks]).reshape(-1, 2)
    q = np.array([line.q for line in landmarks]).reshape(-1, 2)
    for pose, wall, foot in seen:
        assert len(p) and _segment_distance(foot, p, q).min() <= ON_LINE, (pose, s.segment_ids[wall])


# --------------------------------------------------------------------- office: behind the glass


def test_walls_the_lsl_sees_through_the_glass_stay_in_the_map(runs):
    run = runs["office"]
    s = run.world.surfaces()
    behind = np.flatnonzero(np.char.startswith(s.segment_ids, "meeting-room"))
    assert len(behind) == 3
    for i in behind:  # outside the open space: the sonar's sound stops at the glass
        assert any(line.belief > 0.5 for line in _lines_along(run, s.p[i], s.q[i])), s.segment_ids[i]


# --------------------------------------------------------------------- hall: pillars


def test_pillars_facing_the_robot_become_landmarks(runs):
    run = runs["hall"]
    s = run.world.surfaces()
    pose = run.world.poses[0]
    landmarks = [o for o in run.map.landmarks() if isinstance(o, Line)]
    assert len(s.cylinder_ids) == 4
    for center, radius, name in zip(s.cylinder_centers, s.cylinder_radii, s.cylinder_ids, strict=True):
        angle = np.arctan2(*(center - pose[:2])[::-1])
        _, hit = cast_rays(pose[:2], [angle], s.p, s.q, s.cylinder_centers, s.cylinder_radii, np.inf)
        assert s.cylinder_ids[hit[0] - len(s.p)] == name  # in sight
        on_it = [
            line
            for line in landmarks
            if np.all(np.abs(np.hypot(*(np.array([line.p, line.q]) - center).T) - radius) <= ON_LINE)
        ]
        assert on_it, name


# --------------------------------------------------------------------- lab: foam


def _foam_lines(run: Run) -> list:
    s = run.world.surfaces()
    (i,) = np.flatnonzero(s.segment_ids == "foam-screen")
    lines = _lines_along(run, s.p[i], s.q[i])
    assert lines, "the LSL sees the foam screen"
    return lines


def test_foam_screen_seen_by_the_lsl_only_is_no_landmark(runs):
    run = runs["lab"]
    landmarks = [o for o in run.map.landmarks() if isinstance(o, Line)]
    foam = _foam_lines(run)
    assert not {line.id for line in foam} & {line.id for line in landmarks}
    assert max(line.belief for line in foam) < min(line.belief for line in landmarks)


def test_foam_screen_keeps_a_mid_level_belief(runs):
    """The map cannot know the screen absorbs sound: sonar predicts an echo and hears none, so the
    line gets the weak disagreeing evidence ``missed`` (never ``matched``) and keeps a mid-level belief."""
    run = runs["lab"]
    for line in _foam_lines(run):
        assert {r["category"] for r in _sonar_records(run, line.id)} <= {"missed"}
        assert 0.5 < line.belief <= _base_mass(run, line.id).belief("real")


# --------------------------------------------------------------------- patrol: repeated observations


def test_beliefs_grow_with_agreeing_evidence_from_several_poses(runs):
    run = runs["patrol"]
    config = run.config
    (source,) = config.stage_sources("reinforcement")
    row = source.masses({"sonar_match": np.array(["matched"])})[0]
    matched_once = MassFunction.from_dense(run.map.frame, row, open_world=True)
    grown = 0
    for line in run.map.lines(min_belief=0.0):
        records = _sonar_records(run, line.id)
        poses = {r["pose"] for r in records if r["category"] == "matched"}
        if len(poses) < 2 or any(r["category"] == "missed" for r in records):
            continue
        one_pose = combine(_base_mass(run, line.id), matched_once, rule=config.rule).belief("real")
        assert line.belief > one_pose, line.id
        grown += 1
    assert grown >= 3


@pytest.mark.parametrize("name", ["office", "lab"])
def test_beliefs_fall_with_disagreeing_evidence(runs, name):
    """A line the simulated sonar predicts and the actual sonar misses believes less than it did."""
    run = runs[name]
    fallen = 0
    for line in run.map.lines(min_belief=0.0):
        records = _sonar_records(run, line.id)
        if records and all(r["category"] == "missed" for r in records):
            assert line.belief < _base_mass(run, line.id).belief("real"), line.id
            fallen += 1
    assert fallen >= 1


def test_relations_are_judged_against_the_union_of_every_poses_open_space(runs):
    run = runs["patrol"]
    store = run.map.segments
    union = run.map.open_space
    spaces = [o.open_space for o in run.outcomes]
    assert len(spaces) == 3
    assert union.symmetric_difference(spaces[0].union(spaces[1]).union(spaces[2])).area < 1e-6
    assert relation(store.p, store.q, union, run.config.noise).tolist() == store.relation.tolist()
    own = np.concatenate(
        [relation(store.p[o.segments], store.q[o.segments], o.open_space, run.config.noise) for o in run.outcomes]
    )
    order = np.concatenate([o.segments for o in run.outcomes])
    rank = {"outside": 0, "partly_inside": 1, "inside": 2}
    before = np.array([rank[r] for r in own])
    after = np.array([rank[r] for r in store.relation[order]])
    assert np.all(after >= before)  # more open space can only bring a segment further in
    assert np.any(after > before)  # and the union decides differently from a pose's own open space


def test_repeated_observations_keep_the_walls_the_union_of_open_spaces_covers(runs):
    """The contract judges every segment against the union of all poses' open spaces. An RCD's sector
    spans its whole arc at its range, and specular side walls are silent at oblique incidence, so a
    far RCD's sector covers part of them: one pose leaves each real segment partly outside, the union
    of three covers some completely. The repeated-observation source (another pose's LSL saw the
    segment again) keeps them; without it, the union costs a third of the real segments or more."""
    run = runs["patrol"]
    assert report(run)["real_loss"] <= MAX_REAL_LOSS
    data = run.config.to_data()
    data["stages"]["repeated_observation"] = []
    without = run_scenario(run.world.scenario, config_from_data(data, "paper.yaml without lsl_repeat"))
    assert report(without)["real_loss"] >= 0.3
    assert report(without)["noise_recall"] == report(run)["noise_recall"]  # phantoms are seen once
