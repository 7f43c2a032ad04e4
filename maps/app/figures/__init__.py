"""The figures of the paper's pipeline (Figs. 2 and 4-7), one matplotlib figure per stage.

Each function takes a :class:`~evmap.maps.app.run.Run` and returns a
:class:`matplotlib.figure.Figure` on an Agg canvas (no pyplot). Units are
metres, axes have equal aspect; the true walls of a simulated world are drawn
dashed and labelled "true walls" (LSL-transparent ones, glass and mirrors, in
blue; sonar-absorbing ones in brown). A run of measured data (no world, ground
truth of the segments unknown) is drawn without them.

Every title states what its figure counts, and where ``report.json`` has that
number, the title's equals it:

=============================  ===========================  =========  =================================================
file                           function                     paper      what it shows and counts
=============================  ===========================  =========  =================================================
``fig2_sonar_scan_rcds``       :func:`sonar_scan_figure`    Fig. 2     one pose's sonar scan and its RCDs at the figure
                                                                       tolerance ``config.rcd_figure`` (1 cm, 10°), and
                                                                       how many the matching and the open space use
``fig4_lsl_lines``             :func:`lsl_lines_figure`     Fig. 4     every pose's LSL segments, real and sunlight
                                                                       phantoms (``lsl_segments``, ``noise_segments``)
``fig5_open_space``            :func:`open_space_figure`    Fig. 5     (a) one pose's raw range scan, multiple
                                                                       reflections marked; (b) the open space of its
                                                                       primitive RCDs (every width)
``fig6a_noise_eliminated``     :func:`noise_figure`         Sec. III   every pose's segments kept and eliminated (faint)
                                                                       against the open space (``noise_eliminated``,
                                                                       ``real_eliminated``, ``lines_before_merge``)
``fig6b_merged_corners``       :func:`merged_map_figure`    Sec. III   merged lines over the surviving segments, corners
                                                                       and free ends (``lines_after_merge``,
                                                                       ``corners``)
``fig6c_rcd_matching``         :func:`rcd_matching_figure`  Fig. 6     one pose's matching RCDs (at least
                                                                       ``config.rcd.min_width_deg``): (a) actual, (b)
                                                                       simulated from the map, the matched pairs; with
                                                                       several poses the headline gives the totals
                                                                       (``rcds_actual``, ``rcds_simulated``,
                                                                       ``rcds_matched``)
``fig7_final_map``             :func:`final_map_figure`     Fig. 7     the final map, line width by Bel(real),
                                                                       landmarks emphasised, ``unidentified`` objects
``fig8_sensor_features``       ``sensor_features_figure``   (new)      what each YAML sensor's feature said of every
                                                                       segment (report's ``sensors``); only for a
                                                                       config that declares sensors
``fig9_line_fit``              :func:`line_fit_figure`      (new)      a robot log's returned laser rays, explained by
                                                                       a segment of their scan or not, under the final
                                                                       map (report's ``line_fit``); only for a log
=============================  ===========================  =========  =================================================

:func:`write_figures` writes them as ``png`` (150 dpi), ``svg`` or ``pdf``
files: the scan figures (Figs. 2, 5, 6c) once per pose, pose ``k > 0`` as
``<name>_pose<k>.<fmt>``, the others once. :data:`FIGURE_FILES` maps the PNG
file names of pose 0 to the functions.

Artists carry ``gid`` tags (``"rcd-arcs"``, ``"lsl-phantom"``, ``"landmark-lines"``,
...) so tests and users can find what a figure drew. Importing this package does
not import matplotlib: the figure modules load on first use.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from evmap.maps.app.figures.catalogue import FIGURE_FILES
    from evmap.maps.app.figures.files import FORMATS, write_figures
    from evmap.maps.app.figures.line_fit import line_fit_figure
    from evmap.maps.app.figures.line_map import final_map_figure, merged_map_figure
    from evmap.maps.app.figures.lsl import lsl_lines_figure, noise_figure
    from evmap.maps.app.figures.matching import rcd_matching_figure
    from evmap.maps.app.figures.scan import open_space_figure, sonar_scan_figure
    from evmap.maps.app.figures.sensors import sensor_features_figure

__all__ = [
    "FIGURE_FILES",
    "FORMATS",
    "final_map_figure",
    "line_fit_figure",
    "lsl_lines_figure",
    "merged_map_figure",
    "noise_figure",
    "open_space_figure",
    "rcd_matching_figure",
    "sensor_features_figure",
    "sonar_scan_figure",
    "write_figures",
]

HOMES = {
    "FIGURE_FILES": "catalogue",
    "FORMATS": "files",
    "write_figures": "files",
    "final_map_figure": "line_map",
    "line_fit_figure": "line_fit",
    "merged_map_figure": "line_map",
    "lsl_lines_figure": "lsl",
    "noise_figure": "lsl",
    "rcd_matching_figure": "matching",
    "open_space_figure": "scan",
    "sonar_scan_figure": "scan",
    "sensor_features_figure": "sensors",
}
"""Public name -> the module of this package that defines it, imported when the name is first used."""


def __getattr__(name: str) -> Any:
    """A public name, from its module (imported now: matplotlib comes with the figure modules)."""
    if name not in HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{HOMES[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
