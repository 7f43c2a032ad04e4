"""What ``evmap config check`` and ``evmap config explain`` print: a config as it was understood."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel

from evidential import Frame, TotalConflictError, combine_batch
from evmap.sources.config_model import PARAMETER_SECTIONS, Config, SensorsParams

__all__ = ["MAX_EXPLAIN_ROWS", "describe_config", "explain_value"]

MAX_EXPLAIN_ROWS = 1000
"""Most combinations ``evmap config explain`` prints for one stage."""


def describe_config(cfg: Config) -> str:
    """The config as understood: frames, sources with their masses at example values, stages, parameters."""
    combined = {n for names in cfg.stages.values() for n in names}
    unused = [
        f"{cfg.name}: sources.{n}: in no stage, so it takes no part in a run (list it under stages)"
        for n in cfg.sources
        if n not in combined
    ]
    out = [f"{cfg.name}: valid", *[f"warning: {w}" for w in (*cfg.warnings, *unused)], f"rule: {cfg.rule}", ""]
    for name, frame in cfg.frames.items():
        role = " (the map's frame)" if name == cfg.frame_name else ""
        out.append(f"frame {name}{role}: {', '.join(frame.elements)}")
        for alias, written in cfg.aliases[name].items():
            out.append(f"  alias {alias} = {_label(frame, frame.mask(written))}")
    readers: dict[str, list[str]] = {}
    for name, source in cfg.sources.items():
        readers.setdefault(source.feature, []).append(name)
    for sensor in cfg.extra_sensors.values():
        out += ["", *sensor.describe(readers)]
    for name in cfg.sources:
        out += ["", *_describe_source(cfg, name)]
    out += ["", f"stages (combined by {cfg.rule}):"]
    out += [f"  {stage}: {', '.join(names)}" for stage, names in cfg.stages.items()]
    out += ["", "parameters:"]
    for section in PARAMETER_SECTIONS:
        model = getattr(cfg, section)
        if isinstance(model, SensorsParams):
            out += [f"  {section}.{sensor}: {_fields(params)}" for sensor, params in model]
        else:
            out.append(f"  {section}: {_fields(model)}")
    return "\n".join(out)


def explain_value(cfg: Config, name: str, value: str) -> str:
    """What the source ``name`` gives for one feature ``value``, and what it combines to in its stages."""
    if name not in cfg.sources:
        raise ValueError(f"unknown source {name!r} in config {cfg.name}; its sources are: {', '.join(cfg.sources)}")
    source = cfg.sources[name]
    m = source.masses({source.feature: [value]})
    out = [
        (
            f"{source.name} ({getattr(source, 'kind', type(source).__name__)} on {source.feature!r}), "
            f"{source.feature} = {value}:"
        ),
        f"  {_masses(source.frame, m[0])}",
    ]
    stages = [stage for stage, names in cfg.stages.items() if source.name in names]
    if not stages:
        out.append(f"  (no stage combines {source.name})")
    for stage in stages:
        out += ["", *_explain_stage(cfg, stage, source.name, m)]
    return "\n".join(out)


def _explain_stage(cfg: Config, stage: str, name: str, m: NDArray[np.float64]) -> list[str]:
    """The source's masses ``m`` (one row) combined with every row of the stage's other sources."""
    others = [s for s in cfg.stage_sources(stage) if s.name != name]
    if not others:
        return [f"stage {stage}: {name} is its only source; its masses are combined into each object's stored belief"]
    total = math.prod(len(getattr(s, "examples", ())) for s in others)
    if not total:
        return [f"stage {stage}: its other sources show no example rows"]
    rows = list(itertools.islice(itertools.product(*(s.examples for s in others)), MAX_EXPLAIN_ROWS))
    # one batch: every combination of the other sources' rows, with the explained source
    columns = [np.array([row[i] for row in rows]) for i in range(len(others))]
    masses = [s.masses({s.feature: col}) for s, col in zip(others, columns)]
    batch = [np.repeat(m, len(rows), axis=0), *masses]
    fused = _combine_rows(batch, cfg.rule)
    k = combine_batch(*batch, rule="conjunctive")[:, 0]  # K: the conjunctive mass on the empty set
    frame = cfg.frame
    decide = stage == "noise_elimination" and "noise" in frame.elements
    out = [f"stage {stage}, combined by {cfg.rule} with each row of {', '.join(s.name for s in others)}:"]
    for i, row in enumerate(rows):
        given = "; ".join(
            f"{s.name} ({s.feature} = {value}): {_masses(frame, mass[i])}"
            for s, value, mass in zip(others, row, masses)
        )
        if fused[i] is None:
            out += [f"  with {given}", f"    -> total conflict (K = {k[i]:.6g}): {cfg.rule} is undefined"]
            continue
        line = f"    -> {_masses(frame, fused[i])}; K = {k[i]:.6g}"
        if decide:
            noise = fused[i][frame.mask("noise")]
            verdict = "removed" if noise > cfg.noise.threshold else "kept"
            relation = ">" if noise > cfg.noise.threshold else "<="
            line += f"; m(noise) = {noise:.6g} {relation} {cfg.noise.threshold:g}: {verdict}"
        out += [f"  with {given}", line]
    if total > len(rows):
        out.append(f"  (the first {len(rows)} of {total} rows)")
    return out


def _combine_rows(batch: list[NDArray[np.float64]], rule: str) -> list[NDArray[np.float64] | None]:
    """Combine a batch row by row under ``rule``; ``None`` for a row in total conflict."""
    try:
        return list(combine_batch(*batch, rule=rule))
    except TotalConflictError:  # find which rows: combine them one at a time
        rows: list[NDArray[np.float64] | None] = []
        for i in range(len(batch[0])):
            try:
                rows.append(combine_batch(*(m[i : i + 1] for m in batch), rule=rule)[0])
            except TotalConflictError:
                rows.append(None)
        return rows


def _describe_source(cfg: Config, name: str) -> list[str]:
    """A source as understood: its kind, frame, feature, and its masses at its example values."""
    source = cfg.sources[name]
    frame_name = next(k for k, f in cfg.frames.items() if f == source.frame)
    out = [f"source {name} (frame {frame_name}): {getattr(source, 'summary', type(source).__name__)}"]
    examples = list(getattr(source, "examples", ()))
    if examples:
        masses = source.masses({source.feature: np.array(examples)})
        width = max(len(str(e)) for e in examples)
        out += [
            f"  {source.feature} = {e!s:<{width}}  {_masses(source.frame, row)}" for e, row in zip(examples, masses)
        ]
    return out


def _masses(frame: Frame, row: NDArray[np.float64]) -> str:
    """Non-zero masses of one mass function, e.g. ``real 0.3, real|noise 0.7``."""
    return ", ".join(f"{_label(frame, b)} {row[b]:.6g}" for b in np.flatnonzero(row)) or "(no mass)"


def _label(frame: Frame, mask: int) -> str:
    """A focal set as written in YAML: names in frame order joined by ``|``; ``""`` the empty set."""
    return frame.label(mask) or '""'


def _fields(model: BaseModel) -> str:
    """A parameter model as ``key=value`` pairs, values spelt as YAML has them (``true``, ``null``)."""
    return " ".join(f"{k}={json.dumps(v) if isinstance(v, bool) or v is None else v}" for k, v in model)
