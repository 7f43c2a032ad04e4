"""Rules, source kinds and sensor kinds from other installed packages, through entry points.

A package adds to evmap by declaring entry points in its ``pyproject.toml``::

    [project.entry-points."evmap.rules"]
    trimmed_mean = "my_package.rules:trimmed_mean"       # a function (sources, n) -> Stack
    [project.entry-points."evmap.source_kinds"]
    logistic = "my_package.kinds:LOGISTIC"               # an evmap.sources.evidence.SourceKind
    [project.entry-points."evmap.sensor_kinds"]
    bumper = "my_package.sensors:BUMPER"                 # an evmap.sources.sensor_kinds.SensorKind

The entry point's name is the name of the rule or kind. A rule function may carry
``rule_options``, a dict of the keyword arguments of
:func:`evidential.rules.register_rule` (``properties``, ``open_world``,
``nondogmatic``, ``empty_set``). :func:`load_plugins` loads every entry point
once, on first use (a config naming a rule or kind that is not built in, the
sensor kinds, ``evmap rules``, ``evmap sources``), and registers each after
checking it:

- a rule is registered with ``builtin=False`` (each result it returns is checked
  to be a mass function, naming the rule, whatever calls it), then combines two
  fixed pairs of mass functions; a rule that fails is removed again and refused;
- a source kind is registered by :func:`evmap.sources.evidence.register_kind`,
  which builds its example and runs it through the conformance checks;
- a sensor kind by :func:`evmap.sources.sensor_kinds.register_sensor_kind`.

A plugin that fails to load or to register is not an error of evmap: it is kept
in :data:`PLUGINS` with its problem (``evmap rules`` and ``evmap sources`` show
it), and naming it in a config or on the command line raises its problem.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Any

from evidential import RULES, register_rule
from evmap.sources.conformance import check_rule_function
from evmap.sources.evidence import SourceKind, register_kind
from evmap.sources.sensor_kinds import SENSOR_KINDS, SensorKind, register_sensor_kind

__all__ = ["GROUPS", "PLUGINS", "Plugin", "load_plugins", "origin_of", "refusal", "register_plugin", "sensor_kinds"]

GROUPS: tuple[str, ...] = ("evmap.rules", "evmap.source_kinds", "evmap.sensor_kinds")
"""The entry-point groups evmap reads."""

PLUGINS: list[Plugin] = []
"""Every entry point loaded so far, registered or refused, in the order loaded."""

_LOADED: list[bool] = []  # one entry once the entry points have been read
_ORIGINS: dict[tuple[str, str], str] = {}  # (group, name) -> origin of a plugin rule


@dataclass(frozen=True)
class Plugin:
    """One entry point: its group, name, target (``module:object``), package, and its problem if refused."""

    group: str
    name: str
    target: str
    package: str
    problem: str | None = None

    @property
    def origin(self) -> str:
        """Where it comes from, e.g. ``evmap-test-plugins 0.1 (evmap_test_plugins:mean_rule)``."""
        return f"{self.package} ({self.target})"


def load_plugins() -> tuple[Plugin, ...]:
    """Load and register every entry point of :data:`GROUPS`, the first time only; return them all.

    >>> all(p.group in GROUPS for p in load_plugins())
    True
    """
    if not _LOADED:
        _LOADED.append(True)
        installed = entry_points()  # one scan of the installed distributions for every group
        for group in GROUPS:
            for point in sorted(installed.select(group=group), key=lambda e: e.name):
                PLUGINS.append(_load(group, point))
    return tuple(PLUGINS)


def _load(group: str, point: EntryPoint) -> Plugin:
    package = f"{point.dist.name} {point.dist.version}" if point.dist is not None else "an unknown package"
    plugin = Plugin(group, point.name, point.value, package)
    try:
        register_plugin(group, point.name, point.load(), plugin.origin)
    except Exception as exc:  # noqa: BLE001 - a broken plugin is reported, never fatal to evmap
        return dataclasses.replace(plugin, problem=f"{type(exc).__name__}: {exc}")
    return plugin


def sensor_kinds(wanted: Iterable[object] | None = None) -> dict[str, SensorKind]:
    """Every sensor kind: the built-in ones (:mod:`evmap.sources.sim.sensor_models`, which registers them with
    their simulators) and those of installed plugins (loaded once, on first use). Given the kinds ``wanted``
    (a config's), the plugins are loaded only if one of them is not built in, as for rules and source kinds.

    >>> sorted(sensor_kinds())[:3]
    ['contour_property', 'detector', 'range']
    """
    import evmap.sources.sim.sensor_models  # noqa: F401 - registers the built-in kinds

    if wanted is None or any(kind not in SENSOR_KINDS for kind in wanted):
        load_plugins()
    return SENSOR_KINDS


def register_plugin(group: str, name: str, obj: Any, origin: str) -> None:
    """Check and register one rule, source kind or sensor kind of an entry-point ``group``.

    Raises
    ------
    ValueError
        naming the rule or kind and what is wrong with it.
    """
    registrars: dict[str, Callable[[str, Any, str], None]] = {
        "evmap.rules": _register_rule,
        "evmap.source_kinds": _register_source_kind,
        "evmap.sensor_kinds": _register_sensor_kind,
    }
    if group not in registrars:
        raise ValueError(f"unknown entry-point group {group!r}; evmap reads {', '.join(GROUPS)}")
    registrars[group](name, obj, origin)


def _register_rule(name: str, function: Any, origin: str) -> None:
    if not callable(function):
        raise TypeError(f"rule {name!r}: the entry point gives {type(function).__name__}, not a function")
    if not name or any(c == "," or c.isspace() for c in name):
        raise ValueError(f"rule {name!r}: a rule's name may not hold a comma or a space (--rules lists names so)")
    options = dict(getattr(function, "rule_options", {}))
    register_rule(name, builtin=False, **options)(function)
    try:
        check_rule_function(name)
    except Exception as exc:  # noqa: BLE001 - whatever the rule raised, it is refused, and says why
        del RULES[name]
        raise ValueError(f"rule {name!r} refused: {exc}") from None
    _ORIGINS[("evmap.rules", name)] = origin


def _register_source_kind(name: str, kind: Any, origin: str) -> None:
    if not isinstance(kind, SourceKind) or kind.name != name or kind.example is None:
        raise ValueError(f"source kind {name!r}: the entry point must give a SourceKind named {name!r} with an example")
    register_kind(name, kind.spec, kind.example, origin)(kind.build)


def _register_sensor_kind(name: str, kind: Any, origin: str) -> None:
    import evmap.sources.sim.sensor_models  # noqa: F401 - the built-in kinds first: a plugin cannot take their names

    if not isinstance(kind, SensorKind) or kind.name != name:
        raise ValueError(f"sensor kind {name!r}: the entry point must give a SensorKind named {name!r}")
    register_sensor_kind(dataclasses.replace(kind, origin=origin))


def origin_of(group: str, name: str) -> str:
    """Where a registered rule or kind comes from: ``builtin``, a plugin's origin, or ``Python``.

    >>> origin_of("evmap.rules", "dempster"), origin_of("evmap.source_kinds", "table")
    ('builtin', 'builtin')
    """
    if group == "evmap.rules":
        rule = RULES[name]
        return "builtin" if rule.builtin else _ORIGINS.get((group, name), "registered from Python")
    from evmap.sources.evidence import KINDS

    kinds: dict[str, Any] = KINDS if group == "evmap.source_kinds" else SENSOR_KINDS
    return str(kinds[name].origin)


def refusal(group: str, name: str) -> str | None:
    """Why the plugin ``name`` of ``group`` was refused, naming its origin; ``None`` if none was.

    >>> refusal("evmap.rules", "no such rule") is None
    True
    """
    for plugin in load_plugins():
        if plugin.group == group and plugin.name == name and plugin.problem is not None:
            return f"plugin {name!r} of {plugin.origin} was refused: {plugin.problem}"
    return None
