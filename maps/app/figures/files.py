"""Writing a run's figures into a directory, in one format, one file per figure and per scan figure's pose.

This module loads matplotlib only when a figure is written, so that importing
it (as ``evmap``'s command line does) stays fast.
"""

from __future__ import annotations

from pathlib import Path

from evmap.maps.app.run import Run

__all__ = ["FORMATS", "figure_name", "write_figures"]

FORMATS = ("png", "svg", "pdf")
"""The formats figures are written in."""

METADATA = {"png": {}, "svg": {"Date": None}, "pdf": {"CreationDate": None}}
"""No creation date in the files, so that a run's figures are the same each time."""


def figure_name(name: str, fmt: str, pose: int | None = None) -> str:
    """The file of figure ``name`` (a key of ``FIGURE_FILES``) in format ``fmt``, for pose ``pose``.

    Pose 0 (and a figure showing every pose) keeps the contract's name; another
    pose ``k`` of a scan figure adds ``_pose<k>``.

    >>> figure_name("fig2_sonar_scan_rcds.png", "svg"), figure_name("fig2_sonar_scan_rcds.png", "png", 2)
    ('fig2_sonar_scan_rcds.svg', 'fig2_sonar_scan_rcds_pose2.png')
    """
    stem = Path(name).stem
    return f"{stem}_pose{pose}.{fmt}" if pose else f"{stem}.{fmt}"


def write_figures(run: Run, directory: str | Path, fmt: str = "png", *, dpi: int = 150) -> list[Path]:
    """Write every figure of ``FIGURE_FILES`` into ``directory`` (which must exist); return their paths.

    Parameters
    ----------
    run : the run to draw.
    directory : where the files go.
    fmt : one of :data:`FORMATS`; it replaces the ``.png`` of the names.
    dpi : resolution of PNG files (and of the raster parts of the others).

    Returns
    -------
    The paths written, in the order of ``FIGURE_FILES``: the scan figures (Figs.
    2, 5 and 6c) once per pose (see :func:`figure_name`), the others once. A run
    over a robot log (no world) has no scan figures. A config that declares YAML
    sensors adds ``SENSOR_FIGURES`` (``fig8_sensor_features``), a run over a log ``LOG_FIGURES``
    (``fig9_line_fit``).

    >>> import tempfile
    >>> from evmap.sources.config import load_config
    >>> from evmap.sources.sim.scenario import default_scenario
    >>> from evmap.maps.app.run import run_scenario
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     [path.name for path in write_figures(run_scenario(default_scenario(), load_config()), tmp)][:2]
    ['fig2_sonar_scan_rcds.png', 'fig4_lsl_lines.png']
    """
    if fmt not in FORMATS:
        raise ValueError(f"figure format must be one of {', '.join(FORMATS)}; got {fmt!r}")
    from evmap.maps.app.figures.catalogue import (  # loads matplotlib
        FIGURE_FILES,
        LOG_FIGURES,
        SCAN_FIGURES,
        SENSOR_FIGURES,
    )

    directory = Path(directory)
    paths = []
    catalogue = {
        **FIGURE_FILES,
        **(SENSOR_FIGURES if run.config.extra_sensors else {}),
        **(LOG_FIGURES if run.log is not None else {}),
    }
    for name, make in catalogue.items():
        if make in SCAN_FIGURES and run.log is not None:
            continue  # a log's scans are thousands: its map figures show them all, no figure per scan
        for pose in range(len(run.observations)) if make in SCAN_FIGURES else [None]:
            fig = make(run) if pose is None else make(run, pose)
            path = directory / figure_name(name, fmt, pose)
            fig.savefig(path, format=fmt, dpi=dpi, metadata=METADATA[fmt])
            paths.append(path)
    return paths
