"""Config files: the paper's config, and every kind of bad input named by file, key path and problem."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from evidential import RULES, Frame
from evmap import configs
from evmap.sources.config import load_config
from evmap.sources.config_model import MAX_FRAME_ELEMENTS, MAX_SOURCES, STAGES
from evmap.sources.evidence import MAX_BREAK_POINTS, MAX_CATEGORIES, MAX_TABLE_CELLS
from evmap.sources.loading import InputError

HERE = Path(__file__).parent / "configs"
PAPER = configs.path("paper.yaml")


def paper_data() -> dict:
    return yaml.safe_load(PAPER.read_text())


def write(tmp_path: Path, data: dict) -> Path:
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


# ---- the paper's config -------------------------------------------------------------------------


def test_default_config_is_the_packaged_paper_yaml():
    cfg = load_config()
    assert cfg.name == str(PAPER)
    assert cfg.frame == Frame(["real", "noise"])
    assert cfg.frame_name == "existence"
    assert cfg.aliases["existence"] == {"unknown": "real|noise"}
    assert cfg.rule == "dempster"


def test_a_packaged_name_is_the_packaged_config_whatever_the_directory_holds(tmp_path, monkeypatch):
    """An output directory named after the config (``--out paper``) made ``--config paper`` fail, and a file
    named ``default`` was read in place of the packaged config; ``./paper`` names a file."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper").mkdir()
    (tmp_path / "default").write_text("not: a config\n")
    assert load_config("paper").name == load_config(configs.path("paper.yaml")).name
    assert load_config("default").stages == load_config(configs.path("default.yaml")).stages
    with pytest.raises(InputError, match="default"):
        load_config("./default")


def test_paper_table_1():
    source = load_config().sources["sonar_open_space"]
    m = source.masses({"relation": np.array(["outside", "partly_inside", "inside"])})
    # columns: {}, real, noise, real|noise (Unknown)
    np.testing.assert_array_equal(m, [[0, 0.8, 0.1, 0.1], [0, 0.1, 0.1, 0.8], [0, 0.1, 0.8, 0.1]])


def test_paper_lsl_ramp_c_06_l_040():
    source = load_config().sources["lsl_length"]
    lengths = np.array([0.0, 0.1, 0.2, 0.4, 0.41, 3.0])
    m = source.masses({"length": lengths})
    np.testing.assert_allclose(m[:, 1], 0.6 * np.minimum(lengths / 0.40, 1), atol=1e-15)
    np.testing.assert_allclose(m[:, 3], 1 - m[:, 1], atol=1e-15)


def test_paper_parameters():
    cfg = load_config()
    assert (cfg.rcd.range_tolerance, cfg.rcd.min_width_deg) == (0.02, 8.0)
    assert (cfg.rcd_figure.range_tolerance, cfg.rcd_figure.min_width_deg) == (0.01, 10.0)
    assert (cfg.merge.distance, cfg.merge.angle_deg) == (0.05, 10.0)
    assert cfg.corners.distance == 0.05
    assert (cfg.noise.threshold, cfg.noise.inside_fraction, cfg.noise.outside_fraction) == (0.5, 0.99, 0.01)
    assert (cfg.sensors.sonar.beam_width_deg, cfg.sensors.lsl.fov_deg, cfg.sensors.lsl.snapshots) == (25, 27, 15)
    assert cfg.sensors.lsl.step_deg == 24


def test_paper_stages_and_reinforcement_tables():
    cfg = load_config()
    assert set(cfg.stages) == set(STAGES)
    assert [s.name for s in cfg.stage_sources("reinforcement")] == ["sonar_match"]
    assert [s.name for s in cfg.stage_sources("unidentified")] == ["sonar_only"]
    match = cfg.sources["sonar_match"].masses({"sonar_match": ["matched", "missed", "unobserved"]})
    assert match[0, 1] > 0.5 and match[0, 2] == 0  # matched: strong support for real
    assert 0 < match[1, 2] < 0.5 and match[1, 1] == 0  # missed: weak support for noise
    np.testing.assert_array_equal(match[2], [0, 0, 0, 1])  # unobserved: vacuous
    only = cfg.sources["sonar_only"].masses({"rcd_type": ["I", "II", "III", "IV"]})
    assert 0 < only[0, 1] <= 0.6 and not only[:, 2].any()  # mid-level belief in real at most
    np.testing.assert_array_equal(only[3], [0, 0, 0, 1])


def test_a_copy_anywhere_works_and_key_order_has_no_meaning(tmp_path):
    def reverse(node):  # every mapping in reverse key order; lists (stages, break points) kept
        if isinstance(node, dict):
            return {k: reverse(node[k]) for k in reversed(list(node))}
        return [reverse(v) for v in node] if isinstance(node, list) else node

    original, shuffled = load_config(), load_config(write(tmp_path, reverse(paper_data())))
    for name, source in original.sources.items():
        values = np.array(source.examples)
        np.testing.assert_array_equal(
            shuffled.sources[name].masses({source.feature: values}), source.masses({source.feature: values})
        )
    assert shuffled.stages == original.stages
    assert shuffled.noise == original.noise and shuffled.sensors == original.sensors
    assert shuffled.frame == original.frame


def test_the_good_fixture_loads_and_missing_sections_take_the_defaults():
    cfg = load_config(HERE / "minimal.yaml")
    assert cfg.noise.threshold == 0.5 and cfg.rcd_figure.range_tolerance == 0.01
    assert cfg.stages["noise_elimination"] == ("sonar_open_space", "lsl_length")


def test_config_is_immutable_and_with_rule_makes_a_copy():
    cfg = load_config()
    other = cfg.with_rule("yager")
    assert (cfg.rule, other.rule) == ("dempster", "yager")
    assert other.sources is cfg.sources
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.rule = "pcr6"  # type: ignore[misc]
    with pytest.raises(TypeError):
        cfg.sources["x"] = cfg.sources["lsl_length"]  # type: ignore[index]
    with pytest.raises(TypeError):
        cfg.stages["reinforcement"] = ()  # type: ignore[index]
    with pytest.raises(Exception, match="frozen"):
        cfg.noise.threshold = 0.9  # type: ignore[misc]


def test_with_rule_accepts_every_registered_rule_for_closed_world_sources_and_refuses_others():
    cfg = load_config()
    for rule in RULES:
        if RULES[rule].empty_set == "required":  # bold: m(∅) > 0 in every source, which evmap's never have
            with pytest.raises(ValueError, match=f"rule '{rule}' combines only mass functions with m\\(∅\\) > 0"):
                cfg.with_rule(rule)
        else:
            assert cfg.with_rule(rule).rule == rule
    with pytest.raises(ValueError, match="unknown rule 'dempstr'; rules are: .*dempster"):
        cfg.with_rule("dempstr")


def test_stage_sources_refuses_an_unknown_stage():
    with pytest.raises(ValueError, match="unknown stage 'merging'"):
        load_config().stage_sources("merging")


# ---- bad input: the fixtures --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fixture", "where", "problem"),
    [
        ("bad_sum.yaml", "sources.sonar_open_space.table.inside:", "masses sum to 0.9, not 1"),
        ("negative_mass.yaml", "sources.sonar_open_space.table.outside.unknown:", "mass -0.1 is negative"),
        ("unknown_element.yaml", "sources.sonar_open_space.table.partly_inside.ghost:", "'ghost' is not in"),
        ("missing_category.yaml", "sources.sonar_open_space.table:", "'partly_inside' is missing"),
        ("ramp_not_monotone.yaml", "sources.lsl_length.points[2]:", "strictly increasing in x"),
        ("unknown_kind.yaml", "sources.lsl_length.kind:", "unknown source kind 'spline'; kinds are: ramp, table"),
        ("duplicate_source.yaml", "line 18, column 3:", "duplicate key 'sonar_open_space'"),
        ("syntax_error.yaml", "line 18, column 13:", "expected ',' or '}'"),
        ("python_tag.yaml", "line 7, column 7:", "could not determine a constructor for the tag"),
    ],
)
def test_bad_fixture_is_named_by_file_key_path_and_problem(fixture, where, problem):
    path = HERE / fixture
    with pytest.raises(InputError) as err:
        load_config(path)
    message = str(err.value)
    assert message.startswith(f"{path}: {where}")
    assert problem in message


def test_a_python_tag_runs_no_code(tmp_path):
    marker = tmp_path / "ran"
    text = PAPER.read_text().replace("rule: dempster", f'rule: !!python/object/apply:os.system ["touch {marker}"]')
    (tmp_path / "c.yaml").write_text(text)
    with pytest.raises(InputError, match="python/object/apply:os.system"):
        load_config(tmp_path / "c.yaml")
    assert not marker.exists()


def test_a_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="nowhere.yaml: cannot read file"):
        load_config(tmp_path / "nowhere.yaml")


# ---- bad input: edits of the paper's config -----------------------------------------------------


def edit(data: dict, path: str, value) -> dict:
    """Set data at a dotted path (a value of ``DELETE`` removes the key)."""
    *parents, last = path.split(".")
    node = data
    for key in parents:
        node = node[key]
    if value is DELETE:
        del node[last]
    else:
        node[last] = value
    return data


DELETE = object()
TABLE = "sources.sonar_open_space"
RAMP = "sources.lsl_length"


@pytest.mark.parametrize(
    ("path", "value", "where", "problem"),
    [
        ("frame", "occupancy", "frame", "unknown frame 'occupancy'; frames are: existence"),
        ("rule", "dempstr", "rule", "unknown rule 'dempstr'"),
        ("frames.existence.elements", ["real", "real"], "frames.existence.elements", "'real' is given twice"),
        ("frames.existence.elements", [], "frames.existence.elements", "at least 1 item"),
        ("frames.existence.elements", ["real", "a|b"], "frames.existence.elements[1]", "should match pattern"),
        ("frames.existence.aliases", {"real": "noise"}, "frames.existence.aliases.real", "also an element"),
        ("frames.existence.aliases", {"unknown": "real|ghost"}, "frames.existence.aliases.unknown", "'ghost'"),
        (f"{TABLE}.frame", "other", f"{TABLE}.frame", "unknown frame 'other'"),
        (f"{TABLE}.kind", DELETE, f"{TABLE}.kind", "required key is missing; kinds are: ramp, table"),
        (f"{TABLE}.kind", 3, f"{TABLE}.kind", "unknown source kind 3"),
        (f"{TABLE}.colour", "red", f"{TABLE}.colour", "unknown key"),
        (
            f"{TABLE}.table.inside",
            {"real": 0.1, "noise": 0.8, "unknown": 0.1, "real|noise": 0.0},
            f"{TABLE}.table.inside.real|noise",
            "same focal set as 'unknown'",
        ),
        (
            f"{TABLE}.table.inside",
            {"real": 0.1, "noise": ".8", "unknown": 0.1},
            f"{TABLE}.table.inside.noise",
            "valid number",
        ),
        (
            f"{TABLE}.table.inside",
            {"real": 0.1, "noise": float("nan"), "unknown": 0.1},
            f"{TABLE}.table.inside.noise",
            "finite number",
        ),
        (f"{TABLE}.table.inside", {"real": 0.1, "noise": 0.8, "": 0.1}, f"{TABLE}.table.inside.", "empty set"),
        (f"{TABLE}.table.near", {"real": 1.0}, f"{TABLE}.table.near", "'near' is not in `categories`"),
        (
            f"{TABLE}.categories",
            ["outside", "inside", "outside", "partly_inside"],
            f"{TABLE}.categories[2]",
            "listed twice",
        ),
        (f"{TABLE}.categories", ["outside", True], f"{TABLE}.categories[1]", "valid string"),
        (f"{RAMP}.points", [[0.0, 0.0], [0.4, 1.5]], f"{RAMP}.points[1]", "mass 1.5 is outside [0, 1]"),
        (f"{RAMP}.points", [[0.0, 0.0], [0.0, 0.6]], f"{RAMP}.points[1]", "strictly increasing"),
        (f"{RAMP}.points", [], f"{RAMP}.points", "at least 1 item"),
        (f"{RAMP}.points", [[0.0, 0.0, 1.0]], f"{RAMP}.points[0]", "at most 2 items"),
        (f"{RAMP}.focal", "ghost", f"{RAMP}.focal", "'ghost' is not in"),
        (f"{RAMP}.focal", "", f"{RAMP}.focal", "empty set"),
        (f"{RAMP}.rest", {"unknown": 0.5, "noise": 0.4}, f"{RAMP}.rest", "sum to 0.9"),
        (
            "stages.reinforcement",
            ["sonar_match", "sonar_macth"],
            "stages.reinforcement[1]",
            "unknown source 'sonar_macth'",
        ),
        ("stages.reinforcement", ["sonar_match", "sonar_match"], "stages.reinforcement[1]", "listed twice"),
        ("stages.reinforcement", [], "stages.reinforcement", "at least 1 item"),
        ("stages.unidentified", DELETE, "stages.unidentified", "required key is missing"),
        ("stages.merging", ["sonar_match"], "stages.merging", "unknown key"),
        ("noise.threshold", 1.5, "noise.threshold", "less than or equal to 1"),
        ("sensors.sonar.beam_width", 25, "sensors.sonar.beam_width", "unknown key"),
        ("version", 2, "version", "unsupported version: this program reads version 1"),
        ("extra", 1, "extra", "unknown key"),
    ],
)
def test_bad_edit_is_named_by_key_path_and_problem(tmp_path, path, value, where, problem):
    config = write(tmp_path, edit(paper_data(), path, value))
    with pytest.raises(InputError) as err:
        load_config(config)
    message = str(err.value)
    assert message.startswith(f"{config}: {where}:"), message
    assert problem in message, message


def test_a_stage_source_on_another_frame_is_refused(tmp_path):
    data = paper_data()
    data["sources"]["sonar_match_existence"] = dict(data["sources"]["sonar_match"])
    data["frames"]["occupancy"] = {"elements": ["free", "occupied"], "aliases": {"unknown": "free|occupied"}}
    data["sources"]["sonar_match"]["frame"] = "occupancy"
    data["sources"]["sonar_match"]["table"] = {
        c: {"unknown": 1.0} for c in data["sources"]["sonar_match"]["categories"]
    }
    with pytest.raises(InputError, match="stages.reinforcement\\[0\\]: source 'sonar_match' is on frame 'occupancy'"):
        load_config(write(tmp_path, data))
    # the same source is fine outside the stages
    data["stages"]["reinforcement"] = ["sonar_match_existence"]
    cfg = load_config(write(tmp_path, data))
    assert cfg.sources["sonar_match"].frame == Frame(["free", "occupied"])


def test_a_frame_whose_elements_equal_the_map_frame_is_the_same_frame(tmp_path):
    data = paper_data()
    data["frames"]["copy"] = {"elements": ["real", "noise"]}
    data["sources"]["sonar_match"]["frame"] = "copy"
    data["sources"]["sonar_match"]["table"]["matched"] = {"real": 0.8, "real|noise": 0.2}
    data["sources"]["sonar_match"]["table"]["missed"] = {"noise": 0.2, "real|noise": 0.8}
    data["sources"]["sonar_match"]["table"]["unobserved"] = {"real|noise": 1.0}
    assert load_config(write(tmp_path, data)).stage_sources("reinforcement")[0].frame == Frame(["real", "noise"])


def test_loading_never_half_applies(tmp_path):
    # every source is valid but the last stage names a missing one: nothing is returned,
    # and the registry of kinds and an earlier config are untouched
    data = edit(paper_data(), "stages.unidentified", ["nobody"])
    before = load_config()
    with pytest.raises(InputError, match="stages.unidentified\\[0\\]"):
        load_config(write(tmp_path, data))
    assert set(before.sources) == {"sonar_open_space", "lsl_length", "lsl_repeat", "sonar_match", "sonar_only"}


# ---- absurd sizes -------------------------------------------------------------------------------


def test_too_many_sources(tmp_path):
    data = paper_data()
    for i in range(MAX_SOURCES):
        data["sources"][f"copy{i}"] = data["sources"]["lsl_length"]
    with pytest.raises(InputError, match=f"sources: Dictionary should have at most {MAX_SOURCES} items"):
        load_config(write(tmp_path, data))


def test_too_many_frame_elements(tmp_path):
    data = edit(paper_data(), "frames.existence.elements", [f"e{i}" for i in range(MAX_FRAME_ELEMENTS + 1)])
    with pytest.raises(InputError, match=f"frames.existence.elements: List should have at most {MAX_FRAME_ELEMENTS}"):
        load_config(write(tmp_path, data))


def test_too_many_categories(tmp_path):
    categories = [f"c{i}" for i in range(MAX_CATEGORIES + 1)]
    data = edit(paper_data(), f"{TABLE}.categories", categories)
    edit(data, f"{TABLE}.table", {c: {"unknown": 1.0} for c in categories})
    with pytest.raises(InputError, match=f"{TABLE}.categories: List should have at most {MAX_CATEGORIES}"):
        load_config(write(tmp_path, data))


def test_too_many_table_cells(tmp_path):
    # the most elements (256 focal sets) times 257 categories exceeds the cell limit
    elements = [f"e{i}" for i in range(MAX_FRAME_ELEMENTS)]
    categories = [f"c{i}" for i in range(MAX_TABLE_CELLS // 2**MAX_FRAME_ELEMENTS + 1)]
    data = paper_data()
    data["frames"]["big"] = {"elements": elements}
    data["sources"]["wide"] = {
        "kind": "table", "frame": "big", "feature": "f", "categories": categories,
        "table": {c: {"e0": 1.0} for c in categories},
    }  # fmt: skip
    with pytest.raises(InputError, match=f"sources.wide.categories: {len(categories)} categories .* exceed the limit"):
        load_config(write(tmp_path, data))


def test_too_many_break_points(tmp_path):
    points = [[i / 1000, 0.5] for i in range(MAX_BREAK_POINTS + 1)]
    with pytest.raises(InputError, match=f"{RAMP}.points: List should have at most {MAX_BREAK_POINTS}"):
        load_config(write(tmp_path, edit(paper_data(), f"{RAMP}.points", points)))


def test_a_huge_file_is_refused(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text(PAPER.read_text() + "#" * 5_000_001)
    with pytest.raises(InputError, match="larger than the limit"):
        load_config(path)


def test_a_misspelt_table_row_is_named_at_its_line_with_the_category_it_likely_is(tmp_path):
    """The error named the category the table lacked at the table's line, never the misspelt row."""
    data = paper_data()
    table = data["sources"]["sonar_open_space"]["table"]
    table["outsde"] = table.pop("outside")
    path = write(tmp_path, data)
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if "outsde:" in text)
    with pytest.raises(
        InputError,
        match=rf"sources\.sonar_open_space\.table\.outsde: category 'outsde' is not in `categories`: "
        rf"is it 'outside', which the table lacks\? \(line {line}\)",
    ):
        load_config(path)
