"""Self-contained HTML reports: every number read from a run's results, figures embedded as base64 PNG.

* :mod:`pgcomm.report.linear`: ``pgcomm reproduce`` on a linear motor, our numbers beside the paper's;
* :mod:`pgcomm.report.rotary`: ``pgcomm identify`` and ``pgcomm reproduce`` on a rotary motor;
* :mod:`pgcomm.report.page`: the style sheet and the embedded figures both share.

The modules are imported by name (``from pgcomm.report.rotary import write_rotary_report``): a rotary report loads
nothing of the linear experiment.
"""
