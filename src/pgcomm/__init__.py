"""pgcomm: physics-guided commutation for multi-coil-set linear motors and rotary motors on field-oriented drives
(:mod:`pgcomm.rotary`).

Data flow (one module per stage)::

    trajectory -> control -> commutation -> drive -> plant (twin / forcemap)
    -> sensors -> logs -> calibration / identify -> models -> commutation
    -> evaluation (metrics, report) / export (C, LUT)

Conventions: SI units (m, s, N, N*m, A, rad); force vectors ``F = [Fy, Fx, Tz]``;
star-connected coil sets with independent currents ``(ia, ib)``, ``ic = -ia - ib``.
All numerics are float64: every module that computes with JAX enables x64 when imported
(:mod:`pgcomm._x64`).

The front door: the names in :data:`__all__` are importable from ``pgcomm`` directly
(``from pgcomm import TwinParams, ModelLaw``). They load on first use, so ``import pgcomm``
alone loads no JAX and changes no process-wide setting (the command line sets its own,
:mod:`pgcomm.cli`).
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

from pgcomm.errors import PgcommError  # noqa: E402

#: public name -> (module, attribute)
_PUBLIC = {
    # the motor and the plants
    "Motor": ("pgcomm.motor", "Motor"),
    "load_motor": ("pgcomm.io.config", "load_motor"),
    "write_motor": ("pgcomm.io.config", "write_motor"),
    "TwinParams": ("pgcomm.twin", "TwinParams"),
    "DEFAULT_TWIN": ("pgcomm.twin", "DEFAULT_TWIN"),
    "ForceMapPlant": ("pgcomm.forcemap", "ForceMapPlant"),
    "load_forcemap": ("pgcomm.io.forcemap", "load_forcemap"),
    # experiment settings, set-up, the whole experiment
    "ExperimentConfig": ("pgcomm.settings", "ExperimentConfig"),
    "load_experiment": ("pgcomm.io.config", "load_experiment"),
    "build_setup": ("pgcomm.setup", "build_setup"),
    "run_experiment": ("pgcomm.reproduce", "run"),
    # the rig: plan, logs, calibration, identification
    "make_plan": ("pgcomm.plan", "make_plan"),
    "Log": ("pgcomm.io.logs", "Log"),
    "read_log": ("pgcomm.io.logs", "read_log"),
    "read_logs": ("pgcomm.io.logs", "read_logs"),
    "write_log": ("pgcomm.io.logs", "write_log"),
    "calibrate_from_logs": ("pgcomm.calibration", "calibrate_from_logs"),
    "coil_set_data_from_logs": ("pgcomm.data", "coil_set_data_from_logs"),
    "identify_pgnn": ("pgcomm.identify", "identify"),
    "IdentifyOptions": ("pgcomm.identify.options", "IdentifyOptions"),
    "identify_spline": ("pgcomm.identify.spline", "identify_spline"),
    # a linear motor's coil sets from their data sets (pgcomm identify), with its options
    "identify_coil_sets": ("pgcomm.identification", "identify_coil_sets"),
    "CoilSetsOptions": ("pgcomm.identification", "CoilSetsOptions"),
    # a rotary motor from its drive's logs (pgcomm identify --motor rotary.toml), with its settings
    "identify_rotary_logs": ("pgcomm.rotary.from_logs", "identify_from_logs"),
    "RotaryIdentifyOptions": ("pgcomm.settings", "RotaryIdentifyOptions"),
    "load_rotary_motor": ("pgcomm.io.config", "load_rotary_motor"),
    # models and laws
    "CombinedModel": ("pgcomm.models", "CombinedModel"),
    "SplineModel": ("pgcomm.spline_model", "SplineModel"),
    "load_model": ("pgcomm.io.model", "load_model"),
    "save_model": ("pgcomm.io.model", "save_model"),
    "ClassicalLaw": ("pgcomm.commutation", "ClassicalLaw"),
    "ModelLaw": ("pgcomm.commutation", "ModelLaw"),
    # deployment
    "write_c": ("pgcomm.export.c", "write_c"),
    "CLawOptions": ("pgcomm.export.c", "CLawOptions"),
    "build_lut": ("pgcomm.export.lut", "build_lut"),
    # the interfaces
    "ForceModel": ("pgcomm.protocols", "ForceModel"),
    "Plant": ("pgcomm.protocols", "Plant"),
    "Law": ("pgcomm.protocols", "Law"),
}

__all__ = ["PgcommError", "__version__", *_PUBLIC]


def __getattr__(name: str):
    # PEP 562: the public names load their modules on first use (JAX only when needed)
    try:
        module, attr = _PUBLIC[name]
    except KeyError:
        raise AttributeError(f"module 'pgcomm' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))
