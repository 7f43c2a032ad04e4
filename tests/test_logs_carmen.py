"""CARMEN log reader: the excerpts of the Intel and Freiburg 079 logs, and every refused line."""

from __future__ import annotations

import gzip
import os
from pathlib import Path

import numpy as np
import pytest

from evmap.maps.app.log_run import run_log
from evmap.sources.config import load_config
from evmap.sources.logs import open_log
from evmap.sources.logs.carmen import CarmenOptions, read_carmen
from evmap.sources.logs.scan import LogError

DATA = Path(__file__).parent / "data" / "logs"
INTEL = DATA / "intel-excerpt.log.gz"
FREIBURG = DATA / "freiburg-079-excerpt.log.gz"
FLASER = "FLASER 3 1.0 2.0 3.0 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0"


def write(tmp_path: Path, *lines: str, name: str = "x.log") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_intel_excerpt_layout_and_no_returns() -> None:
    records = list(read_carmen(INTEL))
    assert len(records) == 30
    assert [r.index for r in records] == list(range(30))
    scan = records[0].scan
    assert len(scan) == 180 and scan.max_range == 80.0
    np.testing.assert_allclose(np.degrees(scan.angles[[0, -1]]), [-90, 90])
    assert np.all(np.isnan(scan.ranges) | (scan.ranges < 80))
    with gzip.open(INTEL, "rt") as f:
        raw = next(line.split() for line in f if line.startswith("FLASER"))
    assert (np.isnan(scan.ranges) == (np.array(raw[2:182], dtype=float) >= 80)).all()
    np.testing.assert_allclose(scan.pose, np.array(raw[182:185], dtype=float))
    assert records[0].sonar is None


def test_freiburg_excerpt_takes_layout_and_max_range_from_param() -> None:
    records = list(read_carmen(FREIBURG))
    assert len(records) == 20
    scan = records[0].scan
    assert len(scan) == 360 and scan.max_range == pytest.approx(80.99)
    np.testing.assert_allclose(np.degrees(np.diff(scan.angles)), 0.5)
    np.testing.assert_allclose(np.degrees(scan.angles[[0, -1]]), [-89.75, 89.75])
    # robot_frontlaser_offset -0.04: the robot is 4 cm ahead of the laser
    offset = records[0].robot_pose[:2] - scan.pose[:2]
    np.testing.assert_allclose(offset, 0.04 * np.array([np.cos(scan.pose[2]), np.sin(scan.pose[2])]), atol=1e-12)


def test_log_is_reiterable_and_options_override(tmp_path: Path) -> None:
    log = read_carmen(write(tmp_path, FLASER), CarmenOptions(fov_deg=90, max_range=2.5))
    first, second = list(log), list(log)
    assert len(first) == len(second) == 1
    np.testing.assert_allclose(np.degrees(first[0].scan.angles), [-45, 0, 45])
    assert np.isnan(first[0].scan.ranges[2])


def test_plain_and_gzip_read_alike(tmp_path: Path) -> None:
    plain = write(tmp_path, FLASER)
    zipped = tmp_path / "x.log.gz"
    zipped.write_bytes(gzip.compress(plain.read_bytes()))
    a, b = next(iter(read_carmen(plain))), next(iter(read_carmen(zipped)))
    np.testing.assert_array_equal(a.scan.ranges, b.scan.ranges)


def test_a_byte_order_mark_is_no_part_of_the_first_line(tmp_path: Path) -> None:
    """A log saved with a UTF-8 byte-order mark lost its first line: a PARAM, or the first scan."""
    path = tmp_path / "bom.log"
    path.write_text("PARAM robot_frontlaser_offset 0.5\n" + FLASER + "\n", encoding="utf-8-sig")
    (record,) = read_carmen(path)
    np.testing.assert_allclose(record.robot_pose[:2], [0.0, 0.0], atol=1e-12)  # the laser 0.5 m ahead, at x = 0.5


def test_robotlaser1_and_sonar(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "SONAR 0.4363 2 1.0 9.0 0.1 0.0 0.0 0.0 0.1 1.5708 3.0 host 3.0",
        "ROBOTLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 50 3 0 1 2 0.1 1 2 0.1 0 0 0 0 0 5.0 host 5.0",
    )
    (record,) = read_carmen(path)
    assert record.scan.ranges.tolist()[1:] == [pytest.approx(np.nan, nan_ok=True), 3.0]
    assert record.sonar is not None
    assert record.sonar.ranges[0] == 1.0 and np.isnan(record.sonar.ranges[1])
    np.testing.assert_allclose(record.sonar.beam_width, 0.4363)
    np.testing.assert_allclose(record.sonar.offsets[1], [0, 0.1, 1.5708])


def test_a_sonar_glitch_is_no_echo_and_a_sonar_in_another_unit_is_refused(tmp_path: Path) -> None:
    """One reading of 10.7 m (the sonar's maximum 5 m) refused the whole log, where a ROS bag's is no echo."""
    offsets = " ".join(["0 0 0"] * 3)
    path = write(tmp_path, f"SONAR 0.4363 3 1.0 10.7 2.0 {offsets} 3.0 host 3.0", FLASER)
    (record,) = read_carmen(path)
    assert record.sonar is not None and np.isnan(record.sonar.ranges[1])
    assert record.sonar.ranges[[0, 2]].tolist() == [1.0, 2.0]
    path = write(tmp_path, f"SONAR 0.4363 3 1000 1070 2000 {offsets} 3.0 host 3.0", FLASER)
    with pytest.raises(LogError, match=r"x.log:1: the SONAR readings' median 1070 m is over twice .* 'm' right"):
        list(read_carmen(path))


def test_millimetres_declared(tmp_path: Path) -> None:
    line = "FLASER 3 1000 2000 3000 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0"
    (record,) = read_carmen(write(tmp_path, line), CarmenOptions(unit="mm"))
    assert record.scan.ranges.tolist() == [1.0, 2.0, 3.0]


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("FLASER 3 1.0 2.0 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0", "x.log:2: FLASER with 3 beams needs 14 fields"),
        ("FLASER three 1.0 2.0 3.0 0 0 0 0 0 0 1 h 1", "x.log:2: FLASER beam count 'three' is not an integer"),
        ("FLASER é 1.0 2.0 3.0 0 0 0 0 0 0 1 h 1", "x.log:2: FLASER beam count 'é' is not an integer"),
        ("FLASER 3 1.0 abc 3.0 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0", "x.log:2: a range reading is not a number"),
        ("FLASER 3 1.0 -2.0 3.0 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0", "x.log:2: reading 1 is negative"),
        ("FLASER 3 1.0 2.0 3.0 nan 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0", "x.log:2: laser pose (nan, 0.0, 0.0)"),
        ("FLASER 3 1.0 2.0 3.0 0.5 inf 0.0 0.5 0.0 0.0 10.0 host 10.0", "is not finite"),
        ("FLASER 3 1000 2000 3000 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0", "smaller unit than the declared 'm'"),
        ("ODOM 0 nan 0 0 0 0 1 host 1", "x.log:2: odometry pose"),
        ("ODOM 0 0 0 0 0 1 host 1", "x.log:2: ODOM needs 10 fields"),
        ("SONAR 0.4 2 1.0 2.0 0 0 0 3.0 host 3.0", "x.log:2: SONAR with 2 sensors needs 14 fields"),
        ("SONAR 0.4 1 -1.0 0 0 0 3.0 host 3.0", "SONAR reading 0 is negative"),
        ("ROBOTLASER1 0 -1.5708 3.1416 0.01 50 0.01 0 3 1 2 3 0 1 2 0.1 1 2 0.1 0 0 0 0 0 5.0 h 5.0", "do not fit"),
        ("ROBOTLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 1 2 0.1 1 2 0.1 0 0 0 0 5.0 h 5.0", "needs 27"),
        ("RAWLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 5.0 h", "x.log:2: RAWLASER1 with 3 beams and 0 rem"),
        ("PARAM robot_front_laser_max", "x.log:2: PARAM needs a name and a value"),
        ("FLASER 3 1.0 2.0 3.0 1e300 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0", "x.log:2: laser pose (1e+300, 0.0, 0.0): x"),
        ("FLASER 3 1.0 2.0 3.0 0.5 0.0 1e308 0.5 0.0 0.0 10.0 host 10.0", "a heading of 1e+308 rad is no angle"),
        ("FLASER 3 1.0 2.0 3.0 0.5 0.0 0.0 0.5 0.0 0.0 nan host 10.0", "x.log:2: FLASER timestamp nan is not finite"),
        ("SONAR 0.26 1 1.0 1e300 0 0 3.0 host 3.0", "x.log:2: SONAR offset of sensor 0 (1e+300, 0.0, 0.0): x and y"),
        ("ROBOTLASER1 0 nan 3.1416 1.5708 50 0.01 0 3 1 2 3 0 1 2 0.1 1 2 0.1 0 0 0 0 0 5.0 h 5.0", "is no angle"),
        ("ROBOTLASER1 0 1e300 3.1416 1.5708 50 0.01 0 3 1 2 3 0 1 2 0.1 1 2 0.1 0 0 0 0 0 5.0 h 5.0", "is no angle"),
    ],
)
def test_malformed_lines_name_file_and_line(tmp_path: Path, line: str, message: str) -> None:
    path = write(tmp_path, "# a comment", line)
    with pytest.raises(LogError, match=None) as info:
        list(read_carmen(path))
    assert message in str(info.value)
    assert isinstance(info.value, ValueError)


def test_metres_logged_as_millimetres_are_refused(tmp_path: Path) -> None:
    ranges = " ".join(["1.5"] * 12)
    path = write(tmp_path, f"FLASER 12 {ranges} 0 0 0 0 0 0 1 host 1")
    with pytest.raises(LogError, match="x.log:1: median range 0.0015 m is implausibly short"):
        list(read_carmen(path, CarmenOptions(unit="mm")))


def test_millimetres_read_as_metres_are_refused_when_the_maximum_range_is_in_millimetres_too(tmp_path: Path) -> None:
    """A ROS bag's range_max in millimetres let every reading through: the scans were mapped kilometres wide and the
    run failed at the grid, on its size."""
    ranges = " ".join(["2500"] * 12)
    path = write(tmp_path, f"FLASER 12 {ranges} 0 0 0 0 0 0 1 host 1")
    with pytest.raises(LogError, match="x.log:1: median range 2500 m is implausibly long: .* smaller unit"):
        list(read_carmen(path, CarmenOptions(max_range=30000.0)))


def test_a_beam_spacing_no_laser_has_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, "PARAM laser_front_laser_resolution 1e-300 h 0", FLASER)
    with pytest.raises(
        LogError, match=r"x.log:2: FLASER with 3 beams: beams 1.74533e-302 rad apart are closer than any"
    ):
        list(read_carmen(path))


def test_beam_spacing_and_field_of_view_params_that_disagree_are_refused(tmp_path: Path) -> None:
    """Three beams 1 deg apart span 2 deg, not the 180 deg laser_front_laser_fov says (the resolution won,
    silently: a 361-beam scan over 180 deg was drawn over 360 deg); one step apart is a layout's rounding."""
    fov = "PARAM laser_front_laser_fov 180 h 0"
    path = write(tmp_path, "PARAM laser_front_laser_resolution 1.0 h 0", fov, FLASER)
    with pytest.raises(LogError, match=r"x.log:3: FLASER with 3 beams: PARAM laser_front_laser_resolution 1 deg"):
        list(read_carmen(path))
    path = write(tmp_path, "PARAM laser_front_laser_resolution 1.0 h 0", "PARAM laser_front_laser_fov 3 h 0", FLASER)
    assert np.degrees(np.ptp(next(iter(read_carmen(path))).scan.angles)) == pytest.approx(2.0)


def test_a_laser_offset_that_puts_the_robot_beyond_any_map_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, "PARAM robot_frontlaser_offset 1e300 h 0", FLASER)
    with pytest.raises(LogError, match=r"x.log:2: robot pose \(robot_frontlaser_offset behind\) \(-1e\+300"):
        list(read_carmen(path))


def test_bad_param_is_refused(tmp_path: Path) -> None:
    path = write(tmp_path, "PARAM robot_front_laser_max far", FLASER)
    with pytest.raises(LogError, match="x.log:2: PARAM robot_front_laser_max 'far' is not a positive number"):
        list(read_carmen(path))


def test_open_log_picks_the_reader(tmp_path: Path) -> None:
    assert len(list(open_log(INTEL))) == 30
    assert len(list(open_log(DATA / "killian-excerpt.g2o"))) == 3
    with pytest.raises(LogError, match="no such log"):
        open_log(tmp_path / "missing.log")


def test_damaged_gzip_and_files_that_are_no_log_are_refused_naming_them(tmp_path: Path) -> None:
    data = INTEL.read_bytes()
    (tmp_path / "cut.log.gz").write_bytes(data[: len(data) // 2])
    damaged = bytearray(data)
    damaged[len(data) // 3] ^= 0xFF
    (tmp_path / "damaged.log.gz").write_bytes(bytes(damaged))
    (tmp_path / "magic.log").write_bytes(b"\x1f\x8b")
    for name in ("cut.log.gz", "magic.log"):
        with pytest.raises(LogError, match=rf"{name}:\d+: gzip data damaged or cut short"):
            list(open_log(tmp_path / name))
    with pytest.raises(LogError, match=r"damaged.log.gz:\d+: "):  # the inflated garbage's line, or the gzip error
        list(open_log(tmp_path / "damaged.log.gz"))
    os.mkfifo(tmp_path / "pipe.log")  # a FIFO is refused at once, not read until a writer comes
    with pytest.raises(LogError, match="pipe.log: not a regular file"):
        list(open_log(tmp_path / "pipe.log"))
    (tmp_path / "dir.g2o").mkdir()
    with pytest.raises(LogError, match="dir.g2o: not a regular file"):
        list(open_log(tmp_path / "dir.g2o"))


def raw_version(path: Path, tmp_path: Path) -> Path:
    """The log with each FLASER line recorded as the CARMEN logger records a scan: the robot's odometry pose
    (ODOM), then the scan without a pose (RAWLASER1), the layout the FLASER line's reading gives."""
    records = iter(read_carmen(path))
    lines = []
    with gzip.open(path, "rt") as f:
        for line in f:
            words = line.split()
            if words and words[0] == "FLASER":
                r = next(records)
                n, a = len(r.scan), r.scan.angles.tolist()
                robot, stamps = " ".join(map(repr, r.robot_pose.tolist())), " ".join(words[-3:])
                layout = f"0 {a[0]!r} {a[-1] - a[0]!r} {(a[-1] - a[0]) / (n - 1)!r} {r.scan.max_range!r} 0.01 0"
                lines += [
                    f"ODOM {robot} 0 0 0 {stamps}",
                    f"RAWLASER1 {layout} {n} {' '.join(words[2 : 2 + n])} 0 {stamps}",
                ]
            elif words and words[0] != "ODOM":
                lines.append(line.strip())
    return write(tmp_path, *lines, name="raw.log")


def test_rawlaser1_scans_are_placed_at_the_latest_odometry(tmp_path: Path) -> None:
    """The logger's RAWLASER1 and ODOM lines give the scans and poses the FLASER lines give (the laser 4 cm
    behind the robot, as robot_frontlaser_offset says)."""
    flaser, raw = list(read_carmen(FREIBURG)), list(read_carmen(raw_version(FREIBURG, tmp_path)))
    assert [r.index for r in raw] == [r.index for r in flaser] == list(range(20))
    for a, b in zip(flaser, raw, strict=True):
        np.testing.assert_allclose(b.scan.angles, a.scan.angles, atol=1e-12)
        np.testing.assert_array_equal(b.scan.ranges, a.scan.ranges)
        np.testing.assert_allclose(b.robot_pose, a.robot_pose, atol=1e-12)
        np.testing.assert_allclose(b.scan.pose, a.scan.pose, atol=1e-12)
        assert b.scan.stamp == a.scan.stamp and b.scan.max_range == a.scan.max_range


def test_rawlaser1_scans_are_placed_between_the_odometry_around_their_stamps(tmp_path: Path) -> None:
    raw = "RAWLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 {t} host {t}"
    odom = "ODOM {x} 0 {theta} 0 0 0 {t} host {t}"
    lines = [
        odom.format(x=1.0, theta=3.0, t=1.0),
        raw.format(t=1.25),  # the next ODOM line comes after it
        odom.format(x=3.0, theta=-3.0, t=2.0),  # turning the short way, through pi
        raw.format(t=2.5),  # no ODOM line after it for more than a second: at the latest
        raw.format(t=3.6),
        raw.format(t=3.7),  # the log ends: at the latest
    ]
    records = list(read_carmen(write(tmp_path, *lines)))
    turn = 2 * np.pi - 6.0
    np.testing.assert_allclose(
        [r.robot_pose for r in records], [[1.5, 0, 3.0 + turn / 4], [3.0, 0, -3.0], [3.0, 0, -3.0], [3.0, 0, -3.0]]
    )


def test_a_clock_stepping_back_in_a_raw_log_is_refused_naming_the_line(tmp_path: Path) -> None:
    """RAWLASER1 scans of a log whose clock stepped back 3 s were placed among the other period's odometry, up to
    5 m off, without a word."""
    raw = "RAWLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 {t} host {t}"
    odom = "ODOM {x} 0 0 0 0 0 {t} host {t}"
    lines = [odom.format(x=0.0, t=1.0), raw.format(t=1.5), odom.format(x=1.0, t=2.0), odom.format(x=2.0, t=-1.0)]
    with pytest.raises(LogError, match=r"x.log:4: ODOM stamp -1.000000 is 3.000000 s before an earlier line's"):
        list(read_carmen(write(tmp_path, *lines)))


def test_rawlaser1_is_read_only_where_the_log_has_no_other_scans(tmp_path: Path) -> None:
    raw = "RAWLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 5.0 host 5.0"
    robot = "ROBOTLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 1 2 0.1 1 2 0.1 0 0 0 0 0 5.0 host 5.0"
    odom = "ODOM 1 2 0.1 0 0 0 4.0 host 4.0"
    (record,) = read_carmen(write(tmp_path, odom, raw, robot))  # the logger writes each scan both ways
    assert record.scan.pose.tolist() == [1.0, 2.0, 0.1]
    early = raw.replace("5.0 host 5.0", "3.0 host 3.0")
    records = list(read_carmen(write(tmp_path, early, odom, raw, raw)))  # the first, stamped before odometry: skipped
    assert [r.index for r in records] == [0, 1] and records[0].robot_pose.tolist() == [1.0, 2.0, 0.1]
    assert [r.skipped for r in records] == [1, 1]
    with pytest.raises(LogError, match="x.log: none of the 2 RAWLASER1 scans could be placed: the log has no ODOM"):
        list(read_carmen(write(tmp_path, raw, raw)))


def test_a_raw_log_maps_as_its_flaser_version(tmp_path: Path) -> None:
    flaser, raw = (run_log(log, load_config()) for log in (FREIBURG, raw_version(FREIBURG, tmp_path)))
    np.testing.assert_array_equal(raw.map.segments.p, flaser.map.segments.p)
    lines = [sorted((u, v) for u, v, _ in run.map.graph.edges()) for run in (raw, flaser)]
    assert lines[0] == lines[1] and raw.log.scans == 20
