"""Figure builders (plotly) and the one place figures are written to disk.

Builders take datasets and return ``plotly.graph_objects.Figure``; notebooks call them and
:func:`save_figure`, which writes interactive HTML that opens offline and a PNG (kaleido's bundled
renderer: no browser to install). One module per topic: :mod:`.charts` (generic lines and bars), :mod:`.propagation`,
:mod:`.dop` (notebook 02), :mod:`.gps` (03), :mod:`.deltav` (04), :mod:`.campaign` (06),
:mod:`.pareto` (07), :mod:`.validation` (06-07), :mod:`.design_life` and :mod:`.frozen` (08), :mod:`.benchmark` (10), and :mod:`.export` (HTML and PNG writing). Figures import only foundations,
:mod:`lnss_lib.outputs`, plotly and numpy: they receive datasets, never run studies or campaigns.
"""

from ..outputs import use_reader_tables
from .benchmark import benchmark_scatter, epoch_sensitivity_lines, label_positions
from .campaign import (
    campaign_convergence,
    campaign_throughput,
    designs_pdop_deltav,
    generation_curve,
    replay_scaling,
    seed_curves,
)
from .charts import bar_chart, days_since_start, line_chart
from .deltav import (
    deltav_elements_and_rates,
    deltav_sampling,
    deltav_singularity,
    deltav_thrust_components,
    lsq_recovery_series,
    thrust_history,
)
from .design_life import (
    estimate_vs_closed_loop,
    integrator_convergence_chart,
    life_element_histories,
    maneuver_timeline,
    monthly_dop,
)
from .dop import (
    DOP_MAP_PANELS,
    POLE_AXES,
    colour_scale_caption,
    colour_scales,
    dop_grid_points,
    dop_polar_maps,
    dop_time_series,
    dop_time_series_by_frame,
    polar_wedges,
)
from .export import (
    NOTEBOOK_RENDERER,
    PNG_ENV,
    NotebookRenderer,
    figure_title,
    local_plotlyjs,
    save_figure,
    use_notebook_renderer,
)
from .frozen import frozen_family_chart, perilune_envelope
from .gps import (
    GPS_SENSITIVITY_GROUPS,
    cn0_vs_off_boresight,
    gnss_visibility_pdop,
    gps_sensitivity_scatter,
    gps_view_from_lnss,
    gps_visibility_pdop,
    gps_visibility_pdop_vs_paper,
    gps_visible_links,
    off_boresight_geometry,
)
from .pareto import LABELS, dop_against_availability, pareto_3d, variable_relationships
from .propagation import constellation_3d, elements_history
from .validation import front_estimate_vs_closed_loop, headline_chart, size_chart

__all__ = [
    "save_figure",
    "figure_title",
    "local_plotlyjs",
    "PNG_ENV",
    "NOTEBOOK_RENDERER",
    "NotebookRenderer",
    "use_notebook_renderer",
    "LABELS",
    "DOP_MAP_PANELS",
    "GPS_SENSITIVITY_GROUPS",
    "line_chart",
    "bar_chart",
    "days_since_start",
    "elements_history",
    "constellation_3d",
    "dop_time_series",
    "dop_grid_points",
    "dop_polar_maps",
    "colour_scale_caption",
    "colour_scales",
    "polar_wedges",
    "POLE_AXES",
    "dop_time_series_by_frame",
    "gps_visibility_pdop",
    "off_boresight_geometry",
    "gps_view_from_lnss",
    "cn0_vs_off_boresight",
    "gps_visibility_pdop_vs_paper",
    "gps_visible_links",
    "gps_sensitivity_scatter",
    "gnss_visibility_pdop",
    "thrust_history",
    "deltav_elements_and_rates",
    "deltav_thrust_components",
    "lsq_recovery_series",
    "deltav_sampling",
    "deltav_singularity",
    "pareto_3d",
    "dop_against_availability",
    "variable_relationships",
    "campaign_convergence",
    "designs_pdop_deltav",
    "campaign_throughput",
    "generation_curve",
    "seed_curves",
    "replay_scaling",
    "benchmark_scatter",
    "epoch_sensitivity_lines",
    "label_positions",
    "life_element_histories",
    "maneuver_timeline",
    "monthly_dop",
    "estimate_vs_closed_loop",
    "integrator_convergence_chart",
    "frozen_family_chart",
    "perilune_envelope",
    "front_estimate_vs_closed_loop",
    "headline_chart",
    "size_chart",
]

use_notebook_renderer()  # in a notebook kernel: figures keep a static copy (nbconvert, code hosts)
use_reader_tables()  # and tables show labelled headers and each quantity's number format
