"""Plugins: the test package of tests/plugins seen through its entry points, by the CLI and by the rule suite.

The package is made visible to ``importlib.metadata`` the way pip installs it, offline
and at once: its module and a ``.dist-info`` (``METADATA``, ``entry_points.txt`` written
from its ``pyproject.toml``) in a temporary folder put on ``PYTHONPATH``.
"""

import csv
import importlib
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from evidential import RULES, Frame, MassError, MassFunction, combine, combine_batch
from evidential.stack import Stack
from evmap import configs
from evmap.maps.app.run import run_scenario
from evmap.sources.config import load_config
from evmap.sources.evidence import KINDS
from evmap.sources.plugins import register_plugin
from evmap.sources.sensor_kinds import SENSOR_KINDS
from evmap.sources.sim.scenario import default_scenario

PACKAGE = Path(__file__).parent / "plugins"
README = configs.path("examples/README.md")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A folder where the test package is installed, as pip would lay it out."""
    target = tmp_path_factory.mktemp("site")
    shutil.copytree(PACKAGE / "evmap_test_plugins", target / "evmap_test_plugins")
    project = tomllib.loads((PACKAGE / "pyproject.toml").read_text())["project"]
    info = target / f"evmap_test_plugins-{project['version']}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    groups = [
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in points.items())
        for group, points in project["entry-points"].items()
    ]
    (info / "entry_points.txt").write_text("\n".join(groups))
    return target


def evmap_cli(site, *args, cwd=None):
    """Run ``evmap ARGS`` in a fresh interpreter that sees the installed test package."""
    paths = [str(site), *sys.path]
    code = "import sys; from evmap.maps.app.cli import main; sys.exit(main(sys.argv[1:]))"
    env = {"PYTHONPATH": ":".join(p for p in paths if p), "PATH": "/usr/bin:/bin"}
    return subprocess.run(
        [sys.executable, "-c", code, *args], check=False, capture_output=True, text=True, env=env, cwd=cwd
    )


def test_evmap_rules_lists_the_good_rule_and_refuses_the_broken_one_by_name(site):
    done = evmap_cli(site, "rules")
    assert done.returncode == 0, done.stderr
    assert "average       evmap-test-plugins 0.1 (evmap_test_plugins:average); commutative, idempotent" in done.stdout
    assert "  dempster      builtin;" in done.stdout
    assert re.search(r"refused: doubled from evmap-test-plugins 0\.1 .*rule 'doubled' .*summing to 2", done.stdout)


def test_evmap_sources_lists_plugin_kinds_with_their_origin(site):
    done = evmap_cli(site, "sources")
    assert done.returncode == 0, done.stderr
    assert "  logistic  evmap-test-plugins 0.1 (evmap_test_plugins:LOGISTIC)" in done.stdout
    assert "  bumper  evmap-test-plugins 0.1 (evmap_test_plugins:BUMPER); not simulated" in done.stdout
    assert "    features (of the example): NAME_touched ['yes', 'no']" in done.stdout
    assert re.search(r"refused: source_kinds overfull from .*source kind 'overfull': row 0 sums to 2", done.stdout)


def test_evmap_run_uses_a_plugin_rule_and_refuses_the_broken_one(site, tmp_path):
    done = evmap_cli(site, "run", "--rule", "average", "--out", str(tmp_path / "a"), "--no-figures")
    assert done.returncode == 0, done.stderr
    assert "with rule 'average'" in done.stderr
    done = evmap_cli(site, "run", "--rule", "doubled", "--out", str(tmp_path / "b"), "--no-figures")
    assert done.returncode == 2
    assert "evmap: error: plugin 'doubled' of evmap-test-plugins 0.1" in done.stderr and "summing to 2" in done.stderr


def test_a_config_uses_a_plugin_source_kind(site, tmp_path):
    text = configs.path("paper.yaml").read_text()
    ramp = text[text.index("  lsl_length:\n") : text.index("  lsl_repeat:")]
    logistic = "  lsl_length:\n    kind: logistic\n    frame: existence\n    feature: length\n    focal: real\n"
    logistic += "    top: 0.6\n    middle: 0.2\n    scale: 0.05\n\n"
    (tmp_path / "logistic.yaml").write_text(text.replace(ramp, logistic))
    done = evmap_cli(
        site, "run", "--config", str(tmp_path / "logistic.yaml"), "--out", str(tmp_path / "o"), "--no-figures"
    )
    assert done.returncode == 0, done.stderr
    assert "0 real lost" in done.stderr
    (tmp_path / "overfull.yaml").write_text(
        text.replace(ramp, "  lsl_length: {kind: overfull, frame: existence, feature: length}\n")
    )
    done = evmap_cli(site, "config", "check", str(tmp_path / "overfull.yaml"))
    assert (
        done.returncode == 2 and "sources.lsl_length.kind: plugin 'overfull' of evmap-test-plugins 0.1" in done.stderr
    )


def test_plugins_are_read_when_a_config_names_a_kind_that_is_not_built_in(site, tmp_path):
    """Entry points are read on a config's first miss (rules, source and sensor kinds), not for every run."""
    (tmp_path / "bumper.yaml").write_text(
        configs.path("default.yaml").read_text() + "\nextra_sensors:\n  front: {kind: bumper}\n"
    )
    code = (
        "import sys; from evmap.sources.config import load_config; from evmap.sources.plugins import PLUGINS;"
        "sensors = load_config(sys.argv[1]).extra_sensors;"
        "print(len(PLUGINS), *(f'{name}={s.kind.origin}' for name, s in sensors.items()))"
    )
    env = {"PYTHONPATH": ":".join(p for p in [str(site), *sys.path] if p), "PATH": "/usr/bin:/bin"}
    found = {}
    for config in ("default", configs.path("examples/radar.yaml"), tmp_path / "bumper.yaml"):
        command = [sys.executable, "-c", code, str(config)]
        done = subprocess.run(command, check=False, capture_output=True, text=True, env=env)
        assert done.returncode == 0, done.stderr
        found[Path(config).stem] = done.stdout.strip()
    assert found["default"] == "0" and found["radar"] == "0 radar=builtin"  # a detector: built in
    assert found["bumper"] == "5 front=evmap-test-plugins 0.1 (evmap_test_plugins:BUMPER)"


@pytest.fixture
def plugin_module(site, monkeypatch):
    """The test package imported in this process; what it registers is removed afterwards."""
    monkeypatch.syspath_prepend(str(site))
    module = importlib.import_module("evmap_test_plugins")
    yield module
    for registry, name in ((RULES, "average"), (KINDS, "logistic"), (SENSOR_KINDS, "bumper")):
        registry.pop(name, None)


def test_the_plugin_rule_passes_the_rule_suite(plugin_module):
    import test_engine_rules as suite

    register_plugin("evmap.rules", "average", plugin_module.average, "tests")
    for prop in sorted(RULES["average"].properties):
        getattr(suite, f"test_{prop}")(name="average")
    suite.test_result_is_a_valid_mass_function(name="average")
    suite.test_bel_betp_pl_ordering_on_results(name="average")


def test_the_broken_rule_is_refused_by_name_and_not_registered(plugin_module):
    with pytest.raises(ValueError, match=r"rule 'doubled' refused: rule 'doubled' returned masses summing to 2"):
        register_plugin("evmap.rules", "doubled", plugin_module.doubled, "tests")
    assert "doubled" not in RULES


def test_plugin_kinds_are_checked_at_registration(plugin_module):
    register_plugin("evmap.source_kinds", "logistic", plugin_module.LOGISTIC, "tests")
    assert KINDS["logistic"].origin == "tests"
    with pytest.raises(ValueError, match="source kind 'overfull': row 0 sums to 2"):
        register_plugin("evmap.source_kinds", "overfull", plugin_module.OVERFULL, "tests")
    with pytest.raises(ValueError, match="must give a SourceKind named 'other' with an example"):
        register_plugin("evmap.source_kinds", "other", plugin_module.LOGISTIC, "tests")
    register_plugin("evmap.sensor_kinds", "bumper", plugin_module.BUMPER, "tests")
    assert SENSOR_KINDS["bumper"].declares("b", SENSOR_KINDS["bumper"].spec(kind="bumper")) == {
        "b_touched": ("yes", "no")
    }


def test_the_readme_shows_the_tested_plugin_package():
    """Every file of the test package appears whole in configs/examples/README.md: the documented example is tested."""
    readme = README.read_text()
    for path in (PACKAGE / "pyproject.toml", PACKAGE / "evmap_test_plugins" / "__init__.py"):
        assert path.read_text().strip() in readme, f"{path.name} is not shown whole in {README.name}"


def test_evmap_compare_uses_a_plugin_rule_and_refuses_the_broken_one(site, tmp_path):
    """`evmap compare --rules` runs the installed package's rule beside a built-in one; naming the broken one
    stops it before any world, by the rule's name, nothing written."""
    args = ["--worlds", "1", "--seed", "3", "--scheduler", "synchronous", "--configs", "paper"]
    done = evmap_cli(site, "compare", "--rules", "average,dempster", *args, "--out", str(tmp_path / "a"))
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader((tmp_path / "a" / "summary.csv").open()))
    assert sorted(r["rule"] for r in rows) == ["average", "dempster"]
    average = next(r for r in rows if r["rule"] == "average")
    assert 0 <= float(average["noise_recall"]) <= 1 and float(average["lines"]) > 0
    done = evmap_cli(site, "compare", "--rules", "average,doubled", *args, "--out", str(tmp_path / "b"))
    assert done.returncode == 2
    assert "plugin 'doubled' of evmap-test-plugins 0.1 (evmap_test_plugins:doubled) was refused" in done.stderr
    assert "summing to 2" in done.stderr and not (tmp_path / "b").exists()


def _average(sources, n):
    masks = np.unique(np.concatenate([s.masks for s in sources]))
    masses = np.zeros((len(masks), sources[0].masses.shape[1]))
    for s in sources:
        masses[np.searchsorted(masks, s.masks)] += s.masses
    return Stack(masks, masses / len(sources))


def _spoilt(how):
    """The average, spoilt ``how`` in every column but the first: it passes the registration's probes (one
    column each, or two) and fails on the first batch of three or more."""

    def rule(sources, n):
        out = _average(sources, n)
        masses = out.masses.copy()
        if masses.shape[1] > 2:
            if how == "negative":
                masses[-1, 1:] += 0.3
                masses[0, 1:] -= 0.3
            elif how == "nan":
                masses[0, 1:] = np.nan
            else:  # sum off 1
                masses[:, 1:] *= 1.01
        return Stack(out.masks, masses)

    return rule


def _with_empty(stack, empty):
    """``stack`` with mass ``empty`` moved to the empty set, the rest scaled down."""
    masks = np.union1d([0], stack.masks)
    masses = np.zeros((len(masks), stack.masses.shape[1]))
    masses[np.searchsorted(masks, stack.masks)] = (1 - empty) * stack.masses
    masses[0] += empty
    return Stack(masks, masses)


BROKEN = {
    "negative": lambda sources, n: Stack(
        sources[0].masks, np.where(np.arange(len(sources[0].masks))[:, None] == 0, -0.1, sources[0].masses * 1.1)
    ),
    "nan": lambda sources, n: Stack(sources[0].masks, np.full_like(sources[0].masses, np.nan)),
    "sum_off": lambda sources, n: Stack(sources[0].masks, sources[0].masses * 0.99),
    "closed_with_empty": lambda sources, n: _with_empty(sources[0], 0.2),
}


REFUSED = {
    "negative": r"returned mass -0\.1 on focal set 0",
    "nan": r"returned mass nan",
    "sum_off": r"returned masses summing to 0\.99",
    "closed_with_empty": r"claims a closed world but returned m\(∅\) = 0\.2",
}


@pytest.mark.parametrize("how", sorted(BROKEN))
def test_a_rule_that_is_not_a_mass_function_is_refused_at_registration_by_name(how):
    with pytest.raises(ValueError, match=rf"rule 'broken_{how}' refused: rule 'broken_{how}' {REFUSED[how]}"):
        register_plugin("evmap.rules", f"broken_{how}", BROKEN[how], "tests")
    assert f"broken_{how}" not in RULES


def test_an_open_world_rule_may_leave_mass_on_the_empty_set():
    leaky = BROKEN["closed_with_empty"]
    leaky.rule_options = {"open_world": True, "empty_set": "as_set"}
    try:
        register_plugin("evmap.rules", "leaky", leaky, "tests")
        result = combine_batch(np.array([[0.0, 0.6, 0.1, 0.3]]), np.array([[0.0, 0.2, 0.5, 0.3]]), rule="leaky")
        assert result.shape == (1, 4) and result[0, 0] > 0
    finally:
        RULES.pop("leaky", None)


@pytest.mark.parametrize("how", ["negative", "nan", "sum_off"])
def test_a_rule_that_breaks_after_registration_is_refused_by_name_on_every_path(how):
    """Registered (its probes pass), then caught on whatever path calls it: combine, combine_batch, a run."""
    name = f"late_{how}"
    register_plugin("evmap.rules", name, _spoilt(how), "tests")
    try:
        frame = Frame(["real", "noise"])
        a = MassFunction(frame, {"real": 0.6, "noise": 0.1, "real|noise": 0.3})
        assert combine(a, a, rule=name).frame == frame  # one mass function: fine
        rows = np.array([[0.0, 0.6, 0.1, 0.3], [0.0, 0.2, 0.5, 0.3], [0.0, 0.1, 0.1, 0.8]])
        with pytest.raises(MassError, match=rf"rule '{name}' returned"):
            combine_batch(rows, rows, rule=name)
        with pytest.raises(MassError, match=rf"rule '{name}' returned"):
            run_scenario(default_scenario(), load_config().with_rule(name))
    finally:
        RULES.pop(name)


def _registered(name, function, **options):
    """Register ``function`` as the plugin rule ``name`` with these ``rule_options``; whether it was."""
    function.rule_options = options
    try:
        register_plugin("evmap.rules", name, function, "tests")
    finally:
        registered = RULES.pop(name, None) is not None
    return registered


def test_a_rule_needing_mass_on_the_empty_set_is_probed_with_subnormal_mass_functions():
    from evidential.rules import bold

    assert _registered("my_bold", lambda sources, n: bold(sources, n), open_world=True, empty_set="required",
                       properties=["associative", "commutative", "idempotent"])  # fmt: skip


def test_a_claimed_property_the_probes_refute_is_refused_by_name():
    with pytest.raises(ValueError, match="rule 'avg' claims 'associative', but on probe mass functions "
                       r"\(a ⊕ b\) ⊕ c and a ⊕ b ⊕ c differ by"):  # fmt: skip
        _registered("avg", _average, properties=["commutative", "associative"], empty_set="conflict")
    with pytest.raises(ValueError, match="claims 'idempotent'"):
        _registered("vacuous", lambda s, n: Stack(np.array([(1 << n) - 1]), np.ones((1, s[0].masses.shape[1]))),
                    properties=["idempotent"])  # fmt: skip
    assert _registered("avg", _average, properties=["commutative"], empty_set="conflict")


def test_a_rule_failing_on_a_batch_or_on_three_sources_is_refused_at_registration():
    def pairs_only(sources, n):
        if len(sources) != 2:
            raise ValueError("two sources only")
        return _average(sources, n)

    def one_row(sources, n):
        if sources[0].masses.shape[1] > 1:
            raise IndexError("one row only")
        return _average(sources, n)

    with pytest.raises(ValueError, match="rule 'pairs' refused: two sources only"):
        _registered("pairs", pairs_only)
    with pytest.raises(ValueError, match="rule 'rows' refused: one row only"):
        _registered("rows", one_row)


def test_a_rule_name_that_compare_could_not_name_is_refused():
    with pytest.raises(ValueError, match=r"rule 'a,b': a rule's name may not hold a comma or a space"):
        _registered("a,b", _average)
