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


def quaternion(yaw: float) -> object:
    return T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=np.sin(yaw / 2), w=np.cos(yaw / 2))


def scan(t: float, ranges: list[float], increment: float = np.pi / 4, angle_max: float | None = None) -> object:
    n = len(ranges)
    start = -increment * (n - 1) / 2
    return T["sensor_msgs/msg/LaserScan"](
        header=header(t, "laser"),
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


def odometry(t: float, x: float, y: float, yaw: float) -> object:
    v = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    return T["nav_msgs/msg/Odometry"](
        header=header(t, "odom"),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=quaternion(yaw)
            ),
            covariance=np.zeros(36),
        ),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=v, angular=v), covariance=np.zeros(36)
        ),
    )


def transform(t: float, parent: str, child: str, x: float, y: float, yaw: float) -> object:
    stamped = T["geometry_msgs/msg/TransformStamped"](
        header=header(t, parent),
        child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0), rotation=quaternion(yaw)
        ),
    )
    return T["tf2_msgs/msg/TFMessage"](transforms=[stamped])


def sonar(t: float, value: float) -> object:
    return T["sensor_msgs/msg/Range"](
        header=header(t, "sonar"), radiation_type=0, field_of_view=0.4, min_range=0.02, max_range=5.0, range=value
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
    assert record.index == 0 and record.scan.stamp == pytest.approx(1.2)
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
            "/odom@1.000000000: odometry pose (nan, 0.0, 0.0) is not finite",
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
        ([("/odom", "nav_msgs/msg/Odometry", 1.0, odometry(1.0, 0.0, 0.0, 0.0))], None, "0 LaserScan topics (none)"),
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
