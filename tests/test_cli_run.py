"""`evmap run`, through main() and the installed script: artefacts, --json, and refusals that leave no trace."""

from __future__ import annotations

import gc
import json
import subprocess
import sys
from pathlib import Path

import pytest

from evidential import RULES
from evmap import configs
from evmap.maps.app.cli import main
from evmap.maps.app.figures import FIGURE_FILES
from evmap.maps.app.output_layout import MARKER

SCENARIOS = Path(__file__).parent / "scenarios"
SMALL = str(SCENARIOS / "pipeline_small.yaml")
BAD_CONFIG = str(Path(__file__).parent / "configs" / "bad_sum.yaml")

ARTEFACTS = {"report.json", "segments.json", "map.json", MARKER}  # evmap marks the directories it writes
FIGURES = set(FIGURE_FILES)  # their names are pinned by tests/test_figures.py


def evmap(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_run_writes_the_artefacts_and_logs_on_stderr_only(capsys, tmp_path):
    out = tmp_path / "out"
    code, stdout, stderr = evmap(capsys, "run", "--out", str(out))
    assert code == 0, stderr
    assert stdout == ""  # without --json nothing goes to standard output
    assert "corridor" in stderr and str(out) in stderr
    assert {p.name for p in out.iterdir()} == ARTEFACTS | FIGURES
    assert all((out / name).read_bytes().startswith(b"\x89PNG") for name in FIGURES)
    summary = json.loads((out / "report.json").read_text())
    assert summary["scenario"] == "corridor" and summary["rule"] == "dempster" and summary["poses"] == 1
    assert len(json.loads((out / "segments.json").read_text())) == summary["lsl_segments"]
    assert len(json.loads((out / "map.json").read_text())["edges"]) == summary["lines_after_merge"]


def test_installed_script_prints_exactly_report_json_on_stdout(tmp_path):
    out = tmp_path / "out"
    script = Path(sys.executable).parent / "evmap"
    done = subprocess.run(
        [script, "run", "--out", str(out), "--json"], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stderr
    written = (out / "report.json").read_text()
    assert done.stdout == written
    assert json.loads(done.stdout) == json.loads(written)
    assert "evmap: running scenario 'corridor'" in done.stderr and "Traceback" not in done.stderr


def test_a_bad_scenario_exits_2_naming_file_and_key_and_leaves_no_directory(capsys, tmp_path):
    out = tmp_path / "out"
    bad = str(SCENARIOS / "pipeline_bad.yaml")
    code, stdout, stderr = evmap(capsys, "run", bad, "--out", str(out))
    assert code == 2 and stdout == ""
    assert f"{bad}: world.walls[1].material: unknown material" in stderr
    assert "Traceback" not in stderr
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # no staging directory left either


def test_a_non_empty_directory_is_refused_without_force_and_left_untouched(capsys, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    code, stdout, stderr = evmap(capsys, "run", SMALL, "--out", str(out))
    assert code == 2 and stdout == ""
    assert "not empty" in stderr and "--force" in stderr and "Traceback" not in stderr
    assert [p.name for p in out.iterdir()] == ["notes.txt"] and (out / "notes.txt").read_text() == "mine"
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_force_replaces_a_directory_evmap_wrote_and_nothing_else(capsys, tmp_path):
    out = tmp_path / "out"
    assert evmap(capsys, "run", SMALL, "--out", str(out))[0] == 0
    code, _, stderr = evmap(capsys, "run", SMALL, "--rule", "yager", "--out", str(out), "--force")
    assert code == 0, stderr
    assert {p.name for p in out.iterdir()} == ARTEFACTS | FIGURES
    assert json.loads((out / "report.json").read_text())["rule"] == "yager"
    assert [p.name for p in tmp_path.iterdir()] == ["out"]
    (out / "notes.txt").write_text("mine")
    code, _, stderr = evmap(capsys, "run", SMALL, "--out", str(out), "--force")
    assert code == 2 and "notes.txt" in stderr and "Traceback" not in stderr
    assert (out / "notes.txt").read_text() == "mine" and (out / "report.json").exists()


def test_an_unknown_rule_exits_2_naming_the_known_rules(capsys, tmp_path):
    out = tmp_path / "out"
    code, stdout, stderr = evmap(capsys, "run", "--rule", "unknown_rule", "--out", str(out))
    assert code == 2 and stdout == ""
    assert "unknown_rule" in stderr and all(rule in stderr for rule in RULES)
    assert "Traceback" not in stderr
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "named"),
    [(["run", ""], "scenario"), (["run", "--config", ""], "--config"), (["run", "--rule", ""], "--rule"),
     (["log", ""], "file"), (["compare", "--rules", ""], "--rules")],
)  # fmt: skip
def test_an_empty_argument_is_refused_naming_it_not_taken_for_the_default(capsys, tmp_path, args, named):
    """A script's unset ``$SCENARIO`` ran the embedded corridor and exited 0; ``--config ""`` was named ``.``."""
    out = tmp_path / "out"
    code, stdout, stderr = evmap(capsys, *args, "--out", str(out))
    assert code == 2 and stdout == "" and f"evmap: error: argument {named}: empty" in stderr
    assert not out.exists()


def test_a_bad_config_exits_2_naming_the_file(capsys, tmp_path):
    out = tmp_path / "out"
    code, stdout, stderr = evmap(capsys, "run", "--config", BAD_CONFIG, "--out", str(out))
    assert code == 2 and stdout == ""
    assert stderr.startswith("evmap: error: ") and BAD_CONFIG in stderr
    assert "Traceback" not in stderr
    assert not out.exists()


def test_a_config_no_sensor_can_feed_is_refused_before_the_run_naming_the_key(capsys, tmp_path):
    out = tmp_path / "out"
    text = configs.path("examples/infrared.yaml").read_text()  # without the sensor `ir` that gives ir_return
    infrared = str(tmp_path / "infrared.yaml")
    Path(infrared).write_text(text[: text.index("extra_sensors:")] + text[text.index("\nsources:") :])
    code, stdout, stderr = evmap(capsys, "run", "--config", infrared, "--out", str(out))
    assert code == 2 and stdout == "" and not out.exists()
    assert stderr.startswith(f"evmap: error: {infrared}: sources.infrared.feature: reads feature 'ir_return'")
    code, stdout, _ = evmap(capsys, "config", "check", infrared)
    assert code == 0 and "warning: " in stdout and "'ir_return'" in stdout


def test_the_rule_option_reaches_the_report_and_the_map(capsys, tmp_path):
    out = tmp_path / "out"
    code, stdout, stderr = evmap(capsys, "run", SMALL, "--rule", "yager", "--out", str(out), "--json")
    assert code == 0, stderr
    assert json.loads(stdout) == json.loads((out / "report.json").read_text())
    assert json.loads(stdout)["rule"] == "yager"
    assert json.loads((out / "map.json").read_text())["graph"]["rule"] == "yager"


def test_the_command_line_starts_without_the_heavy_libraries():
    code = (
        "import sys; from evmap.maps.app.cli import build_parser; build_parser();"
        "print(sorted(m for m in ('numpy', 'scipy', 'shapely', 'networkx', 'matplotlib', 'dask', 'pydantic')"
        " if m in sys.modules), 'importlib.metadata' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[] False"  # nor entry points: --version looks itself up when asked
    version = subprocess.run(
        [sys.executable, "-m", "evmap.maps.app.cli", "--version"], capture_output=True, text=True, check=False
    )
    assert version.returncode == 0 and version.stdout.startswith("evmap ")


def test_a_run_without_figures_imports_neither_networkx_nor_matplotlib(tmp_path):
    """networkx is a tenth of a second of a small run's half second (``benchmarks/bench_cli.py``)."""
    code = (
        "import sys; from evmap.maps.app.cli import main;"
        f"main(['run', '--out', {str(tmp_path / 'out')!r}, '--figures', 'none']);"
        "print(sorted(m for m in ('networkx', 'matplotlib', 'dask') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]" and (tmp_path / "out" / "map.json").exists()


def test_the_collector_gets_back_what_a_command_froze_unless_it_is_the_process(capsys, tmp_path):
    """As the process's command, the modules a run imported stay frozen out of the garbage collector's passes;
    called from Python, the collector has them back afterwards."""
    assert main(["run", "--out", str(tmp_path / "a"), "--figures", "none"]) == 0
    assert gc.get_freeze_count() == 0
    code = (
        "import gc, sys; from evmap.maps.app.cli import main; sys.argv[1:] = ['run', '--out', sys.argv[1],"
        " '--figures', 'none']; main(); print(gc.get_freeze_count() > 10_000, gc.isenabled())"
    )
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "b")], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "True"]


def test_a_run_s_files_are_not_each_forced_to_disk_the_staging_appears_whole(tmp_path, monkeypatch):
    """A run writes into a staging directory that is renamed into place whole: forcing each file to the disk
    (about 0.1 s on these machines, a fifth of a small run) would buy nothing; a map saved on its own is."""
    import os

    from evmap.maps import BeliefMap

    synced: list[int] = []
    monkeypatch.setattr(os, "fsync", synced.append)
    assert main(["run", "--figures", "none", "--out", str(tmp_path / "out")]) == 0
    assert synced == [] and (tmp_path / "out" / "map.json").is_file()
    BeliefMap.load(tmp_path / "out" / "map.json").save(tmp_path / "alone.json")
    assert len(synced) == 1
