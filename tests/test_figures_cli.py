"""`evmap run --figures png|svg|pdf|none` (and `--no-figures`, the same as `none`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from evmap.maps.app.cli import main
from evmap.maps.app.figures import FIGURE_FILES

SMALL = str(Path(__file__).parent / "scenarios" / "pipeline_small.yaml")
ARTEFACTS = {"report.json", "segments.json", "map.json", ".evmap-out"}  # the marker: evmap wrote the directory


@pytest.mark.parametrize(
    ("option", "suffix"), [((), ".png"), (("--figures", "svg"), ".svg"), (("--figures", "pdf"), ".pdf")]
)
def test_run_writes_the_figures_in_the_chosen_format(capsys, tmp_path: Path, option, suffix: str) -> None:
    out = tmp_path / "out"
    assert main(["run", SMALL, "--out", str(out), *option]) == 0, capsys.readouterr().err
    figures = {p.name for p in out.iterdir()} - ARTEFACTS
    assert figures and all(name.endswith(suffix) for name in figures)
    assert {name.replace(".png", suffix) for name in FIGURE_FILES} <= figures


@pytest.mark.parametrize("option", [("--figures", "none"), ("--no-figures",)])
def test_run_without_figures(capsys, tmp_path: Path, option) -> None:
    out = tmp_path / "out"
    assert main(["run", SMALL, "--out", str(out), *option]) == 0, capsys.readouterr().err
    assert {p.name for p in out.iterdir()} == ARTEFACTS


def test_an_unknown_format_is_a_usage_error_that_leaves_nothing(capsys, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert main(["run", SMALL, "--out", str(out), "--figures", "jpg"]) == 2
    assert "invalid choice: 'jpg'" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
