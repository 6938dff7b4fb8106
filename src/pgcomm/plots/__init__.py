"""Figures. Each function takes results and returns a Matplotlib figure; saving is separate (:func:`save`).

* :mod:`pgcomm.plots.linear`: a linear motor's runs, data, calibration, identification and logs;
* :mod:`pgcomm.plots.rotary`: a rotary motor's identified maps and a rotary run;
* :mod:`pgcomm.plots.fleet`: a fleet's QA distributions;
* :mod:`pgcomm.plots.figure`: Matplotlib on the Agg backend (no display needed), :func:`save` and :func:`png_bytes`.
"""

from pgcomm.plots.figure import png_bytes, save
from pgcomm.plots.fleet import plot_quantity_histogram
from pgcomm.plots.linear import ROW_COLORS, draw_error_lines, finish_error_axes, plot_calibration, plot_cogging, \
    plot_comparison, plot_coverage, plot_gain_columns, plot_logs, plot_model_error, plot_mse_bars, plot_reference, \
    plot_run
from pgcomm.plots.rotary import plot_rotary_maps, plot_rotary_run

__all__ = ["save", "png_bytes", "ROW_COLORS", "plot_run", "plot_comparison", "draw_error_lines", "finish_error_axes",
           "plot_reference", "plot_calibration", "plot_cogging", "plot_gain_columns", "plot_mse_bars", "plot_logs",
           "plot_model_error", "plot_coverage", "plot_rotary_maps", "plot_rotary_run", "plot_quantity_histogram"]
