"""ROS bag reader: ROS 1 and ROS 2 bags written here with the rosbags writers, poses from odometry or tf."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from evmap.sources.logs.rosbag import RosbagOptions, read_rosbag
from evmap.sources.logs.scan import LogError

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types


def header(t: float, frame: str) -> object:
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=int(t), nanosec=int(t % 1 * 1e9)), frame_id=frame
    )


def quaternion(yaw: float, roll: float = 0.0, pitch: float = 0.0) -> object:
    """The rotation Rz(yaw) Ry(pitch) Rx(roll) as a quaternion message."""
    (cr, sr), (cp, sp), (cy, sy) = ((np.cos(a / 2), np.sin(a / 2)) for a in (roll, pitch, yaw))
    return T["geometry_msgs/msg/Quaternion"](
        x=sr * cp * cy - cr * sp * sy,
        y=cr * sp * cy + sr * cp * sy,
        z=cr * cp * sy - sr * sp * cy,
        w=cr * cp * cy + sr * sp * sy,
    )


def scan(
    t: float, ranges: list[float], increment: float = np.pi / 4, angle_max: float | None = None, frame: str = "laser"
) -> object:
    n = len(ranges)
    start = -increment * (n - 1) / 2
    return T["sensor_msgs/msg/LaserScan"](
        header=header(t, frame),
        angle_min=start,
        angle_max=start + increment * (n - 1) if angle_max is None else angle_max,
        angle_increment=increment,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.05,
        range_max=30.0,
        ranges=np.array(ranges, dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )


def odometry(t: float, x: float, y: float, yaw: float, orientation: object | None = None) -> object:
    v = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    return T["nav_msgs/msg/Odometry"](
        header=header(t, "odom"),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                orientation=quaternion(yaw) if orientation is None else orientation,
            ),
            covariance=np.zeros(36),
        ),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=v, angular=v), covariance=np.zeros(36)
        ),
    )


def transform(
    t: float, parent: str, child: str, x: float, y: float, yaw: float, roll: float = 0.0, pitch: float = 0.0
) -> object:
    stamped = T["geometry_msgs/msg/TransformStamped"](
        header=header(t, parent),
        child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0), rotation=quaternion(yaw, roll, pitch)
        ),
    )
    return T["tf2_msgs/msg/TFMessage"](transforms=[stamped])


def sonar(t: float, value: float, frame: str = "sonar", min_range: float = 0.02) -> object:
    return T["sensor_msgs/msg/Range"](
        header=header(t, frame), radiation_type=0, field_of_view=0.4, min_range=min_range, max_range=5.0, range=value
    )


def write_bag(path: Path, version: int, messages: list[tuple[str, str, float, object]]) -> Path:
    """Write ``(topic, msgtype, time, message)`` in order to a ROS 1 (``version`` 1) or ROS 2 bag."""
    writer = Writer1(path) if version == 1 else Writer2(path, version=9)
    with writer:
        connections: dict[str, object] = {}
        for topic, msgtype, t, msg in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=STORE)
            data = STORE.serialize_ros1(msg, msgtype) if version == 1 else STORE.serialize_cdr(msg, msgtype)
            writer.write(connections[topic], int(t * 1e9), data)
    return path


def bag_path(tmp_path: Path, version: int) -> Path:
    return tmp_path / ("test.bag" if version == 1 else "test_bag")


STATIC = ("/tf_static", "tf2_msgs/msg/TFMessage")
TF = ("/tf", "tf2_msgs/msg/TFMessage")
ODOM = ("/odom", "nav_msgs/msg/Odometry")
SCAN = ("/scan", "sensor_msgs/msg/LaserScan")
RANGE = ("/sonar", "sensor_msgs/msg/Range")
NO_ROTATION = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=0.0)


@pytest.mark.parametrize("version", [1, 2])
def test_odometry_poses_static_laser_offset_and_sonar(tmp_path: Path, version: int) -> None:
    path = write_bag(
        bag_path(tmp_path, version),
        version,
        [
            (*STATIC, 0.0, transform(0.0, "base_link", "laser", 0.2, 0.0, 0.0)),
            (*STATIC, 0.0, transform(0.0, "base_link", "sonar", 0.0, 0.1, np.pi / 2)),
            ("/scan", "sensor_msgs/msg/LaserScan", 0.5, scan(0.5, [1.0, 1.0, 1.0])),  # before any pose: skipped
            ("/odom", "nav_msgs/msg/Odometry", 1.0, odometry(1.0, 1.0, 2.0, np.pi / 2)),
            ("/sonar", "sensor_msgs/msg/Range", 1.1, sonar(1.1, 1.5)),
            ("/scan", "sensor_msgs/msg/LaserScan", 1.2, scan(1.2, [1.0, np.inf, 40.0, 0.01, 2.0])),
        ],
    )
    (record,) = list(read_rosbag(path))
    assert record.index == 0 and record.scan.stamp == pytest.approx(1.2) and record.skipped == 1
    np.testing.assert_allclose(record.robot_pose, [1.0, 2.0, np.pi / 2], atol=1e-9)
    np.testing.assert_allclose(record.scan.pose, [1.0, 2.2, np.pi / 2], atol=1e-6)
    assert np.isnan(record.scan.ranges[1:4]).all() and record.scan.ranges[[0, 4]].tolist() == [1.0, 2.0]
    np.testing.assert_allclose(np.degrees(record.scan.angles), [-90, -45, 0, 45, 90], atol=1e-5)
    assert record.sonar is not None
    assert record.sonar.ranges.tolist() == [1.5] and record.sonar.max_range == 5.0
    np.testing.assert_allclose(record.sonar.offsets, [[0.0, 0.1, np.pi / 2]], atol=1e-6)
    np.testing.assert_allclose(record.sonar.beam_width, [0.4], atol=1e-6)


@pytest.mark.parametrize("version", [1, 2])
def test_tf_poses_without_odometry(tmp_path: Path, version: int) -> None:
    path = write_bag(
        bag_path(tmp_path, version),
        version,
        [
            (*STATIC, 0.0, transform(0.0, "base_link", "laser", 0.2, 0.0, 0.0)),
            ("/tf", "tf2_msgs/msg/TFMessage", 1.0, transform(1.0, "odom", "base_link", 3.0, 0.0, np.pi)),
            ("/scan", "sensor_msgs/msg/LaserScan", 1.1, scan(1.1, [1.0, 1.0, 1.0])),
        ],
    )
    (record,) = list(read_rosbag(path))
    np.testing.assert_allclose(record.scan.pose, [2.8, 0.0, np.pi], atol=1e-6)
    np.testing.assert_allclose(record.robot_pose, [3.0, 0.0, np.pi], atol=1e-6)
    assert record.sonar is None


@pytest.mark.parametrize(
    ("messages", "options", "message"),
    [
        (
            [("/scan", "sensor_msgs/msg/LaserScan", 1.0, scan(1.0, [1.0, 1.0, 1.0], angle_max=3.0))],
            None,
            "/scan@1.000000000: LaserScan of 3 beams",
        ),
        (
            [
                ("/odom", "nav_msgs/msg/Odometry", 1.0, odometry(1.0, np.nan, 0.0, 0.0)),
                ("/scan", "sensor_msgs/msg/LaserScan", 1.1, scan(1.1, [1.0, 1.0, 1.0])),
            ],
            None,
            "/odom@1.000000000: odometry pose (position nan, 0, 0; quaternion 0, 0, 0, 1) is not finite",
        ),
        (
            [
                ("/odom", "nav_msgs/msg/Odometry", 1.0, odometry(1.0, 0.0, 0.0, 0.0)),
                ("/scan", "sensor_msgs/msg/LaserScan", 1.1, scan(1.1, [1000.0, 2000.0, 1500.0])),
            ],
            None,
            "smaller unit than the declared 'm'",
        ),
        (
            [("/scan", "sensor_msgs/msg/LaserScan", 1.0, scan(1.0, [1.0, 1.0, 1.0]))],
            None,
            "none of the 1 scans could be placed in the world by tf to 'odom'",
        ),
        (
            [("/scan", "sensor_msgs/msg/LaserScan", 1.0, scan(1.0, [1.0, 1.0, 1.0]))],
            RosbagOptions(scan_topic="/x"),
            "no LaserScan topic '/x'",
        ),
        (
            [("/odom", "nav_msgs/msg/Odometry", 1.0, odometry(1.0, 0.0, 0.0, 0.0))],
            None,
            "bad_bag: no LaserScan topic (a",
        ),
        (
            [
                ("/odom", "nav_msgs/msg/Odometry", 1.0, odometry(1.0, 0.0, 0.0, 0.0)),
                ("/sonar", "sensor_msgs/msg/Range", 1.1, sonar(1.1, 50.0)),
                ("/scan", "sensor_msgs/msg/LaserScan", 1.2, scan(1.2, [1.0, 1.0, 1.0])),
            ],
            None,
            "/sonar@1.100000000: Range reading 50",
        ),
    ],
)
def test_refused_messages_name_topic_and_stamp(
    tmp_path: Path, messages: list, options: RosbagOptions | None, message: str
) -> None:
    path = write_bag(tmp_path / "bad_bag", 2, messages)
    with pytest.raises(LogError) as info:
        list(read_rosbag(path, options))
    assert message in str(info.value)


def test_files_that_are_no_bag_and_damaged_bags_are_refused_naming_them(tmp_path: Path) -> None:
    (tmp_path / "text.bag").write_text("junk\n")
    (tmp_path / "noise.bag").write_bytes(np.random.default_rng(0).bytes(4000))
    (tmp_path / "empty_dir").mkdir()
    (tmp_path / "bad_metadata").mkdir()
    (tmp_path / "bad_metadata" / "metadata.yaml").write_text("x\n")
    for name, message in [
        ("text.bag", "text.bag: not a ROS bag evmap can read"),
        ("noise.bag", "noise.bag: not a ROS bag evmap can read"),
        ("empty_dir", "empty_dir: a directory, but no ROS 2 bag (it holds no metadata.yaml)"),
        ("bad_metadata", "bad_metadata: not a ROS bag evmap can read"),
    ]:
        with pytest.raises(LogError, match=re.escape(message)):
            list(read_rosbag(tmp_path / name))
    odom = ("/odom", "nav_msgs/msg/Odometry")
    path = write_bag(tmp_path / "whole.bag", 1, [(*odom, 1.0 + k, odometry(1.0 + k, k, 0.0, 0.0)) for k in range(200)])
    data = path.read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[: len(data) // 2])  # a bag whose writing stopped half-way
    with pytest.raises(LogError, match=r"cut.bag: (not a ROS bag evmap can read|damaged bag)"):
        list(read_rosbag(cut))


def test_an_upside_down_laser_sweeps_clockwise(tmp_path: Path) -> None:
    ranges = [1.0, 2.0, 3.0]  # beams at -45, 0, 45 deg in the laser frame
    path = write_bag(
        tmp_path / "upside.bag",
        1,
        [
            (*STATIC, 0.0, transform(0.0, "base_link", "laser", 0.2, 0.0, 0.0, roll=np.pi)),
            (*ODOM, 1.0, odometry(1.0, 0.0, 0.0, np.pi / 2)),
            (*SCAN, 1.1, scan(1.1, ranges)),
        ],
    )
    (record,) = list(read_rosbag(path))
    # a beam at angle a points at -a on the robot (its z axis points down), the robot facing +y
    bearings = np.pi / 2 - np.radians([-45.0, 0.0, 45.0])
    expected = np.column_stack([np.cos(bearings), np.sin(bearings)]) * np.array(ranges)[:, None] + [0.0, 0.2]
    np.testing.assert_allclose(record.scan.points, expected[::-1], atol=1e-6)
    assert np.all(np.diff(record.scan.angles) > 0)


@pytest.mark.parametrize(
    ("messages", "message"),
    [
        (
            [(*STATIC, 0.0, transform(0.0, "base_link", "laser", 0.2, 0.0, 0.0, pitch=np.radians(30)))],
            "the scan plane of the laser frame 'laser' is tilted 30.0 deg from the horizontal (at most 10)",
        ),
        (
            [(*ODOM, 0.5, odometry(0.5, 0.0, 0.0, 0.0, orientation=quaternion(0.0, roll=np.radians(20))))],
            "/odom@0.500000000: odometry pose leans 20.0 deg out of the horizontal plane (at most 10)",
        ),
        (
            [(*ODOM, 0.5, odometry(0.5, 0.0, 0.0, 0.0, orientation=NO_ROTATION))],
            "/odom@0.500000000: odometry pose has the rotation (x, y, z, w) = (0, 0, 0, 0), not a unit quaternion",
        ),
        (
            [
                (*STATIC, 0.0, transform(0.0, "base_link", "laser", 0.0, 0.0, 0.0)),
                (*STATIC, 0.0, transform(0.0, "base_link", "sonar", 0.0, 0.0, 0.0, pitch=np.radians(45))),
                (*RANGE, 0.9, sonar(0.9, 1.0)),
            ],
            "the axis of the range sensor frame 'sonar' points 45.0 deg out of the horizontal plane",
        ),
    ],
)
def test_sensors_and_poses_out_of_the_horizontal_plane_are_refused(
    tmp_path: Path, messages: list, message: str
) -> None:
    path = write_bag(
        tmp_path / "tilted.bag",
        1,
        [*messages, (*ODOM, 1.0, odometry(1.0, 0.0, 0.0, 0.0)), (*SCAN, 1.1, scan(1.1, [1.0, 1.0, 1.0]))],
    )
    with pytest.raises(LogError, match=re.escape(message)):
        list(read_rosbag(path))


def test_a_scan_is_placed_at_its_stamp_between_the_poses_around_it_not_when_it_was_recorded(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "latency.bag",
        1,
        [
            *[(*ODOM, t, odometry(t, t, 0.0, t)) for t in (1.0, 1.1, 1.2, 1.3)],
            (*SCAN, 1.32, scan(1.0, [1.0, 1.0, 1.0])),  # recorded 0.32 s after it was taken
            (*SCAN, 1.35, scan(1.15, [1.0, 1.0, 1.0])),
            (*STATIC, 1.4, transform(0.0, "base_link", "laser", 0.0, 0.0, np.pi)),  # static: at every stamp
        ],
    )
    records = list(read_rosbag(path))
    np.testing.assert_allclose([r.robot_pose for r in records], [[1.0, 0, 1.0], [1.15, 0, 1.15]], atol=1e-9)
    np.testing.assert_allclose([r.scan.pose[2] for r in records], [1.0 - np.pi, 1.15 - np.pi], atol=1e-9)


def test_a_scan_waits_for_the_pose_after_its_stamp_at_most_a_second_of_recording(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "wait.bag",
        1,
        [
            (*ODOM, 1.0, odometry(1.0, 1.0, 0.0, 0.0)),
            (*SCAN, 1.05, scan(1.05, [1.0, 1.0, 1.0], frame="base_link")),  # the next pose comes after it
            (*RANGE, 1.06, sonar(1.06, 2.0, frame="base_link")),
            (*ODOM, 1.1, odometry(1.1, 2.0, 0.0, 0.0)),
            (*SCAN, 1.2, scan(1.2, [1.0, 1.0, 1.0], frame="base_link")),  # no pose after it for 1 s: the latest
            (*RANGE, 2.3, sonar(2.3, 3.0, frame="base_link")),
            (*ODOM, 2.5, odometry(2.5, 9.0, 0.0, 0.0)),
            (*SCAN, 2.6, scan(2.6, [1.0, 1.0, 1.0], frame="base_link")),  # the bag ends: the latest
        ],
    )
    records = list(read_rosbag(path))
    assert [r.index for r in records] == [0, 1, 2]
    np.testing.assert_allclose([r.robot_pose[0] for r in records], [1.5, 2.0, 9.0], atol=1e-9)
    assert records[0].sonar is None and [r.sonar.ranges.tolist() for r in records[1:]] == [[2.0], [3.0]]


def test_tf_is_interpolated_turning_the_short_way(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "turn.bag",
        1,
        [
            (*TF, 1.0, transform(1.0, "odom", "base_link", 0.0, 0.0, np.pi - 0.1)),
            (*SCAN, 1.1, scan(1.25, [1.0, 1.0, 1.0], frame="base_link")),
            (*TF, 1.2, transform(1.5, "odom", "base_link", 2.0, 0.0, -np.pi + 0.1)),
        ],
    )
    (record,) = list(read_rosbag(path))
    np.testing.assert_allclose(record.robot_pose[:2], [1.0, 0.0], atol=1e-9)
    assert abs(abs(record.robot_pose[2]) - np.pi) < 1e-9  # through pi, not through 0


def test_the_readings_of_a_scan_that_could_not_be_placed_come_with_the_next(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "early.bag",
        1,
        [
            (*RANGE, 0.4, sonar(0.4, 2.0, frame="base_link")),
            (*SCAN, 0.5, scan(0.5, [1.0, 1.0, 1.0], frame="base_link")),  # before any pose: skipped
            (*ODOM, 1.0, odometry(1.0, 1.0, 0.0, 0.0)),
            (*SCAN, 1.1, scan(1.0, [1.0, 1.0, 1.0], frame="base_link")),
        ],
    )
    (record,) = list(read_rosbag(path))
    assert record.skipped == 1 and record.sonar is not None and record.sonar.ranges.tolist() == [2.0]


def test_transforms_recorded_out_of_stamp_order_apply_by_stamp(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "tf.bag",
        1,
        [
            (*TF, 1.0, transform(1.0, "odom", "base_link", 1.0, 0.0, 0.0)),
            (*TF, 2.0, transform(3.0, "odom", "base_link", 3.0, 0.0, 0.0)),
            (*TF, 2.5, transform(2.0, "odom", "base_link", 2.0, 0.0, 0.0)),  # older than the one held
            (*SCAN, 3.6, scan(3.5, [1.0, 1.0, 1.0], frame="base_link")),
            (*SCAN, 3.7, scan(2.2, [1.0, 1.0, 1.0], frame="base_link")),
        ],
    )
    np.testing.assert_allclose([r.robot_pose[0] for r in read_rosbag(path)], [3.0, 2.2], atol=1e-9)


def test_a_scan_older_than_the_poses_kept_after_placed_scans_is_refused(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "old.bag",
        1,
        [
            *[(*ODOM, 1.0 + k, odometry(1.0 + k, k, 0.0, 0.0)) for k in range(40)],
            (*SCAN, 40.5, scan(40.5, [1.0, 1.0, 1.0], frame="base_link")),
            (*SCAN, 40.6, scan(0.5, [1.0, 1.0, 1.0], frame="base_link")),  # before every pose read
        ],
    )
    with pytest.raises(LogError, match=r"/scan@0.500000000: no pose at or before the scan's stamp by odometry"):
        list(read_rosbag(path))


@pytest.mark.parametrize(
    ("messages", "frame"),
    [
        ([(*STATIC, 0.0, transform(0.0, "base_link", "laser_mount", 0.2, 0.0, 0.0))], "laser"),
        (
            [
                (*STATIC, 0.0, transform(0.0, "base_link", "laser", 0.2, 0.0, 0.0)),
                (*RANGE, 1.05, sonar(1.05, 1.0, frame="sonar_left")),
            ],
            "sonar_left",
        ),
    ],
)
def test_a_sensor_tf_does_not_link_to_the_robot_is_refused(tmp_path: Path, messages: list, frame: str) -> None:
    path = write_bag(
        tmp_path / "unlinked.bag",
        1,
        [*messages, (*ODOM, 1.0, odometry(1.0, 0.0, 0.0, 0.0)), (*SCAN, 1.1, scan(1.1, [1.0, 1.0, 1.0]))],
    )
    message = f"unlinked.bag /scan@1.100000000: tf does not link the frame {frame!r} to the robot's frame 'base_link'"
    with pytest.raises(LogError, match=re.escape(message)):
        list(read_rosbag(path))


def test_without_any_tf_the_sensors_sit_on_the_robot_s_centre(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "simple.bag",
        1,
        [
            (*ODOM, 1.0, odometry(1.0, 1.0, 2.0, 0.5)),
            (*RANGE, 1.05, sonar(1.05, 1.0)),
            (*SCAN, 1.1, scan(1.1, [1.0, 1.0, 1.0])),
        ],
    )
    (record,) = list(read_rosbag(path))
    np.testing.assert_allclose(record.scan.pose, [1.0, 2.0, 0.5], atol=1e-9)
    assert record.sonar is not None and record.sonar.offsets.tolist() == [[0.0, 0.0, 0.0]]


def test_a_ring_is_a_new_object_exactly_when_a_range_message_came_whatever_its_stamp(tmp_path: Path) -> None:
    path = write_bag(
        tmp_path / "stamps.bag",
        1,
        [
            (*ODOM, 1.0, odometry(1.0, 0.0, 0.0, 0.0)),
            (*RANGE, 1.05, sonar(0.0, 1.0)),  # every reading stamped 0
            (*SCAN, 1.1, scan(1.1, [1.0, 1.0, 1.0])),
            (*RANGE, 1.15, sonar(0.0, 2.0)),
            (*SCAN, 1.2, scan(1.2, [1.0, 1.0, 1.0])),
            (*SCAN, 1.3, scan(1.3, [1.0, 1.0, 1.0])),
        ],
    )
    first, second, third = (r.sonar for r in read_rosbag(path))
    assert first is not None and second is not None and first is not second and third is second
    assert (first.ranges.tolist(), second.ranges.tolist()) == ([1.0], [2.0])


def test_a_range_too_close_to_measure_is_an_echo_at_min_range(tmp_path: Path) -> None:
    values = {"/a": -np.inf, "/b": 0.01, "/c": np.inf, "/d": 0.03, "/e": np.nan, "/f": 5.0}
    path = write_bag(
        tmp_path / "close.bag",
        1,
        [
            (*ODOM, 1.0, odometry(1.0, 0.0, 0.0, 0.0)),
            *[(topic, RANGE[1], 1.05, sonar(1.05, v, frame="base_link")) for topic, v in values.items()],
            (*SCAN, 1.1, scan(1.1, [1.0, 1.0, 1.0])),
        ],
    )
    (record,) = list(read_rosbag(path))
    assert record.sonar is not None
    np.testing.assert_allclose(record.sonar.ranges, [0.02, 0.02, np.nan, 0.03, np.nan, np.nan])
    bad = write_bag(
        tmp_path / "bad.bag",
        1,
        [
            (*ODOM, 1.0, odometry(1.0, 0.0, 0.0, 0.0)),
            (*RANGE, 1.05, sonar(1.05, 1.0, min_range=-1.0)),
            (*SCAN, 1.1, scan(1.1, [1.0, 1.0, 1.0])),
        ],
    )
    with pytest.raises(LogError, match=re.escape("/sonar@1.050000000: Range min_range -1 is not a number from 0")):
        list(read_rosbag(bad))


def test_a_few_readings_far_beyond_range_max_and_minus_inf_are_no_returns(tmp_path: Path) -> None:
    """A driver reporting its no-returns as 60 m beyond a 30 m range_max, or a too-close beam as -inf (REP 117),
    had the whole bag refused ("a smaller unit than the declared 'm'?"); most readings that far still are."""
    path = write_bag(
        bag_path(tmp_path, 1),
        1,
        [
            ("/odom", "nav_msgs/msg/Odometry", 1.0, odometry(1.0, 0.0, 0.0, 0.0)),
            ("/scan", "sensor_msgs/msg/LaserScan", 1.1, scan(1.1, [2.0, 65.5, -np.inf, 2.0, 2.0])),
        ],
    )
    (record,) = list(read_rosbag(path))
    assert np.isnan(record.scan.ranges[[1, 2]]).all() and (record.scan.ranges[[0, 3, 4]] == 2.0).all()


def test_a_range_glitch_is_no_echo_but_a_topic_of_implausible_readings_is_a_wrong_unit(tmp_path: Path) -> None:
    def bag(name: str, values: list[float]) -> Path:
        messages = [(*ODOM, 1.0, odometry(1.0, 0.0, 0.0, 0.0))]
        for k, value in enumerate(values):
            t = 1.1 + 0.1 * k
            messages += [(*RANGE, t, sonar(t, value)), (*SCAN, t + 0.01, scan(t + 0.01, [1.0, 1.0, 1.0]))]
        return write_bag(tmp_path / name, 1, messages)

    records = list(read_rosbag(bag("glitch.bag", [1.5, 65.535, 2.0, -1.0, 1.2])))  # a driver's 0xFFFF mm, a -1
    assert [r.sonar.ranges[0] if r.sonar else None for r in records] == pytest.approx(
        [1.5, np.nan, 2.0, np.nan, 1.2], nan_ok=True
    )
    with pytest.raises(
        LogError,
        match=r"/sonar@1\.100000000: Range reading 150 m is negative or over twice max_range 5 "
        r"\(10 of the first 10 readings on /sonar are\): is the unit 'm' right\?",
    ):
        list(read_rosbag(bag("centimetres.bag", [150.0] * 11 + [120.0] * 5)))
