"""The figures of the paper's pipeline (maps.app.figures) on the default scenario and a two-pose one.

What they draw; their counts against report.json are in test_figures_counts.py.
"""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import matplotlib.colors as mcolors
import numpy as np
import pytest
from matplotlib.figure import Figure

from evmap.maps.app import figures
from evmap.maps.app.run import Run, run_scenario
from evmap.sources.config import load_config
from evmap.sources.rcd import extract_rcds
from evmap.sources.sim.scenario import default_scenario, load_scenario, parse_scenario

TWO_POSES = Path(__file__).parent / "scenarios" / "figures_two_poses.yaml"
PER_POSE = [f for f in figures.FIGURE_FILES.values() if f not in (figures.merged_map_figure, figures.final_map_figure)]
EXPECTED_FILES = [
    "fig2_sonar_scan_rcds.png",
    "fig4_lsl_lines.png",
    "fig5_open_space.png",
    "fig6a_noise_eliminated.png",
    "fig6b_merged_corners.png",
    "fig6c_rcd_matching.png",
    "fig7_final_map.png",
]


@pytest.fixture(scope="module")
def corridor() -> Run:
    return run_scenario(default_scenario(), load_config())


@pytest.fixture(scope="module")
def two_poses() -> Run:
    return run_scenario(load_scenario(TWO_POSES), load_config())


@pytest.fixture(params=["corridor", "two_poses"])
def run(request: pytest.FixtureRequest) -> Run:
    return request.getfixturevalue(request.param)


def collection(fig: Figure, gid: str, ax: int = 0):
    """The one artist of the figure's axes ``ax`` tagged ``gid``."""
    found = [c for c in fig.axes[ax].get_children() if c.get_gid() == gid]
    assert len(found) == 1, (gid, len(found))
    return found[0]


def labels(fig: Figure, gid: str, ax: int = 0) -> list[str]:
    return [t.get_text() for t in fig.axes[ax].texts if t.get_gid() == gid]


def n_segments(fig: Figure, gid: str, ax: int = 0) -> int:
    return len(collection(fig, gid, ax).get_segments())


@pytest.mark.parametrize("make", figures.FIGURE_FILES.values(), ids=list(figures.FIGURE_FILES))
def test_every_figure_draws_a_titled_map_in_metres(run: Run, make) -> None:
    fig = make(run)
    assert isinstance(fig, Figure)
    for ax in fig.axes:
        assert ax.get_aspect() == 1.0
        assert ax.get_title(loc="left")
        assert collection(fig, "walls", fig.axes.index(ax)) is not None
    assert fig.axes[-1].get_xlabel() == "x (m)" and fig.axes[0].get_ylabel() == "y (m)"
    assert len(fig.legends) == 1 and fig.legends[0].get_texts()
    # the true walls are inside the view
    s = run.world.surfaces()
    x0, x1 = fig.axes[0].get_xlim()
    y0, y1 = fig.axes[0].get_ylim()
    assert x0 < s.vertices[:, 0].min() and s.vertices[:, 0].max() < x1
    assert y0 < s.vertices[:, 1].min() and s.vertices[:, 1].max() < y1


@pytest.mark.parametrize("make", PER_POSE, ids=lambda f: f.__name__)
def test_per_pose_figures_show_the_chosen_pose(two_poses: Run, make) -> None:
    fig = make(two_poses, 1)
    robot = collection(fig, "robot")
    assert robot.center == pytest.approx(tuple(two_poses.world.poses[1, :2]))
    for bad in (2, -1, True, 0.0):
        with pytest.raises(ValueError, match=r"pose must be an integer index in \[0, 2\)"):
            make(two_poses, bad)


def test_map_and_segment_figures_show_every_pose(two_poses: Run) -> None:
    for make in (figures.lsl_lines_figure, figures.noise_figure, figures.merged_map_figure, figures.final_map_figure):
        fig = make(two_poses)
        robots = [c for c in fig.axes[0].patches if c.get_gid() == "robot"]
        assert sorted(r.center for r in robots) == sorted(map(tuple, two_poses.world.poses[:, :2].tolist()))


def test_sonar_scan_figure_draws_every_rcd_of_the_figure_parameters(run: Run) -> None:
    rcds = extract_rcds(run.observations[0].sonar, run.config.rcd_figure)
    fig = figures.sonar_scan_figure(run)
    assert len(rcds) > 0
    assert n_segments(fig, "rcd-arcs") == len(rcds)
    roman = {1: "I", 2: "II", 3: "III", 4: "IV"}
    assert labels(fig, "rcd-label") == [f"{k + 1}·{roman[int(t)]}" for k, t in enumerate(rcds.type)]
    assert collection(fig, "returns").get_offsets().shape == (len(run.observations[0].sonar), 2)
    assert n_segments(fig, "rays") == -(-len(run.observations[0].sonar) // 10)
    # an arc lies at the RCD's mean range from the sensor
    arc = collection(fig, "rcd-arcs").get_segments()[0]
    r = np.hypot(*(arc - run.observations[0].pose[:2]).T)
    assert r == pytest.approx(rcds.range[0])


def test_lsl_figure_tells_phantoms_from_real_segments(run: Run) -> None:
    truth = run.map.segments.truth
    fig = figures.lsl_lines_figure(run)
    assert n_segments(fig, "lsl-real") == int((truth == "real").sum())
    assert n_segments(fig, "lsl-phantom") == int((truth == "noise").sum()) > 0
    real, phantom = collection(fig, "lsl-real"), collection(fig, "lsl-phantom")
    assert not np.allclose(real.get_colors()[0], phantom.get_colors()[0])
    one = figures.lsl_lines_figure(run, 0)
    assert n_segments(one, "lsl-real") + n_segments(one, "lsl-phantom") == len(run.observations[0].lsl)


def test_open_space_figure_marks_multiple_reflections_and_fills_the_open_space(run: Run) -> None:
    scan = run.observations[0].sonar
    fig = figures.open_space_figure(run)
    assert len(fig.axes) == 2
    assert len(collection(fig, "multiple-reflections").get_offsets()) == int((scan.order >= 2).sum())
    space = collection(fig, "open-space", ax=1)
    assert space.get_path().vertices.shape[0] > 3
    assert fig.get_suptitle().startswith("Fig. 5")


def test_noise_figure_draws_eliminated_segments_faint(run: Run) -> None:
    store = run.map.segments
    ids = np.arange(len(store))
    fig = figures.noise_figure(run)
    gids = ("kept-real", "kept-phantom", "eliminated-real", "eliminated-phantom")
    assert sum(n_segments(fig, g) for g in gids) == len(ids)
    gone = store.eliminated[ids]
    noise = store.truth[ids] == "noise"
    assert n_segments(fig, "eliminated-phantom") == int((gone & noise).sum()) > 0
    assert n_segments(fig, "kept-real") == int((~gone & ~noise).sum())
    assert (
        collection(fig, "eliminated-phantom").get_alpha() < 0.5 and collection(fig, "kept-phantom").get_alpha() is None
    )


def test_merged_map_figure_draws_every_line_and_corner(run: Run) -> None:
    g = run.map.graph
    fig = figures.merged_map_figure(run)
    assert n_segments(fig, "map-lines") == g.number_of_edges()
    assert n_segments(fig, "segments") == int((~run.map.segments.eliminated).sum())
    shapes = [d.get("shape") for _, d in g.nodes.items() if d["kind"] == "corner"]
    drawn = {k: len(collection(fig, f"points-{k}").get_xdata()) for k in ("concave", "convex")}
    assert drawn == {"concave": shapes.count("concave"), "convex": shapes.count("convex")}
    ends = sum(d["kind"] == "endpoint" for _, d in g.nodes.items())
    assert len(collection(fig, "points-endpoint").get_xdata()) == ends


def test_rcd_matching_figure_labels_rcds_and_lists_the_matched_pairs(run: Run) -> None:
    outcome = run.outcomes[0]
    ai, si = outcome.matched
    fig = figures.rcd_matching_figure(run)
    actual, simulated = labels(fig, "rcd-label", 0), labels(fig, "rcd-label", 1)
    assert [a.split("·")[0] for a in actual] == [str(k + 1) for k in range(len(outcome.actual))]
    assert [s.split("·")[0] for s in simulated][:3] == ["a", "b", "c"][: len(outcome.predicted)]
    assert len(simulated) == len(outcome.predicted)
    title = fig.axes[1].get_title(loc="left").replace("\n", " ")
    for a, s in zip(ai, si, strict=True):
        assert f"({actual[a].split('·')[0]},\u00a0{simulated[s].split('·')[0]})" in title
    # matched labels are framed green, on both panels
    green = mcolors.to_rgba("#009E73")
    framed = [
        t
        for ax in fig.axes
        for t in ax.texts
        if t.get_gid() == "rcd-label" and np.allclose(t.get_bbox_patch().get_edgecolor()[:3], green[:3])
    ]
    assert len(framed) == 2 * len(ai) > 0


def test_final_map_figure_draws_width_by_belief_and_marks_landmarks(run: Run) -> None:
    bm = run.map
    landmarks = {obj.id for obj in bm.landmarks()}
    lines = bm.lines(0.0)
    fig = figures.final_map_figure(run)
    plain, strong = collection(fig, "lines"), collection(fig, "landmark-lines")
    assert len(strong.get_segments()) == sum(ln.id in landmarks for ln in lines) > 0
    assert len(plain.get_segments()) + len(strong.get_segments()) == len(lines)
    beliefs = [ln.belief for ln in lines if ln.id not in landmarks] + [ln.belief for ln in lines if ln.id in landmarks]
    widths = np.r_[plain.get_linewidths(), strong.get_linewidths()]
    order = np.argsort(beliefs, kind="stable")
    assert np.all(np.diff(widths[order]) >= 0) and widths.max() > widths.min()
    unidentified = bm.unidentified()
    assert len(collection(fig, "unidentified").get_offsets()) == len(unidentified) > 0
    assert sorted(labels(fig, "unidentified-label")) == sorted(f"{u.id} {u.belief:.2f}" for u in unidentified)


def test_two_panel_figures_stack_a_wide_view_and_set_a_tall_one_side_by_side(corridor: Run, two_poses: Run) -> None:
    wide = figures.rcd_matching_figure(corridor)
    (a, b) = (ax.get_position() for ax in wide.axes)
    assert a.y0 > b.y1 and a.x0 == pytest.approx(b.x0)
    tall = figures.rcd_matching_figure(two_poses)
    (a, b) = (ax.get_position() for ax in tall.axes)
    assert b.x0 > a.x1 and a.y0 == pytest.approx(b.y0)


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_write_figures_writes_one_png_per_figure_and_per_pose_of_a_scan_figure(two_poses: Run, tmp_path: Path) -> None:
    paths = figures.write_figures(two_poses, tmp_path)
    assert EXPECTED_FILES == list(figures.FIGURE_FILES)
    extra = ["fig2_sonar_scan_rcds_pose1.png", "fig5_open_space_pose1.png", "fig6c_rcd_matching_pose1.png"]
    assert sorted(p.name for p in paths) == sorted(p.name for p in tmp_path.iterdir()) == sorted(EXPECTED_FILES + extra)
    for path in paths:
        width, height = png_size(path)
        assert width >= 1000 and height >= 700  # 150 dpi: readable
        assert path.stat().st_size > 20_000
    with pytest.raises(ValueError, match="figure format must be one of png, svg, pdf; got 'jpg'"):
        figures.write_figures(two_poses, tmp_path / "never", "jpg")
    assert not (tmp_path / "never").exists()


@pytest.mark.parametrize(("fmt", "magic"), [("svg", b"<?xml"), ("pdf", b"%PDF")])
def test_write_figures_writes_svg_and_pdf_without_a_date(corridor: Run, tmp_path: Path, fmt: str, magic: bytes) -> None:
    paths = figures.write_figures(corridor, tmp_path, fmt)
    assert [p.name for p in paths] == [name.replace(".png", f".{fmt}") for name in EXPECTED_FILES]
    assert all(p.read_bytes().startswith(magic) for p in paths)
    text = paths[0].read_bytes()
    assert b"CreationDate" not in text and b"<dc:date>" not in text


def test_importing_the_figures_and_the_command_line_loads_no_matplotlib() -> None:
    code = (
        "import sys, evmap.maps.app.figures as f, evmap.maps.app.artefacts, evmap.maps.app.cli;"
        "f.write_figures; f.FORMATS;"
        "print('matplotlib' in sys.modules, sorted(set(f.__all__) - set(dir(f))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False []"


def test_figures_leave_pyplot_alone() -> None:
    code = (
        "import sys, evmap.maps.app.figures, evmap.maps.app.run, evmap.sources.config, evmap.sources.sim.scenario;"
        "run = evmap.maps.app.run.run_scenario(evmap.sources.sim.scenario.default_scenario(),"
        " evmap.sources.config.load_config());"
        "evmap.maps.app.figures.final_map_figure(run);"
        "print('matplotlib.pyplot' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_every_figure_draws_a_world_with_nothing_to_eliminate_or_explain(tmp_path: Path) -> None:
    scenario = parse_scenario(
        "version: 1\nname: wall\nworld: {walls: [{id: w, points: [[0, 0], [3, 0]]}]}\nrobot: {poses: [[1.5, 1, 90]]}\n",
        "wall.yaml",
    )
    run = run_scenario(scenario, load_config())
    paths = figures.write_figures(run, tmp_path)
    assert len(paths) == len(EXPECTED_FILES) and all(p.stat().st_size > 0 for p in paths)
    fig = figures.lsl_lines_figure(run)
    assert n_segments(fig, "lsl-phantom") == 0 and n_segments(fig, "lsl-real") == len(run.observations[0].lsl)
    assert len(collection(figures.final_map_figure(run), "unidentified").get_offsets()) == 0
