"""The figure of the YAML sensors: every segment coloured by what each declared sensor's feature said of it.

One panel per feature of the config's ``extra_sensors`` (``ir_return``,
``radar_detection``, ...), every pose's LSL segments drawn in the colour of their
category (a number's segments in the colour of its quartile over the run); where
the ground truth is known, sunlight phantoms are dashed. Each panel's counts are
those of ``report.json``'s ``sensors`` (``segments``). A config without declared
sensors has no such figure.
"""

from __future__ import annotations

import itertools

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import NDArray

from evmap.maps.app.figures import draw
from evmap.maps.app.figures.layout import finish, new_figure, title
from evmap.maps.app.figures.runs import contour_sensor, truth_known
from evmap.maps.app.figures.style import BLACK, BLUE, DASH, GREEN, ORANGE, PURPLE, VERMILION
from evmap.maps.app.run import Run

__all__ = ["sensor_features_figure", "sensor_panels"]

PALETTE = (GREEN, VERMILION, BLUE, ORANGE, PURPLE, BLACK)
"""Colours of a feature's categories (or a number's quartiles), in order; more categories cycle."""


def sensor_panels(run: Run) -> list[tuple[str, str, NDArray[np.str_], list[str]]]:
    """``(feature, sensor and kind, class of every raw segment, classes in order)`` per declared feature.

    A categorical feature's classes are its categories; a number's, its quartiles over the run's segments
    (``"58.7 to 96.1"``, ...).
    """
    store = run.map.segments
    raw = np.flatnonzero(store.raw)
    panels = []
    for name, sensor in run.config.extra_sensors.items():
        for feature, categories in sensor.declares().items():
            if feature not in store.features:
                continue
            values = store.features[feature][raw]
            if categories is None:
                classes, order = _quartiles(values.astype(float))
            else:
                classes, order = values.astype(str), list(categories)
            panels.append((feature, f"{name}, {sensor.kind.name}", classes, order))
    return panels


def _quartiles(values: NDArray[np.float64]) -> tuple[NDArray[np.str_], list[str]]:
    """Each value's quartile over ``values``, named by its range."""
    if not len(values):
        return np.zeros(0, dtype=str), []
    edges = np.unique(np.quantile(values, [0, 0.25, 0.5, 0.75, 1]))
    names = [f"{a:.3g} to {b:.3g}" for a, b in itertools.pairwise(edges)] or [f"{edges[0]:.3g}"]
    which = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, len(names) - 1)
    return np.array(names)[which], names


def sensor_features_figure(run: Run) -> Figure:
    """Every declared sensor feature's verdict on every pose's LSL segments, one panel per feature.

    >>> from evmap import configs
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.maps.app.run import run_scenario
    >>> fig = sensor_features_figure(run_scenario(default_scenario(), load_config(configs.path("examples/radar.yaml"))))
    >>> fig.axes[0].get_title(loc="left").splitlines()[1]
    'of 66 segments: detected 28, missed 24, out_of_view 14'
    """
    panels = sensor_panels(run)
    if not panels:
        raise ValueError(f"the config {run.config.name} declares no sensor (extra_sensors) whose features to draw")
    store = run.map.segments
    raw = np.flatnonzero(store.raw)
    p, q, truth = store.p[raw], store.q[raw], store.truth[raw]
    phantom = truth == "noise" if truth_known(truth) else np.zeros(len(raw), dtype=bool)
    fig, axes = new_figure(run, len(panels))
    handles: list[Line2D] = []
    for ax, (feature, sensor, classes, order) in zip(axes, panels):
        draw.walls(ax, run)
        draw.robots(ax, run)
        for k, name in enumerate(order):
            color = PALETTE[k % len(PALETTE)]
            mine = classes == name
            draw.segments(ax, p[mine & ~phantom], q[mine & ~phantom], color=color, lw=1.8, gid=f"{feature}-{name}")
            draw.segments(
                ax, p[mine & phantom], q[mine & phantom], color=color, lw=1.8, ls=DASH, gid=f"{feature}-{name}-phantom"
            )
            handles.append(Line2D([], [], lw=1.8, color=color, label=f"{feature}: {name}"))
        counts = ", ".join(f"{name} {int((classes == name).sum())}" for name in order)
        title(ax, f"{feature} ({sensor})", f"of {len(raw)} segments: {counts}")
    legend = [*draw.wall_handles(run), *handles]
    if phantom.any():
        legend.append(Line2D([], [], lw=1.8, ls=DASH, color=BLACK, label="sunlight phantom (dashed)"))
    finish(fig, legend, f"What the declared sensors said of the {contour_sensor(run)} segments, all poses")
    return fig
