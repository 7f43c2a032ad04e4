"""The raw segment store behind a map, and observations that bring a new sensor's features."""

import numpy as np
import pytest

from evidential import Frame
from evmap import configs
from evmap.maps import new_map
from evmap.maps.observation import Observation, observe
from evmap.maps.segments import SegmentStore
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import default_scenario
from evmap.sources.sim.world import World

FRAME = Frame(["real", "noise"])


def test_append_grows_and_columns_are_read_only_views_written_by_the_store():
    store = SegmentStore.empty(FRAME)
    for k in range(100):
        ids = store.append([[k, 0.0]], [[k, 1.0]], [k % 3], ["real" if k % 2 else "noise"])
        assert ids.tolist() == [k]
    assert len(store) == 100 and store.p.shape == (100, 2) and store.mass.shape == (100, 4)
    store.write([3, 5], relation="inside")
    store.write([3], eliminated=True)
    assert store.relation[3] == "inside" and store.eliminated.sum() == 1 and store.line[99] == ""
    with pytest.raises(ValueError, match="read-only"):
        store.relation[4] = "inside"
    with pytest.raises(ValueError, match=r"cannot write \['p'\]"):
        store.write([0], p=[5.0, 5.0])
    with pytest.raises(IndexError, match="not all among the 100 segments"):
        store.write([100], line="L1")
    assert store.near((10.5, -1, 12.5, 2)).tolist() == [11, 12]
    assert store.near(np.array([(10.5, -1, 12.5, 2), (39.5, -1, 40.2, 2), (10.5, -1, 11.5, 2)])).tolist() == [
        11,
        12,
        40,
    ]


def test_a_pose_that_saw_no_segment_is_filed_once_the_rows_are_filed_by_pose():
    """A stripe that saw nothing, after the rows were looked up by pose (the rays of a sensor that reports every
    surface it lit): no rows, and the other poses' rows as they were."""
    store = SegmentStore.empty(Frame(["real", "noise"]))
    store.append([[0, 0], [1, 0]], [[1, 0], [2, 0]], [0, 1], ["", ""])
    assert store.seen_from(1).tolist() == [1]
    assert store.append(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, dtype=int), np.zeros(0, dtype=str)).size == 0
    assert store.seen_from(2).tolist() == [] and store.seen_from(0).tolist() == [0]


def test_restore_puts_back_what_was_written_since_the_checkpoint_and_drops_the_rows_appended():
    store = SegmentStore.empty(FRAME)
    store.append([[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [2.0, 0.0]], [0, 0], ["", ""])
    store.write([0, 1], relation="inside", line="L1")
    before = store.to_json()
    checkpoint = store.checkpoint()
    store.write([1], relation="outside", eliminated=True)
    store.append([[5.0, 5.0]], [[6.0, 5.0]], [1], [""])
    store.write([1, 2], line="L2", mass=[[0.0, 0.5, 0.5, 0.0]] * 2)
    store.consolidate([0, 1], [0.0, 0.0], [2.0, 0.0], "L3", 4)
    store.restore(checkpoint)
    assert store.to_json() == before
    assert store.near((-1, -1, 10, 10)).tolist() == [0, 1]
    kept = store.checkpoint()
    store.write([0], relation="outside")
    store.release(kept)
    store.write([1], relation="outside")  # no longer journalled: stays whatever is restored
    store.restore(kept)
    assert store.relation.tolist() == ["inside", "outside"]


def test_json_round_trip_with_features_is_exact():
    store = SegmentStore.empty(FRAME)
    store.append([[0.1, 1 / 3]], [[2.0, 0.7]], [0], ["noise"], {"ir_return": ["beyond"], "echo": [0.25]})
    store.write([0], mass=[0.0, 0.1, 0.7, 0.2])
    back = SegmentStore.from_json(store.to_json(), FRAME)
    assert back.to_json() == store.to_json()
    assert back.p[0, 1] == 1 / 3 and back.features["echo"].tolist() == [0.25]
    back.append([[5.0, 5.0]], [[6.0, 5.0]], [1], ["real"], {"ir_return": ["no_return"], "echo": [0.5]})
    assert back.features["ir_return"].tolist() == ["beyond", "no_return"]


def test_bad_store_data_names_the_column():
    data = SegmentStore.empty(FRAME).to_json()
    del data["mass"]
    with pytest.raises(ValueError, match="'mass' is missing"):
        SegmentStore.from_json(data, FRAME)
    data = SegmentStore.empty(FRAME).to_json()
    data["p"] = [[0.0, 0.0]]
    with pytest.raises(ValueError, match="different lengths"):
        SegmentStore.from_json(data, FRAME)


def test_features_must_match_the_segments_already_stored():
    store = SegmentStore.empty(FRAME)
    store.append([[0, 0]], [[1, 0]], [0], ["real"], {"ir_return": ["echo"]})
    with pytest.raises(ValueError, match="brings features"):
        store.append([[0, 0]], [[1, 0]], [1], ["real"])
    with pytest.raises(ValueError, match="one value per segment"):
        store.append([[0, 0]], [[1, 0]], [1], ["real"], {"ir_return": ["echo", "echo"]})


def test_a_new_sensor_defined_in_yaml_takes_part_in_noise_elimination():
    """configs/examples/infrared.yaml: an infrared reading per segment, brought by the observation."""
    base = load_config()
    infrared = load_config(configs.path("examples/infrared.yaml"))
    obs = observe(World(default_scenario()), 0, base)
    plain = new_map(base)
    plain.update(obs)
    refused = new_map(infrared)
    with pytest.raises(ValueError, match="'ir_return'"):
        refused.update(obs)  # the new source needs its feature
    assert len(refused.segments) == 0 and refused.open_space.is_empty and refused.graph.graph["poses"] == []
    # the IR beam passes through every phantom and returns from every real surface
    ir = np.where(obs.lsl.truth == "noise", "beyond", "echo")
    bm = new_map(infrared)
    bm.update(Observation(obs.pose_index, obs.sonar, obs.lsl, {"ir_return": ir}))
    noise = bm.segments.truth == "noise"
    col = FRAME.mask("noise")
    assert (bm.segments.mass[noise, col] >= plain.segments.mass[noise, col]).all()
    assert (bm.segments.mass[~noise, col] <= plain.segments.mass[~noise, col]).all()
    assert bm.segments.features["ir_return"].tolist() == ir.tolist()


def test_observation_features_are_checked():
    obs = observe(World(default_scenario()), 0, load_config())
    with pytest.raises(ValueError, match="one value per LSL segment"):
        Observation(0, obs.sonar, obs.lsl, {"ir_return": ["echo"]})
    with pytest.raises(ValueError, match="computed by the pipeline"):
        Observation(0, obs.sonar, obs.lsl, {"length": np.ones(len(obs.lsl))})


def test_an_observation_folds_into_a_map_once():
    config = load_config()
    obs = observe(World(default_scenario()), 0, config)
    bm = new_map(config)
    bm.update(obs)
    with pytest.raises(ValueError, match="pose 0 is already folded"):
        bm.update(obs)
    assert bm.graph.graph["poses"] == [0]
