"""A whole config file: frames, the combination rule, evidence sources, stages, parameters.

:func:`load_config` reads a YAML config (by default the packaged
``configs/paper.yaml``), validates it and builds every evidence source, and
returns an immutable :class:`Config`. A config is self-contained: no includes,
and no meaning in the order of keys. Its top-level keys:

``version``
    ``1`` (optional).
``frames``
    frame name -> ``{elements: [...], aliases: {alias: focal set}}``. A focal set
    is written as an element, elements joined by ``|`` (``real|noise``), an
    alias (``unknown: real|noise``), or ``""`` for the empty set.
``frame``
    the name of the frame of the map's beliefs; every stage's sources are on it.
``rule``
    the combination rule, a name in :data:`evidential.RULES` (default ``dempster``).
``sources``
    source name -> a section with ``kind`` (a name in :data:`evmap.sources.evidence.KINDS`:
    ``table``, ``ramp``, or a plugin's), ``frame``, ``feature`` and the kind's own keys.
``extra_sensors``
    sensor name -> a section with ``kind`` (a name in
    :data:`evmap.sources.sensor_kinds.SENSOR_KINDS`: ``range``, ``detector``,
    ``contour_property``, or a plugin's) and the kind's parameters: sensors beyond the
    sonar and the LSL, whose features (``NAME_...``) noise-elimination sources read.
``stages``
    which sources each stage of the pipeline combines: ``noise_elimination``,
    ``reinforcement``, ``unidentified`` (lists of source names).
``sensors``, ``rcd``, ``rcd_figure``, ``open_space``, ``noise``, ``merge``, ``corners``, ``matching``, ``unidentified``
    the parameters of the sensor models and of each stage, validated by the
    models of :mod:`evmap.sources.params`; a missing section takes the models' defaults.

Config files are untrusted input. Limits (:mod:`evmap.sources.config_model`): at most
``MAX_FRAMES`` frames of at most ``MAX_FRAME_ELEMENTS`` elements and ``MAX_ALIASES`` aliases
each, ``MAX_SOURCES`` sources, ``MAX_STAGE_SOURCES`` sources per stage, plus the
per-source limits of :mod:`evmap.sources.evidence` and the file size limit of
:mod:`evmap.sources.loading`. Every error is an :class:`~evmap.sources.loading.InputError`
naming the file, the key path and the problem; nothing is returned unless the
whole file is valid.

The data (the file's structure, its limits, the built
:class:`~evmap.sources.config_model.Config`) are in :mod:`evmap.sources.config_model`,
the building and checking in :mod:`evmap.sources.config_build`; import their names from there.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from evmap import configs
from evmap.sources.config_build import build_config
from evmap.sources.config_model import Config, ConfigFile
from evmap.sources.loading import InputError, read_document, validate

__all__ = ["PACKAGED_CONFIGS", "check_simulated_run", "config_from_data", "config_path", "load_config"]


PACKAGED_CONFIGS = ("paper", "default")
"""The configs evmap ships, by name: ``paper`` (the paper's method) and ``default`` (with the evidence beyond it)."""


def config_path(name: str | Path) -> Path:
    """The file of a config given by path, or by the name of a packaged config (:data:`PACKAGED_CONFIGS`).

    A packaged config's name (a string) is that config, whatever the current directory holds (an output
    directory named ``paper``, say); a file of that name is ``./paper``.

    >>> config_path("paper").name, config_path("configs/paper.yaml").as_posix()
    ('paper.yaml', 'configs/paper.yaml')
    """
    path = Path(name)
    if isinstance(name, str) and name in PACKAGED_CONFIGS:
        return configs.path(f"{name}.yaml")
    if not path.exists() and not path.suffix:
        raise InputError(
            f"{name}: no such config file, nor a packaged config (those are {', '.join(PACKAGED_CONFIGS)})"
        )
    return path


def load_config(path: str | Path | None = None) -> Config:
    """Read, validate and build a config file (a path, or a packaged config's name: ``paper``, ``default``);
    ``None`` reads the packaged ``configs/paper.yaml``.

    Raises
    ------
    evmap.sources.loading.InputError
        naming the file, the key path and the problem, if anything in the file is wrong.

    Examples
    --------
    >>> cfg = load_config()
    >>> cfg.rule, cfg.noise.threshold, cfg.merge.distance
    ('dempster', 0.5, 0.05)
    >>> cfg.sources["lsl_length"].masses({"length": [0.2]}).round(3).tolist()
    [[0.0, 0.3, 0.0, 0.7]]
    >>> sorted(load_config("default").stages) == sorted(cfg.stages)
    True
    """
    document = read_document(configs.path("paper.yaml") if path is None else config_path(path))
    return build_config(document.validate(ConfigFile), document.name, document)


def config_from_data(data: Any, name: str) -> Config:
    """Validate and build a config from parsed data (a YAML file's content, or :meth:`Config.to_data`)."""
    return build_config(validate(ConfigFile, data, name), name)


def check_simulated_run(config: Config) -> None:
    """Refuse a config that ``evmap run`` cannot use on a simulated scenario.

    A source of the noise-elimination (or repeated-observation) stage may read a feature
    that an observation brings; no built-in sensor computes one, so a run on a simulated
    scenario would fail half-way. :attr:`Config.warnings` says the same for ``config check``.

    Raises
    ------
    InputError
        naming the file, the key path of the source's ``feature`` and the feature.

    >>> check_simulated_run(load_config())
    >>> check_simulated_run(load_config(configs.path("examples/infrared.yaml")))  # the sensor `ir` gives ir_return
    >>> data = load_config(configs.path("examples/infrared.yaml")).to_data()
    >>> check_simulated_run(config_from_data({**data, "extra_sensors": {}}, "no_ir"))
    Traceback (most recent call last):
    ...
    evmap.sources.loading.InputError: no_ir: sources.infrared.feature: reads feature 'ir_return', ...
    """
    if config.warnings:
        raise InputError(config.warnings[0])
