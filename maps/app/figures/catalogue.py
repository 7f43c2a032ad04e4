"""Which figures a run has, under which file names (imports every figure, so matplotlib)."""

from __future__ import annotations

from collections.abc import Callable

from matplotlib.figure import Figure

from evmap.maps.app.figures.line_fit import line_fit_figure
from evmap.maps.app.figures.line_map import final_map_figure, merged_map_figure
from evmap.maps.app.figures.lsl import lsl_lines_figure, noise_figure
from evmap.maps.app.figures.matching import rcd_matching_figure
from evmap.maps.app.figures.scan import open_space_figure, sonar_scan_figure
from evmap.maps.app.figures.sensors import sensor_features_figure

__all__ = ["FIGURE_FILES", "LOG_FIGURES", "SCAN_FIGURES", "SENSOR_FIGURES"]

FIGURE_FILES: dict[str, Callable[..., Figure]] = {
    "fig2_sonar_scan_rcds.png": sonar_scan_figure,
    "fig4_lsl_lines.png": lsl_lines_figure,
    "fig5_open_space.png": open_space_figure,
    "fig6a_noise_eliminated.png": noise_figure,
    "fig6b_merged_corners.png": merged_map_figure,
    "fig6c_rcd_matching.png": rcd_matching_figure,
    "fig7_final_map.png": final_map_figure,
}
"""File name (of pose 0, as PNG) -> figure function, in the paper's order (what ``write_figures`` writes)."""

SENSOR_FIGURES: dict[str, Callable[..., Figure]] = {"fig8_sensor_features.png": sensor_features_figure}
"""The figures of the YAML sensors, written after the others for a config that declares sensors."""

LOG_FIGURES: dict[str, Callable[..., Figure]] = {"fig9_line_fit.png": line_fit_figure}
"""The figures of a run over a robot log, written after the others."""

SCAN_FIGURES = (sonar_scan_figure, open_space_figure, rcd_matching_figure)
"""The figures of one sonar scan: one file per pose. The others show every pose in one file."""
