"""Ctrl-C and SIGTERM end a run cleanly: one line, status 130 / 143, no output directory, nothing left behind."""

import signal
import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    ("signum", "status", "line"), [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
def test_a_signal_during_a_run_ends_it_cleanly(tmp_path, signum, status, line):
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "evmap.maps.app.cli", "run", "--out", str(out)],
        stderr=subprocess.PIPE,
        text=True,
    )
    first = process.stderr.readline()  # printed once the command is under way, its handlers set
    assert first.startswith("evmap: running scenario")
    process.send_signal(signum)
    rest = process.stderr.read()
    process.wait(timeout=60)
    if process.returncode == 0:  # the run had already finished when the signal came: nothing to check
        pytest.skip("the run finished before the signal")
    assert process.returncode == status, rest  # what it printed, if it ended otherwise
    assert rest.strip().splitlines()[-1] == f"evmap: {line}" and "Traceback" not in rest
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("reader", ["head -1", "true"])
def test_a_closed_pipe_ends_quietly(reader):
    """The reader takes one line and goes, or reads nothing (``| true``): no traceback, nothing on stderr, and
    the status of a command stopped by SIGPIPE (141) or, if everything fitted in the pipe first, 0."""
    result = subprocess.run(
        ["bash", "-c", f"{sys.executable} -m evmap.maps.app.cli config check | {reader}; exit ${{PIPESTATUS[0]}}"],
        check=False,
        capture_output=True,
        text=True,
    )
    assert result.returncode in (0, 141) and result.stderr == ""
    assert result.stdout.strip().endswith("valid") if reader == "head -1" else result.stdout == ""
