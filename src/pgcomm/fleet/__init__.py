"""A fleet of motors on Dask: one task per motor folder (calibrate, identify, evaluate, export), resumable.

A fleet directory holds one folder per motor, each with ``motor.toml``, optional
``config.toml`` (experiment settings: identification, calibration estimator, evaluation) and
``logs/*.csv`` (the data sets ``Z_i^l`` a production line records, as
``pgcomm calibrate --save-data`` / ``pgcomm zoo --logs`` write them). :func:`process_motor`
is the task, run on a Dask worker; it uses the same library calls as the commands run alone:

* calibration: :func:`pgcomm.calibration.calibrate_from_logs` (Algorithm 1 on the logs);
* identification: :func:`pgcomm.data.coil_set_data_from_logs` and
  :func:`pgcomm.experiment.identify_models` (as ``pgcomm identify --data``), excitation check first;
* evaluation: :func:`pgcomm.evaluation.evaluate_logs` with the model (as ``pgcomm evaluate --model``);
* export: :func:`pgcomm.export.c.write_c` and :mod:`pgcomm.export.lut` (as ``pgcomm export``).

**Resumable workspace.** A finished motor's outputs are staged in ``OUT/.NAME.tmp-*`` and the
folder is renamed to ``OUT/NAME`` when complete (a directory rename is atomic), with
``OUT/NAME/fleet_rows.json`` inside: a folder ``OUT/NAME`` is finished by construction, and a
rerun skips it (unless ``redo``). A motor whose input is bad (a :class:`pgcomm.errors.PgcommError`)
is recorded in ``OUT/failed/NAME.json`` with its one-line error (the line the CLI would print)
and retried on the next run; other motors go on. An interrupted run leaves finished motors
intact; stale staging folders are removed at the next start.

**Workers.** Each worker runs one task at a time with XLA and BLAS pinned to one thread
(:data:`WORKER_ENV`, set before JAX is imported in an embedded cluster's worker processes and
by the :class:`WorkerSetup` plugin on a running cluster whose workers have not imported JAX
yet). JAX compiles the identification per array shape; :class:`WorkerSetup` also points JAX's
persistent compilation cache at ``OUT/.jax_cache`` so compiled code is shared by all workers
that see ``OUT`` and survives reruns.

**QA.** :func:`fleet_rows` collects one row per motor × coil set (:data:`COLUMNS`);
:func:`robust_z` and :func:`flag_outliers` mark motors unlike the others;
:func:`write_fleet_table` writes ``fleet.parquet`` / ``fleet.csv`` and :func:`write_fleet_html`
the distributions with the outliers.
Modules: :mod:`~pgcomm.fleet.motor` (one motor: the task and its rows), :mod:`~pgcomm.fleet.cluster`
(workers and :func:`run_fleet`), :mod:`~pgcomm.fleet.qa` (the table, robust z, outliers),
:mod:`~pgcomm.fleet.report` (``fleet.html``). The public names are re-exported here.
"""

from pgcomm.fleet.cluster import WORKER_ENV, FleetRun, WorkerSetup, run_fleet
from pgcomm.fleet.motor import COLUMNS, QA_QUANTITIES, ROWS_FILE, analyse_motor, find_motors, is_finished, process_motor
from pgcomm.fleet.qa import DEFAULT_OUTLIER_Z, flag_outliers, fleet_rows, robust_z
from pgcomm.fleet.report import write_fleet_html, write_fleet_table

__all__ = ["WORKER_ENV", "COLUMNS", "QA_QUANTITIES", "DEFAULT_OUTLIER_Z", "ROWS_FILE", "find_motors",
           "is_finished", "process_motor", "analyse_motor", "fleet_rows", "robust_z", "flag_outliers",
           "write_fleet_table", "write_fleet_html", "WorkerSetup", "FleetRun", "run_fleet"]
