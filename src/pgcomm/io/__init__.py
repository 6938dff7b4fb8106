"""Input/output: every file format of the package, each with one reader and one writer.

Every reader validates what it reads and raises :class:`pgcomm.errors.DataError`
(data files) or :class:`pgcomm.errors.ConfigError` (TOML/settings) with one line
naming the file and the column/row/key/value; every writer goes through
:mod:`pgcomm.io.atomic` so that no output file is ever half-written.

Modules:

* :mod:`pgcomm.io.tables`: the one reader of CSV, Parquet, MATLAB .mat and HDF5 columns;
* :mod:`pgcomm.io.logs`: the :class:`~pgcomm.io.logs.Log` type and its readers/writers;
* :mod:`pgcomm.io.references`: position references from files;
* :mod:`pgcomm.io.forcemap`: force-map CSV files of a :class:`~pgcomm.forcemap.ForceMapPlant`;
* :mod:`pgcomm.io.config`: TOML loading, generic dataclass loader, motor and experiment configs;
* :mod:`pgcomm.io.model`: model files (JSON + npz), the one validated loader;
* :mod:`pgcomm.io.results`: results.json with dotted keys;
* :mod:`pgcomm.io.rotary_zoo`: a rotary zoo motor's folder (``motor.toml``, ``truth.json``, the drive's logs);
* :mod:`pgcomm.io.static_map`: a drive's own static cogging map;
* :mod:`pgcomm.io.plan`, :mod:`pgcomm.io.rotary_plan`: a rig plan's files;
* :mod:`pgcomm.io.atomic`: write-to-temporary-then-rename helpers.
"""

from pgcomm.io.atomic import atomic_open, atomic_path, atomic_write_bytes, atomic_write_text
from pgcomm.io.config import load_dataclass, load_motor, load_toml, motor_to_toml, write_motor
from pgcomm.io.logs import ColumnMapping, Log, load_column_mapping, read_log, read_logs, write_datasets, write_log
from pgcomm.io.results import get_key, read_results, set_key, to_jsonable, write_results

__all__ = [
    "atomic_open",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "load_dataclass",
    "load_motor",
    "load_toml",
    "motor_to_toml",
    "write_motor",
    "ColumnMapping",
    "Log",
    "load_column_mapping",
    "read_log",
    "read_logs",
    "write_log",
    "write_datasets",
    "get_key",
    "read_results",
    "set_key",
    "to_jsonable",
    "write_results",
]
