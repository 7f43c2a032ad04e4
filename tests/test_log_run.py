"""Robot logs into belief maps: observations without sonar, ``evmap log``, consolidated lines."""

import json
from pathlib import Path

import numpy as np
import pytest
from test_logs_rosbag import ODOM, SCAN, odometry, scan, sonar, write_bag

from evmap import configs
from evmap.maps import new_map
from evmap.maps.app.cli import main
from evmap.maps.app.log_run import run_log
from evmap.maps.app.run import report, run_scenario, segment_records
from evmap.maps.belief_map import BeliefMap
from evmap.maps.log_observation import observation_from_log
from evmap.maps.merging import related_pairs
from evmap.maps.observation import Observation
from evmap.sources.config import load_config
from evmap.sources.logs import open_log
from evmap.sources.logs.scan import RangeReadings
from evmap.sources.sim.scenario import load_scenario

DATA = Path(__file__).parent / "data" / "logs"
INTEL = DATA / "intel-excerpt.log.gz"


@pytest.fixture(scope="module")
def config():
    return load_config()


@pytest.fixture(scope="module")
def intel(config):
    return run_log(INTEL, config)


def test_an_observation_without_sonar_skips_the_sonar_stages(config):
    record = next(iter(open_log(INTEL)))
    obs = observation_from_log(record, config, 0)
    assert obs.sonar is None and len(obs.lsl) > 0
    assert obs.rays.shape == (len(record.scan), 2)  # bearing and range of every beam, NaN where none returned
    np.testing.assert_array_equal(obs.pose, record.robot_pose)
    bm = new_map(config)
    outcome = bm.update(obs)
    assert outcome.predicted_scan is None and len(outcome.actual) == 0 and outcome.open_space.is_empty
    assert bm.open_space.is_empty and bm.graph.number_of_edges() > 0
    assert not bm.unidentified() and not any(d.get("reinforced") for _, _, d in bm.graph.edges())


def test_an_observation_needs_a_pose_and_a_sonar_pose_must_agree(config):
    record = next(iter(open_log(INTEL)))
    obs = observation_from_log(record, config, 0)
    with pytest.raises(ValueError, match="needs robot_pose"):
        Observation(0, None, obs.lsl)
    ring = RangeReadings(
        0.0, np.array([[0.1, 0.0, 0.0], [0.0, 0.1, np.pi / 2]]), np.array([1.0, 2.0]), 5.0, np.full(2, 0.4)
    )
    with_sonar = observation_from_log(record, config, 0, sonar=ring)
    assert with_sonar.sonar is not None and len(with_sonar.sonar) == 2
    with pytest.raises(ValueError, match="is not the sonar scan's pose"):
        Observation(0, with_sonar.sonar, obs.lsl, robot_pose=np.asarray(record.robot_pose) + 1.0)


def test_a_log_run_reports_its_scans_line_fit_and_no_sonar(intel):
    assert intel.log.scans == len(intel.observations) == len(list(open_log(INTEL)))
    assert intel.log.sonar == "none"
    assert 0.5 < intel.log.coverage_mean <= 1.0 and 0 < intel.log.rms_error_median < 0.05
    assert sorted(intel.map.poses) == list(range(intel.log.scans))


def test_lines_seen_from_many_poses_are_one_line_per_wall(intel, config):
    g = intel.map.graph
    fits = np.array([d["fit"] for _, _, d in g.edges()])
    a, _, _ = related_pairs(fits[:, 0], fits[:, 1], config.merge)
    assert len(a) == 0
    store = intel.map.segments
    support = np.flatnonzero(store.role == "support")
    assert len(support) > 0 and (store.seen[support] > 3).all()
    members = [m for _, _, d in g.edges() for m in d["members"]]
    assert not (store.role[members] == "absorbed").any()  # a line's members are its live rows


def test_patrol_lines_are_one_line_per_wall(config):
    run = run_scenario(load_scenario(configs.path("scenarios/patrol.yaml")), config)
    fits = np.array([d["fit"] for _, _, d in run.map.graph.edges()])
    a, _, _ = related_pairs(fits[:, 0], fits[:, 1], config.merge)
    assert len(a) == 0


def test_a_log_s_map_loads_as_it_was_saved(intel, tmp_path):
    """Rows absorbed into a line's support keep the name of that line after a later scan replaced it."""
    store = intel.map.segments
    absorbed = store.role == "absorbed"
    lines = {d["id"] for _, _, d in intel.map.graph.edges()}
    assert any(line not in lines for line in store.line[absorbed].tolist())  # what the file must allow
    intel.map.save(tmp_path / "map.json")
    assert BeliefMap.load(tmp_path / "map.json").to_data() == intel.map.to_data()


def test_evmap_log_writes_the_run_artefacts(tmp_path, capsys):
    out = tmp_path / "out"
    assert (
        main(["log", str(INTEL), "--out", str(out), "--every", "2", "--limit", "5", "--json", "--figures", "svg"]) == 0
    )
    printed = json.loads(capsys.readouterr().out)
    report = json.loads((out / "report.json").read_text())
    assert printed == report
    assert report["scans"] == 5 and report["sonar"] == "none"
    assert report["laser_noise"] == pytest.approx(0.0061, abs=0.0002)  # the log's centimetre steps: below the model's
    assert report["noise_recall"] is None and report["real_loss"] is None
    assert report["scenario"] is None and report["log"] == str(INTEL)  # the contract's keys, every one there
    assert set(report["seconds"]) == {"total", "per_scan_median"} and set(report["line_fit"]) == {
        "coverage_mean",
        "rms_error_median",
    }
    segments = json.loads((out / "segments.json").read_text())
    assert {s["pose"] for s in segments} == set(range(5)) and {s["truth"] for s in segments} == {"unknown"}
    assert len(segments) == report["lsl_segments"]
    names = {p.name for p in out.iterdir()}
    assert {"report.json", "segments.json", "map.json", "map.pgm", "map.yaml", "fig7_final_map.svg"} <= names
    assert "fig9_line_fit.svg" in names
    assert not any("pose" in n for n in names)


def test_the_line_fit_figure_shows_every_returned_ray_and_the_report_s_numbers(intel):
    from evmap.maps.app.figures import line_fit_figure, lsl_lines_figure

    fits = intel.log.fits
    assert len(fits) == intel.log.scans
    returned = sum(int((~np.isnan(obs.rays[:, 1])).sum()) for obs in intel.observations)
    explained = sum(int(f.hit.sum()) for f in fits)
    assert sum(len(f.points) for f in fits) == returned > explained > 0
    for obs, fit in zip(intel.observations, fits, strict=True):  # each ray's end where the laser measured it
        ranges = obs.rays[:, 1][~np.isnan(obs.rays[:, 1])]
        np.testing.assert_allclose(np.hypot(*(fit.points - obs.pose[:2]).T), ranges, atol=1e-9)
    ax = line_fit_figure(intel).axes[0]
    text = ax.get_title(loc="left").replace("\n", " ")
    assert f"{returned} returned rays, {explained} explained" in text
    assert f"coverage {report(intel)['line_fit']['coverage_mean']:.3f}" in text
    assert f"error {100 * report(intel)['line_fit']['rms_error_median']:.2f} cm" in text
    drawn = {c.get_gid(): len(c.get_offsets()) for c in ax.collections if c.get_gid() and "rays" in c.get_gid()}
    assert drawn == {"rays-explained": explained, "rays-missed": returned - explained}
    assert "laser segments" in lsl_lines_figure(intel).axes[0].get_title(loc="left")  # a log's contour: its laser


def test_only_a_log_has_a_line_fit_figure():
    from evmap.maps.app.figures import line_fit_figure

    with pytest.raises(ValueError, match="robot log"):
        line_fit_figure(run_scenario(load_scenario(configs.path("scenarios/lab.yaml")), load_config()))


def test_a_log_whose_scans_give_no_segment_still_makes_its_artefacts(tmp_path):
    # the g2o excerpt's scans have five beams 45 deg apart: no segment, no line, no open space
    out = tmp_path / "out"
    assert main(["log", str(DATA / "killian-excerpt.g2o"), "--out", str(out), "--figures", "none"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["scans"] == 3 and report["lsl_segments"] == 0 and report["lines_after_merge"] == 0
    assert (out / "map.pgm").stat().st_size > 0
    grid = BeliefMap.load(out / "map.json").occupancy_grid()
    assert grid.size > 0 and (grid == -1).all()  # every cell unknown, around the poses


def test_a_bad_log_is_an_error_naming_file_and_line_and_nothing_is_written(tmp_path, capsys):
    bad = tmp_path / "bad.log"
    bad.write_text("FLASER 3 1.0 2.0 x 0 0 0 0 0 0 0 0 host 0\n")
    out = tmp_path / "out"
    assert main(["log", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"evmap: error: {bad}:1: " in err
    assert not out.exists() and list(tmp_path.iterdir()) == [bad]


def test_a_yaml_sensor_reads_its_readings_from_a_log_s_directory(tmp_path, capsys):
    """configs/examples/radar.yaml on a log: DIR/scan-N.npz per scan used gives the radar's readings; its
    feature reaches the segments; a config with a declared sensor and no readings, a missing file or a wrong
    array is refused naming what and where, and nothing is written."""
    cfg = load_config(configs.path("examples/radar.yaml"))
    readings = tmp_path / "readings"
    readings.mkdir()
    detected = 0
    for k, record in zip(range(3), open_log(INTEL), strict=False):
        lsl = observation_from_log(record, cfg, k).lsl
        points = ((lsl.p + lsl.q) / 2)[::2]  # the radar reports every other segment's middle
        detected += int((np.hypot(*(points - record.robot_pose[:2]).T) <= 4.0).sum())  # within its max_range
        np.savez(readings / f"scan-{record.index}.npz", **{"radar/pose": record.robot_pose, "radar/points": points})
    run = run_log(INTEL, cfg, limit=3, readings=readings)
    feature = run.map.segments.features["radar_detection"]
    assert len(feature) == len(run.map.segments) and (feature == "detected").sum() >= detected > 0
    tally = report(run)["sensors"]["radar"]["features"]["radar_detection"]
    assert tally["segments"]["detected"] == (feature == "detected").sum() and "phantoms" not in tally  # no truth
    assert {r["features"]["radar_detection"] for r in segment_records(run)} >= {"detected"}

    config = str(configs.path("examples/radar.yaml"))
    out = tmp_path / "out"
    assert main(["log", str(INTEL), "--config", config, "--limit", "3", "--out", str(out)]) == 2
    assert "declares the sensors ['radar']; give their readings with --readings DIR" in capsys.readouterr().err
    (readings / "scan-2.npz").unlink()
    assert (
        main(["log", str(INTEL), "--config", config, "--limit", "3", "--readings", str(readings), "--out", str(out)])
        == 2
    )
    assert f"{readings / 'scan-2.npz'}: no readings for scan 2 of the log" in capsys.readouterr().err
    np.savez(readings / "scan-2.npz", **{"radar/pose": [0.0, 0.0]})
    assert (
        main(["log", str(INTEL), "--config", config, "--limit", "3", "--readings", str(readings), "--out", str(out)])
        == 2
    )
    assert f"{readings / 'scan-2.npz'}: sensor 'radar' (detector): readings need the arrays" in capsys.readouterr().err
    assert main(["log", str(INTEL), "--limit", "3", "--readings", str(readings), "--out", str(out)]) == 2
    assert "declares no sensor to read them" in capsys.readouterr().err
    assert not out.exists()


def test_damaged_or_wrong_readings_files_are_refused_naming_them(tmp_path, capsys):
    config = str(configs.path("examples/infrared.yaml"))
    readings = tmp_path / "readings"
    readings.mkdir()
    good = readings / "good.npz"
    np.savez(good, **{"ir/pose": np.zeros(3), "ir/angles": np.zeros(36), "ir/ranges": np.full(36, np.inf)})
    data = good.read_bytes()
    damaged = bytearray(data)
    damaged[len(data) // 2] ^= 0xFF
    cases = {
        "cut": lambda path: path.write_bytes(data[: len(data) // 2]),
        "damaged": lambda path: path.write_bytes(bytes(damaged)),
        "empty": lambda path: path.write_bytes(b""),
        "noise": lambda path: path.write_bytes(np.random.default_rng(0).bytes(500)),
        "npy": lambda path: path.write_bytes(open_npy_bytes()),
        "a directory": lambda path: path.mkdir(),
        "an infinite pose": lambda path: np.savez(
            path.with_suffix(""), **{"ir/pose": [np.inf, 0, 0], "ir/angles": np.zeros(36), "ir/ranges": np.ones(36)}
        ),
    }
    expected = {
        "cut": "not a readable .npz archive",
        "damaged": "not a readable .npz archive",
        "empty": "not a readable .npz archive",
        "noise": "not a readable .npz archive",
        "npy": "a single .npy array, not an .npz archive",
        "a directory": "not a regular file",
        "an infinite pose": "sensor 'ir': readings 'pose' must be finite, got an infinite value",
    }
    out = tmp_path / "out"
    for case, write in cases.items():
        scan = readings / "scan-0.npz"
        if scan.is_dir():
            scan.rmdir()
        else:
            scan.unlink(missing_ok=True)
        write(scan)
        argv = ["log", str(INTEL), "--config", config, "--limit", "1", "--readings", str(readings), "--out", str(out)]
        assert main(argv) == 2, case
        err = capsys.readouterr().err
        assert f"evmap: error: {scan}: {expected[case]}" in err and "Traceback" not in err, (case, err)
        assert not out.exists()


def open_npy_bytes() -> bytes:
    """A single array as ``np.save`` writes it (an .npy file)."""
    import io

    buffer = io.BytesIO()
    np.save(buffer, np.zeros(3))
    return buffer.getvalue()


def test_evmap_log_takes_no_figures_as_run_does(tmp_path):
    out = tmp_path / "out"
    assert main(["log", str(INTEL), "--out", str(out), "--limit", "3", "--no-figures"]) == 0
    assert not list(out.glob("fig*")) and (out / "map.pgm").exists()


def _box_ranges(x: float, angles: np.ndarray) -> np.ndarray:
    """Ranges from (x, 0), heading 0, to the walls of the box [-2, 6] x [-1, 3]."""
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (6 - x) / c, np.where(c < 0, (-2 - x) / c, np.inf))
        ty = np.where(s > 0, 3 / s, np.where(s < 0, -1 / s, np.inf))
    return np.minimum(tx, ty)


def test_sonar_readings_are_new_by_their_order_in_the_log_not_by_their_stamps(config, tmp_path):
    angles = np.radians(np.linspace(-90, 90, 181))
    lines = []
    for k, x in enumerate([0.0, 0.1, 0.2]):
        if k < 2:  # a SONAR line before the first two scans, stamped 0 as some loggers do
            lines.append("SONAR 0.4363 2 1.5 2.5 0.1 0 0 0 0.1 1.5708 0.0 host 0.0")
        ranges = " ".join(f"{r:.4f}" for r in _box_ranges(x, angles))
        lines.append(f"FLASER 181 {ranges} {x} 0 0 {x} 0 0 {1.0 + k} host {1.0 + k}")
    path = tmp_path / "stamps.log"
    path.write_text("\n".join(lines) + "\n")
    run = run_log(path, config)
    assert [obs.sonar is not None for obs in run.observations] == [True, True, False]
    assert run.log.sonar == "log"


def _bag(tmp_path: Path) -> Path:
    """A ROS bag of two laser topics, a Range topic, and a scan of /scan before the first pose."""
    messages = [(*SCAN, 0.5, scan(0.5, [1.0, 1.0, 1.0], frame="base_link"))]
    for k in range(3):
        t = 1.0 + k
        ranges = list(_box_ranges(0.1 * k, np.radians(np.linspace(-90, 90, 181))))
        messages += [
            (*ODOM, t, odometry(t, 0.1 * k, 0.0, 0.0)),
            ("/sonar", "sensor_msgs/msg/Range", t + 0.01, sonar(t + 0.01, 1.5, frame="base_link")),
            (*SCAN, t + 0.05, scan(t + 0.05, ranges, increment=np.pi / 180, frame="base_link")),
            ("/scan2", SCAN[1], t + 0.06, scan(t + 0.06, ranges, increment=np.pi / 180, frame="base_link")),
        ]
    return write_bag(tmp_path / "two.bag", 1, messages)


def test_evmap_log_reads_the_bag_s_topics_it_is_told_by_name_or_relative_name_and_reports_the_scans_skipped(
    tmp_path, capsys
):
    bag = _bag(tmp_path)
    out = tmp_path / "out"
    assert main(["log", str(bag), "--out", str(out), "--figures", "none"]) == 2
    assert "2 LaserScan topics (/scan, /scan2): name one with --scan-topic" in capsys.readouterr().err
    assert not out.exists()
    assert main(["log", str(bag), "--out", str(out), "--figures", "none", "--scan-topic", "/scan"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert (report["scans"], report["scans_skipped"], report["sonar"]) == (3, 1, "log")
    out2 = tmp_path / "out2"
    args = ["log", str(bag), "--out", str(out2), "--figures", "none", "--scan-topic", "scan2", "--range-topics", ""]
    assert main(args) == 0
    report = json.loads((out2 / "report.json").read_text())
    assert (report["scans"], report["scans_skipped"], report["sonar"]) == (3, 0, "none")


def test_ros_bag_flags_for_a_log_that_is_no_bag_are_refused(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["log", str(INTEL), "--out", str(out), "--odom-topic", ""]) == 2
    err = capsys.readouterr().err
    assert f"evmap: error: {INTEL}: ROS bag topics and frames (--scan-topic, --odom-topic" in err
    assert "given for a log that is no ROS bag" in err and not out.exists()


def test_the_rule_flag_says_which_rules_it_takes(capsys):
    assert main(["log", "--help"]) == 0
    help_text = " ".join(capsys.readouterr().out.split())
    assert "(a name in evidential.RULES that combines any mass functions)" in help_text


def test_carmen_raw_scans_before_the_first_odometry_are_counted(tmp_path):
    raw = "RAWLASER1 0 -1.5708 3.1416 1.5708 50 0.01 0 3 1 2 3 0 {t} host {t}"
    early, late = raw.format(t=3.0), raw.format(t=5.0)  # stamped before the odometry, after it
    path = tmp_path / "raw.log"
    path.write_text(f"{early}\n{early}\nODOM 1 2 0.1 0 0 0 4.0 host 4.0\n{late}\n{late}\n")
    assert [r.skipped for r in open_log(path)] == [2, 2]


def test_evmap_log_takes_the_unit_of_the_log_s_ranges(tmp_path, capsys):
    """A log in millimetres was refused ("a smaller unit than the declared 'm'?") with no way to declare it."""
    log = tmp_path / "mm.log"
    ranges = " ".join(["2000"] * 181)
    log.write_text(f"FLASER 181 {ranges} 0.5 0.0 0.0 0.5 0.0 0.0 10.0 host 10.0\n")
    assert main(["log", str(log), "--out", str(tmp_path / "m"), "--figures", "none"]) == 2
    assert "smaller unit than the declared 'm'" in capsys.readouterr().err
    out = tmp_path / "mm"
    assert main(["log", str(log), "--out", str(out), "--figures", "none", "--unit", "mm", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["scans"] == 1
