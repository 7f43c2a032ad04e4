"""``evmap rules`` and ``evmap sources``: what the installed evmap and its plugins offer, and the refused plugins."""

from __future__ import annotations

import argparse

__all__ = ["list_rules", "list_sources"]


def list_rules(args: argparse.Namespace) -> int:
    """``evmap rules``: every combination rule and where it comes from; refused plugin rules and why."""
    from evidential import RULES
    from evmap.sources.plugins import load_plugins, origin_of

    refused = [p for p in load_plugins() if p.group == "evmap.rules" and p.problem]
    out = [
        "rules (`rule:` in a config, `evmap run --rule NAME`), the properties each claims, and what it does with",
        "mass on the empty set in a source (empty set: refuse, conflict, as_set, or required: m(∅) > 0 in every",
        "source, which evmap's sources never give, so such a rule is for the engine, not for a config):",
    ]
    width = max(map(len, RULES))
    for name in sorted(RULES):
        rule = RULES[name]
        claimed = ", ".join(sorted(rule.properties)) or "no properties claimed"
        out.append(f"  {name:<{width}}  {origin_of('evmap.rules', name)}; {claimed}; empty set: {rule.empty_set}")
    out += [f"refused: {p.name} from {p.origin}: {p.problem}" for p in refused]
    print("\n".join(out))
    return 0


def list_sources(args: argparse.Namespace) -> int:
    """``evmap sources``: every kind of evidence source and of sensor, where it comes from; refused plugins."""
    from evmap.sources.evidence import KINDS
    from evmap.sources.plugins import load_plugins, origin_of, sensor_kinds

    groups = ("evmap.source_kinds", "evmap.sensor_kinds")
    refused = [p for p in load_plugins() if p.group in groups and p.problem]
    sensors = sensor_kinds()
    out = ["source kinds (`kind:` of a section under `sources`):"]
    out += [f"  {name}  {origin_of('evmap.source_kinds', name)}" for name in sorted(KINDS)]
    out.append("sensor kinds (`kind:` of a section under `extra_sensors`; NAME is the sensor's name):")
    for name in sorted(sensors):
        out += sensors[name].describe()
    out += [f"refused: {p.group.removeprefix('evmap.')} {p.name} from {p.origin}: {p.problem}" for p in refused]
    print("\n".join(out))
    return 0
