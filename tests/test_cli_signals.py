"""Ctrl-C and SIGTERM end a run cleanly: one line, status 130 / 143, no output directory, nothing left behind."""

import signal
import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    ("signum", "status", "line"), [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
def test_a_signal_during_a_run_ends_it_cleanly(tmp_path, signum, status, line):
    """The signal comes once the run is under way (its figures alone take seconds). A process started in the
    background of a shell ignores SIGINT, and so would the run it starts: the run is started as from a terminal."""
    out = tmp_path / "out"
    inherited = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        process = subprocess.Popen(
            [sys.executable, "-m", "evmap.maps.app.cli", "run", "--out", str(out)],
            stderr=subprocess.PIPE,
            text=True,
        )
    finally:
        signal.signal(signal.SIGINT, inherited)
    first = process.stderr.readline()  # printed once the command is under way, its handlers set
    assert first.startswith("evmap: running scenario")
    process.send_signal(signum)
    rest = process.stderr.read()
    process.wait(timeout=60)
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


def test_an_interrupt_while_the_tool_tidies_up_after_the_command_is_one_line(monkeypatch, capsys):
    from evmap.maps.app import cli

    calls = []

    def restore_interrupted(signum, handler):
        calls.append(signum)
        if len(calls) == 2:  # the second call restores SIGTERM's handler, after the command returned
            raise KeyboardInterrupt
        return signal.SIG_DFL

    monkeypatch.setattr(cli.signal, "signal", restore_interrupted)
    assert cli.main(["rules"]) == 130
    out, err = capsys.readouterr()
    assert err == "evmap: interrupted\n" and "dempster" in out


def test_an_interrupt_while_the_command_line_loads_is_one_line(monkeypatch, capsys):
    import importlib.abc

    from evmap.maps import app

    class Interrupting(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name == "evmap.maps.app.cli":
                raise KeyboardInterrupt

    monkeypatch.delitem(sys.modules, "evmap.maps.app.cli", raising=False)
    monkeypatch.setattr(sys, "meta_path", [Interrupting(), *sys.meta_path])
    assert app.main() == 130
    assert capsys.readouterr().err == "evmap: interrupted\n"
