"""The configs a comparison runs: names, paths, the paper's config plus a new source, and the ablation.

``evmap compare --configs`` takes a comma-separated list of configs, each one of

- a config file's path, or a packaged config's name (``paper``, ``default``);
- ``BASE+SOURCE[+SOURCE...]``: the config ``BASE`` with each noise-elimination
  source ``SOURCE`` of the default config added to the stage where the default
  config uses it (``paper+contour_free``: the paper's method and the contour's
  free space);
- ``ablation``: :data:`ABLATION`, the paper's method, the paper's method plus
  each source of :data:`NEW_SOURCES` alone, and the default config.

Workers receive these names, not the configs, and build each once
(:func:`resolve_config`).

>>> config_names("paper, default")
('paper', 'default')
>>> config_names("ablation")[1:4]
('paper+sonar_forward', 'paper+contour_free', 'paper+lsl_persistence')
>>> resolve_config("paper+contour_free").stages["noise_elimination"]
('sonar_open_space', 'lsl_length', 'contour_free')
"""

from __future__ import annotations

import functools
from pathlib import Path

from evmap.sources.config import check_simulated_run, config_from_data, load_config
from evmap.sources.config_model import Config

__all__ = ["ABLATION", "NEW_SOURCES", "config_names", "resolve_config", "sensing_key"]

NEW_SOURCES = ("sonar_forward", "contour_free", "lsl_persistence")
"""The noise-elimination sources of the default config that the paper does not have."""

ABLATION = ("paper", *(f"paper+{source}" for source in NEW_SOURCES), "default")
"""What ``--configs ablation`` runs: what each new source adds to the paper's method, and all of them."""


def config_names(text: str) -> tuple[str, ...]:
    """The configs named by ``--configs`` (module doc), each checked by building it.

    Raises
    ------
    ValueError
        naming the config that cannot be built, or a name given twice.
    """
    names: list[str] = []
    for item in (part.strip() for part in text.split(",")):
        if not item:
            raise ValueError(f"--configs: need one or more comma-separated configs, got {text!r}")
        names += ABLATION if item == "ablation" else [item]
    if len(set(names)) < len(names):
        raise ValueError(f"--configs: a config is named twice in {names}")
    for name in names:
        resolve_config(name)
    return tuple(names)


@functools.lru_cache(maxsize=16)
def resolve_config(name: str) -> Config:
    """The config ``name`` stands for (module doc), built once per process.

    Raises
    ------
    evmap.sources.loading.InputError
        naming the file and key path of a bad config file, or of a source that reads a feature no sensor
        computes (:func:`~evmap.sources.config.check_simulated_run`).
    ValueError
        naming a source the default config does not have.
    """
    config = load_config(name) if Path(name).exists() or "+" not in name else _with_sources(name)
    check_simulated_run(config)  # the worlds are simulated: a source reading a feature none brings fails here
    return config


def _with_sources(name: str) -> Config:
    """``BASE+SOURCE+...``: the config BASE with those sources of the default config added to their stages."""
    base, *added = name.split("+")
    data = load_config(base).to_data()
    default = load_config("default").to_data()
    for source in added:
        stage = next((s for s, used in default["stages"].items() if source in used), None)
        if stage is None:
            known = sorted({s for used in default["stages"].values() for s in used})
            raise ValueError(f"--configs: {name}: the default config has no source {source!r} (it has {known})")
        data["sources"][source] = default["sources"][source]
        if source not in data["stages"].get(stage, []):
            data["stages"][stage] = [*data["stages"].get(stage, []), source]
    return config_from_data(data, name)


def sensing_key(config: Config) -> str:
    """What the simulated sensing of a world depends on in a config: configs with one key share the scans."""
    data = config.to_data()
    return repr((data.get("sensors"), data.get("extra_sensors")))
