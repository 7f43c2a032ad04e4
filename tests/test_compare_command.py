"""`evmap compare` through main(): intervals and definitions, streaming, a bad scheduler, Ctrl-C, --force."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from evmap.maps.app.cli import main
from evmap.maps.app.compare import write_comparison
from evmap.maps.app.compare_metrics import COLUMNS, DISTANCES, FREE_HAZARDS, HAZARDS, METRICS
from evmap.maps.app.compare_plots import PLOT_FILES
from evmap.maps.app.compare_runner import iter_results, run_comparison
from evmap.maps.app.compare_tables import SUMMARY_COLUMNS, summary_markdown
from evmap.maps.app.output_layout import MARKER
from evmap.sources.sim.worldgen_params import WorldGenParams

ONE_POSE = WorldGenParams(single_pose_share=1)
"""Single-pose worlds: the properties tested here do not depend on the tours, which cost several times more."""

ARGS = ["--rules", "dempster,yager,dubois_prade", "--worlds", "3", "--seed", "2", "--quiet"]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("cmp") / "out"
    assert main(["compare", *ARGS, "--out", str(out), "--scheduler", "synchronous"]) == 0
    return out


def test_summary_keeps_the_old_columns_first_and_adds_intervals(written):
    with (written / "summary.csv").open() as f:
        header = next(csv.reader(f))
    assert header[: len(COLUMNS) + 1] == [*COLUMNS, "worlds"]  # what other tools read, unchanged
    assert header == list(SUMMARY_COLUMNS)
    rows = list(csv.DictReader((written / "summary.csv").open()))
    cut = 0
    for row in rows:
        for m in (*METRICS, *HAZARDS, *FREE_HAZARDS):
            if row[f"{m}_lo"]:
                lo, hi = float(row[f"{m}_lo"]), float(row[f"{m}_hi"])
                assert 0 <= lo <= float(row[m]) <= hi <= (np.inf if m in DISTANCES else 1)  # what the metric can be
                cut += lo == 0 or hi == 1
    assert cut  # three worlds: wide intervals, some cut at 0 or 1
    md = (written / "summary.md").read_text()
    assert "Student t interval" in md and all(f"- `{m}`:" in md for m in METRICS)


def test_the_directory_holds_the_tables_plots_and_worlds_and_is_marked(written):
    names = {p.name for p in written.iterdir()}
    assert names == {"summary.csv", "worlds.csv", "summary.md", "worlds", MARKER, *PLOT_FILES}
    assert sorted(p.name for p in (written / "worlds").iterdir()) == [f"world-000{i}.yaml" for i in range(3)]
    worlds = list(csv.DictReader((written / "worlds.csv").open()))
    assert [r["world"] for r in worlds] == [f"world-000{i}" for i in range(3) for _ in range(3)]


def test_equal_rules_get_equal_numbers_and_every_rule_is_drawn(written):
    rows = {r["rule"]: r for r in csv.DictReader((written / "summary.csv").open())}
    assert rows["yager"]["noise_recall"] == rows["dubois_prade"]["noise_recall"]  # equal on a two-element frame
    assert all((written / name).read_bytes().startswith(b"\x89PNG") for name in PLOT_FILES)


def test_same_seed_same_numbers_whatever_the_scheduler():
    def numbers(c):
        return [{k: v for k, v in r.items() if not k.startswith("seconds")} for r in (*c.rows, *c.summary)]

    a = run_comparison(["dempster", "murphy"], 5, 4, params=ONE_POSE, scheduler="synchronous", progress=False)
    b = run_comparison(["dempster", "murphy"], 5, 4, params=ONE_POSE, scheduler="threads", workers=2, progress=False)
    assert numbers(a) == numbers(b) and a.differences == b.differences
    assert all(np.array_equal(a.beliefs[v], b.beliefs[v]) for v in a.variants)
    # the paired differences: murphy's value less dempster's on each world, averaged over the worlds
    (murphy,) = a.differences
    for m in (*METRICS, *HAZARDS, *FREE_HAZARDS):
        rows = {r["rule"]: [x[m] for x in a.rows if x["rule"] == r["rule"]] for r in a.summary}
        d = [u - v for u, v in zip(rows["murphy"], rows["dempster"], strict=True) if u is not None and v is not None]
        assert murphy[m] == pytest.approx(np.mean(d)) if d else murphy[m] is None
        if len(d) > 1:
            assert murphy[f"{m}_lo"] <= murphy[m] <= murphy[f"{m}_hi"]
    assert "Paired differences from `dempster`" in summary_markdown(a)


def test_results_stream_in_world_order_and_lazily():
    results = iter_results(["dempster"], 1_000_000, 3, params=ONE_POSE, scheduler="threads", workers=2, progress=False)
    first = [next(results).world for _ in range(3)]
    results.close()  # a million worlds: only the batches in flight were ever computed
    assert first == ["world-0000", "world-0001", "world-0002"]


def test_an_unreachable_scheduler_is_one_line_and_exit_2(capsys, tmp_path):  # its time: benchmarks/bench_cli.py
    code = main(["compare", *ARGS, "--out", str(tmp_path / "out"), "--scheduler", "tcp://127.0.0.1:9"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("evmap: error: --scheduler tcp://127.0.0.1:9: cannot reach") and err.count("\n") == 1, err
    assert list(tmp_path.iterdir()) == []


def test_force_refuses_a_directory_evmap_did_not_make(capsys, tmp_path, written):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text("mine")
    assert main(["compare", *ARGS, "--out", str(out), "--force", "--scheduler", "synchronous"]) == 2
    assert "results.csv" in capsys.readouterr().err and (out / "results.csv").read_text() == "mine"


@pytest.mark.parametrize(
    ("after", "signum", "status", "how"),
    [
        (4, signal.SIGINT, 130, "interrupted"),  # while the workers start
        (8, signal.SIGINT, 130, "interrupted"),  # while they compute
        (8, signal.SIGTERM, 143, "terminated"),
    ],
)
def test_a_signal_stops_the_cluster_cleanly_with_one_line(tmp_path, after, signum, status, how):
    out = tmp_path / "out"
    script = Path(sys.executable).parent / "evmap"
    proc = subprocess.Popen(
        [script, "compare", "--worlds", "400", "--workers", "1", "--out", str(out)],
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
    )
    time.sleep(after)
    if signum == signal.SIGINT:
        os.killpg(proc.pid, signum)  # what Ctrl-C does: the whole group
    else:
        proc.send_signal(signum)  # what kill does: the command alone, which shuts its workers down
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == status, err
    assert err.rstrip().splitlines()[-1] == f"evmap: {how}; nothing written to {out}"
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_write_comparison_writes_a_gathered_comparison_like_the_command(tmp_path, written):
    comparison = run_comparison(
        ["dempster", "yager", "dubois_prade"], 3, 2, scheduler="synchronous", progress=False,
        configs=("default",),  # the command's default config
    )  # fmt: skip
    write_comparison(comparison, tmp_path)
    for name in ("summary.csv", "worlds.csv"):
        mine, theirs = (list(csv.DictReader((d / name).open())) for d in (tmp_path, written))
        assert [_untimed(r) for r in mine] == [_untimed(r) for r in theirs]
    assert sorted(p.name for p in (tmp_path / "worlds").iterdir()) == sorted(
        p.name for p in (written / "worlds").iterdir()
    )


def _untimed(row):
    return {k: v for k, v in row.items() if not k.startswith("seconds")}
