"""One output staging for evmap run and compare: refusals before the work, --force only on evmap's, no clobbering."""

from __future__ import annotations

import errno
import json
import os
import stat
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from evmap.maps.app import staging as staging_module
from evmap.maps.app.cli import main
from evmap.maps.app.output_layout import MARKER, RUN_LAYOUT, OutputError
from evmap.maps.app.staging import claim_output

SMALL = str(Path(__file__).parent / "scenarios" / "pipeline_small.yaml")


def write_run(out: Path, force: bool = False, files: tuple[str, ...] = ("report.json", "segments.json", "map.json")):
    with claim_output(out, force=force, layout=RUN_LAYOUT) as stage:
        for name in files:
            (stage.path / name).write_text("{}")


def test_a_run_is_marked_with_what_evmap_wrote_and_ordinary_modes(tmp_path):
    out = tmp_path / "out"
    write_run(out)
    assert sorted(p.name for p in out.iterdir()) == sorted([MARKER, "map.json", "report.json", "segments.json"])
    assert json.loads((out / MARKER).read_text())["files"] == ["map.json", "report.json", "segments.json"]
    umask = os.umask(0o022)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o777 & ~umask  # not mkdtemp's 0700
    assert all(stat.S_IMODE(p.stat().st_mode) == 0o666 & ~umask for p in out.iterdir())
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no lock or staging left


def test_force_replaces_what_evmap_wrote(tmp_path):
    out = tmp_path / "out"
    write_run(out, files=("report.json", "segments.json", "map.json", "old.png"))
    write_run(out, force=True)
    assert not (out / "old.png").exists() and (out / "report.json").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_force_replaces_an_unmarked_directory_of_exactly_the_contract_artefacts(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for name in ("report.json", "segments.json", "map.json", "fig2_sonar_scan_rcds.png"):
        (out / name).write_text("old")
    write_run(out, force=True)
    assert (out / "report.json").read_text() == "{}" and not (out / "fig2_sonar_scan_rcds.png").exists()


def test_force_refuses_a_directory_evmap_did_not_make_naming_what_is_in_the_way(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "thesis.tex").write_text("mine")
    with pytest.raises(OutputError, match="thesis.tex"):
        write_run(out, force=True)
    write_run(tmp_path / "mine")
    (tmp_path / "mine" / "notes.txt").write_text("mine")  # a marked directory that now holds a stranger
    with pytest.raises(OutputError, match="notes.txt"):
        write_run(tmp_path / "mine", force=True)
    assert (out / "thesis.tex").read_text() == "mine" and (tmp_path / "mine" / "notes.txt").read_text() == "mine"


def test_a_marker_listing_a_file_that_is_no_artefact_does_not_make_it_evmaps(tmp_path):
    out = tmp_path / "out"
    write_run(out)
    (out / "mine.txt").write_text("mine")
    marker = json.loads((out / MARKER).read_text())
    (out / MARKER).write_text(json.dumps({**marker, "files": [*marker["files"], "mine.txt"]}))
    with pytest.raises(OutputError, match="mine.txt"):
        write_run(out, force=True)
    assert (out / "mine.txt").read_text() == "mine"


def test_a_file_put_into_out_during_the_run_is_not_deleted(tmp_path):
    out = tmp_path / "out"
    write_run(out)
    with pytest.raises(OutputError, match="late.txt"), claim_output(out, force=True, layout=RUN_LAYOUT) as stage:
        (stage.path / "report.json").write_text("new")
        (out / "late.txt").write_text("appeared during the run")
    assert (out / "late.txt").read_text() == "appeared during the run" and (out / "report.json").read_text() == "{}"
    fresh = tmp_path / "fresh"
    with pytest.raises(OutputError, match="not empty"), claim_output(fresh, force=False, layout=RUN_LAYOUT) as stage:
        (stage.path / "report.json").write_text("new")
        fresh.mkdir()
        (fresh / "late.txt").write_text("x")
    assert [p.name for p in fresh.iterdir()] == ["late.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fresh", "out"]


def test_a_second_run_into_the_same_out_is_refused_while_the_first_holds_it(tmp_path):
    out = tmp_path / "out"
    with claim_output(out, force=False, layout=RUN_LAYOUT) as stage:
        with pytest.raises(OutputError, match=f"process {os.getpid()}"):
            write_run(out)
        (stage.path / "report.json").write_text("first")
    assert (out / "report.json").read_text() == "first"


def test_two_concurrent_runs_exactly_one_succeeds(tmp_path):
    out = tmp_path / "out"
    results: list[str] = []
    tried = threading.Event()

    def run(tag: str) -> None:
        try:
            with claim_output(out, force=True, layout=RUN_LAYOUT) as stage:
                tried.wait(timeout=10)  # hold the claim until the other run has tried
                (stage.path / "report.json").write_text(tag)
            results.append(tag)
        except OutputError:
            results.append("refused")
            tried.set()

    threads = [threading.Thread(target=run, args=(t,)) for t in ("a", "b")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(results) in (["a", "refused"], ["b", "refused"])
    assert (out / "report.json").read_text() in ("a", "b")


def test_two_concurrent_evmap_processes_exactly_one_succeeds(tmp_path):
    out = tmp_path / "out"
    script = Path(sys.executable).parent / "evmap"
    procs = [
        subprocess.Popen([script, "run", SMALL, "--out", str(out)], stderr=subprocess.PIPE, text=True) for _ in range(2)
    ]
    codes = sorted(p.wait(timeout=120) for p in procs)
    errors = [p.stderr.read() for p in procs]
    assert codes == [0, 2], errors
    assert any(e.startswith("evmap: error: --out") for e in errors)
    assert (out / "report.json").exists() and [p.name for p in tmp_path.iterdir()] == ["out"]


def test_leftovers_of_a_killed_run_are_cleaned_by_the_next(tmp_path):
    out = tmp_path / "out"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True, check=True
    )
    pid = int(dead.stdout)
    (tmp_path / f".out.evmap-stage-{pid}-abc").mkdir()
    (tmp_path / f".out.evmap-stage-{pid}-abc" / "report.json").write_text("half")
    (tmp_path / ".out.evmap-lock").write_text(f"{pid}\n")
    write_run(out)
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_run_killed_between_the_renames_of_force_leaves_the_old_out_to_the_next(tmp_path):
    """Killed after moving the old --out aside and before moving its own in: the next run puts the old one
    back (it was evmap's and nothing replaced it), then refuses it without --force and replaces it with."""
    out = tmp_path / "out"
    write_run(out, files=("report.json", "segments.json", "map.json", "old.png"))
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True, check=True
    )
    out.rename(tmp_path / f".out.evmap-old-{int(dead.stdout)}")
    with pytest.raises(OutputError, match="not empty"):
        write_run(out)
    assert (out / "old.png").exists() and [p.name for p in tmp_path.iterdir()] == ["out"]
    write_run(out, force=True)
    assert not (out / "old.png").exists() and [p.name for p in tmp_path.iterdir()] == ["out"]


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: (d / "out").write_text("a file"), "not a directory"),
        (lambda d: (d / "parent").write_text("a file"), "in the way"),
        (lambda d: ((d / "target").mkdir(), (d / "out").symlink_to(d / "target")), "symbolic link"),
    ],
)
def test_output_problems_are_one_line_and_exit_2_before_the_work(capsys, tmp_path, monkeypatch, make, message):
    make(tmp_path)
    out = tmp_path / ("parent/out" if message == "in the way" else "out")
    monkeypatch.setattr("evmap.maps.app.run.run_scenario", lambda *a: pytest.fail("the work started"))
    code = main(["run", SMALL, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("evmap: error: --out") and err.count("\n") == 1, err
    if message == "symbolic link":
        assert (tmp_path / "out").is_symlink()  # the link is not replaced by a directory


def test_compare_refuses_a_symbolic_link_out_before_computing_any_world(capsys, tmp_path, monkeypatch):
    """The campaign's `compare --force --out SYMLINK`: a traceback after computing every world."""
    (tmp_path / "target").mkdir()
    (tmp_path / "out").symlink_to(tmp_path / "target")
    monkeypatch.setattr("evmap.maps.app.compare.iter_results", lambda *a, **k: pytest.fail("the work started"))
    argv = ["compare", "--worlds", "1", "--rules", "dempster", "--quiet", "--scheduler", "synchronous"]
    assert main([*argv, "--out", str(tmp_path / "out"), "--force"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"evmap: error: --out {tmp_path / 'out'}: is a symbolic link") and err.count("\n") == 1
    assert (tmp_path / "out").is_symlink() and list((tmp_path / "target").iterdir()) == []


def test_out_dot_and_read_only_and_full_disk_are_refused_before_the_work(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr("evmap.maps.app.run.run_scenario", lambda *a: pytest.fail("the work started"))
    monkeypatch.chdir(tmp_path)
    assert main(["run", SMALL, "--out", "."]) == 2
    assert "current directory" in capsys.readouterr().err
    assert main(["run", SMALL, "--out", ".", "--force"]) == 2  # the campaign's traceback, and a '..old.*' left
    assert (
        capsys.readouterr().err
        == "evmap: error: --out .: name a new directory, not the current directory or one above it\n"
    )
    assert list(tmp_path.iterdir()) == []

    real = os.statvfs

    class Full:
        def __init__(self, flag: int, blocks: int) -> None:
            self.stat = real(tmp_path)
            self.f_flag, self.f_bavail, self.f_frsize = flag, blocks, 4096

    monkeypatch.setattr(staging_module.os, "statvfs", lambda p: Full(os.ST_RDONLY, 10**6))
    assert main(["run", SMALL, "--out", str(tmp_path / "out")]) == 2
    assert "not writable" in capsys.readouterr().err
    monkeypatch.setattr(staging_module.os, "statvfs", lambda p: Full(0, 10))
    assert main(["run", SMALL, "--out", str(tmp_path / "out")]) == 2
    assert "MiB free" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("where", ["evmap.maps.app.artefacts.write_figures", "evmap.maps.BeliefMap.save"])
def test_a_disk_that_fills_up_during_the_run_is_one_line_naming_out_and_leaves_nothing(
    capsys, tmp_path, monkeypatch, where
):
    """The space check before the work passed, then the file system filled up while the artefacts were written
    (matplotlib's own error names no file): exit 2, one line naming --out, no --out and no staging left."""

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(where, full)
    out = tmp_path / "out"
    assert main(["run", SMALL, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == f"evmap: error: --out {out}: writing the artefacts failed: No space left on device", err
    assert "Traceback" not in "\n".join(err) and list(tmp_path.iterdir()) == []
