"""The numbers the figures state (in their titles) and draw, against report.json; a run without a world.

Each figure says what it counts: Fig. 2 the RCDs at its own tolerance, Fig. 5b
the primitive RCDs, Fig. 6 the matching RCDs (the report's ``rcds_*``); the
figures of segments and of the map count every pose, like the report.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest
from matplotlib.figure import Figure
from pinned_worlds import former

from evmap.maps import BeliefMap
from evmap.maps.app import figures
from evmap.maps.app.run import Run, report, run_scenario
from evmap.sources.config import load_config
from evmap.sources.rcd import extract_rcds
from evmap.sources.sim.scenario import default_scenario, load_scenario

SCENARIOS = Path(__file__).parent / "scenarios"
PATROL = Path(__file__).parents[1] / "configs" / "scenarios" / "patrol.yaml"


@pytest.fixture(scope="module", params=["corridor", "figures_two_poses"])
def run(request: pytest.FixtureRequest) -> Run:
    scenario = default_scenario() if request.param == "corridor" else load_scenario(SCENARIOS / f"{request.param}.yaml")
    return run_scenario(scenario, load_config())


def text(fig: Figure) -> str:
    """Headline and every title of a figure, on one line."""
    return " ".join([fig.get_suptitle(), *(ax.get_title(loc="left") for ax in fig.axes)]).replace("\n", " ")


def numbers(pattern: str, fig: Figure) -> tuple[int, ...]:
    found = re.search(pattern, text(fig))
    assert found, (pattern, text(fig))
    return tuple(int(n) for n in found.groups())


def drawn(fig: Figure, gid: str) -> int:
    return sum(len(c.get_segments()) for c in fig.axes[0].collections if c.get_gid() == gid)


def test_segment_figures_state_and_draw_the_reports_counts(run: Run) -> None:
    r = report(run)
    real = r["lsl_segments"] - r["noise_segments"]
    fig4 = figures.lsl_lines_figure(run)
    assert numbers(r"(\d+) LSL segments: (\d+) on true surfaces, (\d+) sunlight phantoms", fig4) == (
        r["lsl_segments"],
        real,
        r["noise_segments"],
    )
    assert drawn(fig4, "lsl-real") + drawn(fig4, "lsl-phantom") == r["lsl_segments"]
    fig6a = figures.noise_figure(run)
    assert numbers(r"(\d+) of (\d+) phantoms eliminated, (\d+) of (\d+) real segments lost, (\d+) kept", fig6a) == (
        r["noise_eliminated"],
        r["noise_segments"],
        r["real_eliminated"],
        real,
        r["lines_before_merge"],
    )
    assert drawn(fig6a, "eliminated-phantom") == r["noise_eliminated"]
    assert drawn(fig6a, "kept-real") + drawn(fig6a, "kept-phantom") == r["lines_before_merge"]


def test_map_figures_state_the_reports_counts(run: Run) -> None:
    r = report(run)
    fig6b = figures.merged_map_figure(run)
    assert numbers(r"(\d+) segments → (\d+) lines .*?; (\d+) corners", fig6b) == (
        r["lines_before_merge"],
        r["lines_after_merge"],
        r["corners"],
    )
    assert drawn(fig6b, "map-lines") == r["lines_after_merge"]
    fig7 = figures.final_map_figure(run)
    assert numbers(r"(\d+) lines \(\d+ reinforced\), (\d+) corners \(\d+ reinforced\), (\d+) unidentified", fig7) == (
        r["lines_after_merge"],
        r["corners"],
        r["unidentified"],
    )


def test_rcd_figures_say_which_rcds_they_count_and_the_matching_sums_to_the_report(run: Run) -> None:
    r = report(run)
    totals = [0, 0, 0]
    for pose, obs in enumerate(run.observations):
        fig6 = figures.rcd_matching_figure(run, pose)
        actual = numbers(
            r"\(a\) The (\d+) matching RCDs of the actual scan RCDs of readings within 2 cm over at least 8°", fig6
        )[0]
        simulated = numbers(r"the (\d+) RCDs of the scan simulated", fig6)[0]
        matched, of = numbers(r"\((\d+) of (\d+) actual RCDs\)", fig6)
        assert of == actual == len(run.outcomes[pose].actual)
        totals = [totals[0] + actual, totals[1] + simulated, totals[2] + matched]
        if len(run.observations) > 1:
            assert numbers(r"poses: (\d+) of (\d+) actual RCDs matched, (\d+) simulated", fig6) == (
                r["rcds_matched"],
                r["rcds_actual"],
                r["rcds_simulated"],
            )
        fig2 = figures.sonar_scan_figure(run, pose)
        plotted = numbers(r"(\d+) RCDs of readings within 1 cm over at least 10°", fig2)[0]
        assert plotted == drawn(fig2, "rcd-arcs") == len(extract_rcds(obs.sonar, run.config.rcd_figure))
        matching, primitive = numbers(r"The matching \(Fig\. 6\) uses (\d+) RCDs .*? (\d+) primitive RCDs", fig2)
        fig5 = figures.open_space_figure(run, pose)
        assert numbers(r"from (\d+) primitive RCDs, every width", fig5) == (primitive,)
        assert (matching, primitive) == (actual, len(run.outcomes[pose].primitive))
    assert totals == [r["rcds_actual"], r["rcds_simulated"], r["rcds_matched"]]


def test_a_multi_pose_run_counts_the_phantoms_of_every_pose() -> None:
    """The patrol's first pose sees no sunlight: a figure of pose 0 alone would say 0 of 0."""
    run = run_scenario(load_scenario(PATROL), load_config())
    r = report(run)
    assert r["poses"] > 1 and r["noise_segments"] > 0
    fig = figures.noise_figure(run)
    assert numbers(r"(\d+) of (\d+) phantoms eliminated", fig) == (r["noise_eliminated"], r["noise_segments"])
    assert f"from all {r['poses']} poses" in text(fig)


def test_figures_of_measured_data_draw_no_true_walls_and_no_truth(tmp_path: Path) -> None:
    simulated = run_scenario(default_scenario(), load_config())
    data = simulated.map.to_data()
    data["graph"]["segments"]["truth"] = [""] * len(simulated.map.segments)  # ground truth unknown, as from a log
    run = dataclasses.replace(simulated, world=None, map=BeliefMap.from_data(data))
    paths = figures.write_figures(run, tmp_path)
    assert len(paths) == len(figures.FIGURE_FILES)
    for make in figures.FIGURE_FILES.values():
        fig = make(run)
        labels = [t.get_text() for t in fig.legends[0].get_texts()]
        assert not any("true" in label or "phantom" in label for label in labels), labels
        assert not [a for ax in fig.axes for a in ax.get_children() if a.get_gid() in ("walls", "sunlight")]
    fig4 = figures.lsl_lines_figure(run)
    assert drawn(fig4, "lsl-segments") == len(run.map.segments)
    assert f"{len(run.map.segments)} LSL segments (ground truth unknown)" in text(fig4)
    eliminated, n = int(run.map.segments.eliminated.sum()), len(run.map.segments)
    assert eliminated > 0
    assert f"{eliminated} of {n} segments eliminated as noise, {n - eliminated} kept" in text(figures.noise_figure(run))


def test_simulated_walls_are_labelled_true_walls() -> None:
    run = run_scenario(default_scenario(), load_config())
    labels = [t.get_text() for t in figures.sonar_scan_figure(run).legends[0].get_texts()]
    assert "true walls (simulated world)" in labels and not any("hand-measured" in label for label in labels)


def test_figures_of_a_log_count_its_raw_segments_as_the_report_does() -> None:
    """A log's lines seen from many poses stand on consolidated supports (rows of the segment store that are no
    scan's segment): the figures, like report.json and segments.json, count the raw segments only."""
    from evmap.maps.app.log_run import run_log

    run = run_log(Path(__file__).parent / "data" / "logs" / "intel-excerpt.log.gz", load_config())
    assert (run.map.segments.role == "support").any()
    r = report(run)
    fig4 = figures.lsl_lines_figure(run)
    assert f"{r['lsl_segments']} laser segments" in text(fig4)
    kept = r["lsl_segments"] - r["eliminated"]
    assert f"{r['eliminated']} of {r['lsl_segments']} segments eliminated as noise, {kept} kept" in text(
        figures.noise_figure(run)
    )
    assert f"{r['lines_before_merge']} segments → " in text(figures.merged_map_figure(run))


def test_a_tour_s_consolidated_supports_are_no_segments_of_the_report_the_records_or_the_figures() -> None:
    """A line seen from more than 3 poses stands on a support row, which a later support may absorb; neither is a
    segment the LSL returned: report.json, segments.json and the figures count and colour the raw ones only."""
    from evmap.maps.app.run import segment_records
    from evmap.sources.sim.worldgen import generate_world, world_seed

    run = run_scenario(generate_world(world_seed(0, 2), former()), load_config("paper"))  # a 6-pose tour
    store = run.map.segments
    assert (store.seen > 1).any() and (store.role[store.seen > 1] == "absorbed").any()
    r, records = report(run), segment_records(run)
    assert r["lsl_segments"] == len(records) == r["noise_segments"] + int((store.truth == "real").sum())
    assert {record["truth"] for record in records} == {"real", "noise"}
    assert r["lines_before_merge"] == sum(not record["eliminated"] for record in records)
    real = r["lsl_segments"] - r["noise_segments"]
    assert numbers(r"(\d+) LSL segments: (\d+) on true surfaces, (\d+) sunlight phantoms", figures.lsl_lines_figure(run)) == (
        r["lsl_segments"], real, r["noise_segments"],
    )  # fmt: skip
    assert f"{r['lines_before_merge']} segments → " in text(figures.merged_map_figure(run))
    from evmap.maps.app.compare_metrics import world_metrics

    metrics = world_metrics(run)
    assert metrics["mean_conflict"] == pytest.approx(float(store.conflict[store.raw].mean()))
    assert metrics["max_conflict"] == pytest.approx(float(store.conflict[store.raw].max()))
