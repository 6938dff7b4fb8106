"""Reading a :class:`~pgcomm.setup.Setup` from files: the twin or a force map with its motor TOML,
and the plant's known fundamental (``truth.json``, written by :mod:`pgcomm.zoo`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from pgcomm.errors import ConfigError
from pgcomm.settings import ExperimentConfig
from pgcomm.setup import Setup, resolve_reference
from pgcomm.twin import true_fundamental

__all__ = ["build_setup", "load_truth"]


def build_setup(config: ExperimentConfig, forcemap_path=None, motor_path=None, truth_path=None) -> Setup:
    """Resolve the plant, the nominal motor and the reference's range.

    Args:
        config: experiment settings.
        forcemap_path: force-map CSV replacing the twin's electromagnetics (needs ``motor_path``).
        motor_path: motor TOML (pole pitch, lever arms, nominal values, sample time, limit).
        truth_path: the plant's known fundamental (:func:`load_truth`); default ``truth.json``
            beside the force map when it exists (the motor zoo writes one).

    Raises:
        ConfigError: a force map without a motor file, or inconsistent coil-set counts.
    """
    cal = config.calibration
    if forcemap_path is None:
        if motor_path is not None:
            raise ConfigError("--motor is only used with --plant FORCEMAP.csv (the twin has its own motor)")
        tw = config.twin
        motor = tw.motor(k_hat=cal.k0, zeta_hat=cal.zeta0, sample_time=config.sample_time,
                         current_limit=config.current_limit, mass=config.mechanics.mass)
        rc = config.reference
        rc = replace(rc, stroke=0.1 if rc.stroke is None else rc.stroke, center=rc.center or 0.0)
        plant = tw.plant()
        config = replace(config, reference=resolve_reference(rc, *plant.y_range, "the twin"))
        k, zeta = true_fundamental(tw, config.reference.span)
        return Setup(plant, motor, config, k, zeta, "twin")
    if motor_path is None:
        raise ConfigError(f"--plant {forcemap_path}: a force map needs --motor MOTOR.toml "
                          "(pole pitch, lever arms, nominal k and zeta)")
    from pgcomm.io.config import load_motor
    from pgcomm.io.forcemap import load_forcemap

    plant = load_forcemap(forcemap_path)
    motor = load_motor(motor_path)
    if plant.n_coil_sets != motor.n_coil_sets:
        raise ConfigError(f"{forcemap_path}: {plant.n_coil_sets} coil sets, but {motor_path} describes "
                          f"{motor.n_coil_sets}")
    try:
        config = replace(config, sample_time=motor.sample_time,
                         current_limit=motor.current_limit if motor.current_limit else config.current_limit)
    except ValueError as e:
        raise ConfigError(f"{motor_path} with the experiment settings: {' '.join(str(e).split())}") from None
    config = replace(config, reference=resolve_reference(config.reference, *plant.y_range, str(forcemap_path)))
    if truth_path is None and (Path(forcemap_path).parent / "truth.json").is_file():
        truth_path = Path(forcemap_path).parent / "truth.json"
    if truth_path is None:
        return Setup(plant, motor, config, None, None, str(forcemap_path))
    truth = load_truth(truth_path, plant.n_coil_sets)
    if truth["y_range"] is not None and not np.allclose(truth["y_range"], config.reference.span,
                                                        rtol=0, atol=1e-9 * (abs(plant.y_range[1]) + 1e-3)):
        # the fundamental depends on the range it is fitted over: the truth must be of this reference
        raise ConfigError(f"{truth_path}: fitted over y in {list(truth['y_range'])} m, but the reference spans "
                          f"{list(config.reference.span)} m; leave [reference] stroke/center at the map's default")
    return Setup(plant, motor, config, truth["k"], truth["zeta"], str(forcemap_path))



def load_truth(path, n_coil_sets: int) -> dict:
    """A plant's known fundamental, ``truth.json`` as :mod:`pgcomm.zoo` writes it.

    Returns:
        ``{"k": (L,) N/A, "zeta": (L,) rad, "y_range": (lo, hi) m or None}``.

    Raises:
        ConfigError: unreadable file, missing keys, or a coil-set count other than ``n_coil_sets``.
    """
    import json

    try:
        data = json.loads(Path(path).read_text())
        k = np.asarray(data["k"], dtype=float)
        zeta = np.asarray(data["zeta"], dtype=float)
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise ConfigError(f"{path}: not a truth file with lists 'k' (N/A) and 'zeta' (rad): {err}") from None
    if k.shape != (n_coil_sets,) or zeta.shape != (n_coil_sets,) or not np.isfinite([*k, *zeta]).all():
        raise ConfigError(f"{path}: 'k' and 'zeta' need {n_coil_sets} finite values (one per coil set), "
                          f"got {k.tolist()} and {zeta.tolist()}")
    y_range = data.get("y_range")
    return {"k": k, "zeta": zeta, "y_range": tuple(float(v) for v in y_range) if y_range else None}

