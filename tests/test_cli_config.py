"""`evmap config check` and `evmap config explain`, through main() and the installed script."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from evmap import configs
from evmap.maps.app.cli import main

HERE = Path(__file__).parent / "configs"
PAPER = str(configs.path("paper.yaml"))
EXAMPLE = str(configs.path("examples/infrared.yaml"))


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_check_prints_every_frame_source_table_and_parameter(capsys):
    code, out, err = run(capsys, "config", "check", PAPER)
    assert (code, err) == (0, "")
    assert out.startswith(f"{PAPER}: valid\nrule: dempster\n")
    assert "frame existence (the map's frame): real, noise\n  alias unknown = real|noise" in out
    # Table 1 as understood, focal sets in frame order
    assert "relation = outside        real 0.8, noise 0.1, real|noise 0.1" in out
    assert "relation = partly_inside  real 0.1, noise 0.1, real|noise 0.8" in out
    assert "relation = inside         real 0.1, noise 0.8, real|noise 0.1" in out
    # the LSL ramp at its break points and midpoint
    assert "(x, m) = (0, 0), (0.4, 0.6), constant beyond the ends" in out
    assert "length = 0.2  real 0.3, real|noise 0.7" in out
    assert "length = 0.4  real 0.6, real|noise 0.4" in out
    assert "sonar_match = unobserved  real|noise 1" in out
    assert "noise_elimination: sonar_open_space, lsl_length" in out
    assert "  rcd: range_tolerance=0.02 min_width_deg=8.0" in out
    assert "  rcd_figure: range_tolerance=0.01 min_width_deg=10.0" in out
    assert "  merge: distance=0.05 angle_deg=10.0" in out
    assert "  sensors.sonar: beam_width_deg=25.0" in out
    assert "  noise: threshold=0.5 inside_fraction=0.99 outside_fraction=0.01" in out


def test_check_without_a_file_checks_the_packaged_paper_config(capsys):
    assert run(capsys, "config", "check")[:2] == run(capsys, "config", "check", PAPER)[:2]


def test_check_the_example_sensor(capsys):
    code, out, _ = run(capsys, "config", "check", EXAMPLE)
    assert code == 0
    assert "ir_return = beyond     noise 0.7, real|noise 0.3" in out
    assert "noise_elimination: sonar_open_space, lsl_length, infrared" in out


def test_a_negative_value_in_exponent_form_is_a_value_not_an_option(capsys):
    for value in ("-1e3", "-2.5E-1"):
        code, out, err = run(capsys, "config", "explain", PAPER, "--source", "lsl_length", "--value", value)
        assert (code, err) == (0, "") and out.startswith(f"lsl_length (ramp on 'length'), length = {value}:")
    code, _, err = run(capsys, "config", "explain", PAPER, "--source", "lsl_length", "--value", "-inf")
    assert code == 2 and "expected finite numbers, got -inf" in err  # a value, refused as a value


def test_explain_a_ramp_value_against_every_row_of_table_1(capsys):
    code, out, err = run(capsys, "config", "explain", PAPER, "--source", "lsl_length", "--value", "0.2")
    assert (code, err) == (0, "")
    lines = out.splitlines()
    assert lines[:2] == ["lsl_length (ramp on 'length'), length = 0.2:", "  real 0.3, real|noise 0.7"]
    # outside: m(noise) = .1 * .7 / (1 - K), K = .1 * .3 = .03
    assert "with sonar_open_space (relation = outside): real 0.8, noise 0.1, real|noise 0.1" in out
    assert "-> real 0.85567, noise 0.0721649, real|noise 0.0721649; K = 0.03; m(noise) = 0.0721649 <= 0.5: kept" in out
    # inside: K = .8 * .3 = .24, m(noise) = .8 * .7 / .76
    assert "K = 0.24; m(noise) = 0.736842 > 0.5: removed" in out
    assert len([line for line in lines if line.startswith("    -> ")]) == 3


def test_explain_a_category_against_the_ramp_rows(capsys):
    code, out, _ = run(capsys, "config", "explain", PAPER, "--source", "sonar_open_space", "--value", "inside")
    assert code == 0
    assert "  real 0.1, noise 0.8, real|noise 0.1" in out
    # a 0.4 m line inside the open space: K = .8 * .6 = .48, m(noise) = .8 * .4 / .52
    assert "with lsl_length (length = 0.4): real 0.6, real|noise 0.4" in out
    assert "K = 0.48; m(noise) = 0.615385 > 0.5: removed" in out


def test_explain_under_another_rule(capsys, tmp_path):
    config = tmp_path / "yager.yaml"
    config.write_text(Path(PAPER).read_text().replace("rule: dempster", "rule: yager"))
    code, out, _ = run(capsys, "config", "explain", str(config), "--source", "lsl_length", "--value", "0.4")
    assert code == 0
    # Yager, inside (.1, .8, .1) with (.6, 0, .4): real .1 * .6 + .1 * .4 + .1 * .6 = .16,
    # noise .8 * .4 = .32, Θ .1 * .4 plus the conflict K = .8 * .6 = .48
    assert "combined by yager" in out
    assert "-> real 0.16, noise 0.32, real|noise 0.52; K = 0.48; m(noise) = 0.32 <= 0.5: kept" in out


def test_explain_a_source_of_a_stage_with_one_source(capsys):
    code, out, _ = run(capsys, "config", "explain", "--source", "sonar_match", "--value", "missed")
    assert code == 0
    assert "  noise 0.2, real|noise 0.8" in out
    assert "sonar_match is its only source" in out


def test_explain_the_example_sensor_with_two_other_sources(capsys):
    code, out, _ = run(capsys, "config", "explain", EXAMPLE, "--source", "infrared", "--value", "beyond")
    assert code == 0
    assert out.count("    -> ") == 3 * 3  # 3 relations times 3 lengths (0, 0.2, 0.4)
    # partly inside, 0.2 m, IR beyond: m(noise) = .462 / .732 (see test_evidence_sources)
    assert "m(noise) = 0.631148 > 0.5: removed" in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["config", "check", str(HERE / "bad_sum.yaml")],
            f"evmap: error: {HERE / 'bad_sum.yaml'}: sources.sonar_open_space.table.inside: masses sum to 0.9",
        ),
        (["config", "check", str(HERE / "syntax_error.yaml")], "syntax_error.yaml: line 18, column 13:"),
        (["config", "check", "/nonexistent/c.yaml"], "evmap: error: /nonexistent/c.yaml: cannot read file"),
        (["config", "explain", "--source", "lidar", "--value", "1"], "evmap: error: unknown source 'lidar' in config "),
        (["config", "explain", "default", "--source", "lidar", "--value", "1"], "default.yaml; its sources are: "),
        (
            ["config", "explain", "--source", "lsl_length", "--value", "long"],
            "evmap: error: source 'lsl_length', feature 'length': expected numbers",
        ),
        (["config", "explain", "--source", "lsl_length", "--value", "nan"], "expected finite numbers"),
        (
            ["config", "explain", "--source", "sonar_open_space", "--value", "near"],
            "unknown category 'near'; the table has 'inside', 'outside', 'partly_inside'",
        ),
    ],
)
def test_bad_input_exits_2_with_a_message_and_no_traceback(capsys, argv, message):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert out == ""
    assert message in err
    assert err.startswith("evmap: error: ")
    assert "Traceback" not in err


@pytest.mark.parametrize("argv", [[], ["config"], ["config", "explain", "--source", "lsl_length"], ["config", "lint"]])
def test_usage_errors_exit_2(capsys, argv):
    code, _, err = run(capsys, *argv)
    assert code == 2
    assert "usage: evmap" in err


def test_help_exits_0(capsys):
    code, out, _ = run(capsys, "config", "explain", "--help")
    assert code == 0
    assert "--source" in out and "--value" in out


def test_installed_console_script():
    evmap = Path(sys.executable).parent / "evmap"
    ok = subprocess.run([evmap, "config", "check", EXAMPLE], capture_output=True, text=True, timeout=60, check=False)
    assert ok.returncode == 0, ok.stderr
    assert "source infrared (frame existence)" in ok.stdout
    bad = subprocess.run(
        [evmap, "config", "check", str(HERE / "python_tag.yaml")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert bad.returncode == 2
    assert bad.stdout == ""
    assert "could not determine a constructor for the tag" in bad.stderr
    assert "Traceback" not in bad.stderr


def test_explain_shows_a_row_in_total_conflict(capsys, tmp_path):
    text = Path(PAPER).read_text()
    text = text.replace("inside:        {real: 0.1, noise: 0.8, unknown: 0.1}", "inside: {noise: 1.0}")
    text = text.replace("points: [[0.0, 0.0], [0.40, 0.6]]", "points: [[0.0, 1.0]]")
    config = tmp_path / "dogmatic.yaml"
    config.write_text(text)
    code, out, _ = run(capsys, "config", "explain", str(config), "--source", "lsl_length", "--value", "0.3")
    assert code == 0
    assert (
        "with sonar_open_space (relation = inside): noise 1\n    -> total conflict (K = 1): dempster is undefined"
        in out
    )
    assert (
        "with sonar_open_space (relation = outside): real 0.8, noise 0.1, real|noise 0.1\n    -> real 1; K = 0.1" in out
    )


def test_check_refuses_what_run_would_refuse_naming_the_key_and_line(capsys, tmp_path):
    text = Path(PAPER).read_text()
    assert "  inside_fraction: 0.99\n" in text
    path = tmp_path / "crossed.yaml"
    path.write_text(text.replace("  inside_fraction: 0.99\n", "  inside_fraction: 0.001\n"))
    code, out, err = run(capsys, "config", "check", str(path))
    assert code == 2 and out == ""
    assert f"{path}: noise: outside_fraction (0.01) must be below inside_fraction (0.001)" in err
    assert "(line " in err and "Traceback" not in err
