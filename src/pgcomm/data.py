"""Identification data: :class:`CoilSetData` per coil set, the train/validation split, and the
builders from simulated data sets ``Z_i^l`` (:func:`generate_datasets`, :func:`coil_set_data_from_runs`)
and from logs (:func:`coil_set_data_from_logs`).

Data sets ``Z_i^l`` (eq. DataSets): for each coil set ``l`` and ``i = 1, 2`` the closed loop
runs the reference with the drive law (eq. Commutation_Solution_With_PhaseOffset) on coil
set ``l`` only, ``Fy^l* = Fy*`` and ``Δ^l = (-1)^i Δ0``, no feedforward (paper,
§Experimental results). All ``2L`` experiments share one compiled simulation and run batched.

From logs (files a rig or ``pgcomm simulate`` wrote): Algorithm 2 identifies each coil set
from experiments in which only that coil set carried current. A log is assigned to the coil
set that carries current in it; logs holding drive inputs ``(Fy_ref_l, delta_l)`` instead of
currents are converted with the drive's fixed commutation ``i = Γ(y) T(Fy*, Δ)`` (``k̂``,
``ζ̂`` of the motor description).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pgcomm.commutation import DriveInputLaw, drive_currents
from pgcomm.errors import DataError
from pgcomm.motor import Motor
from pgcomm.simulate import ClosedLoop, SimResult, simulate_many
from pgcomm.seeds import stream_seed

#: A coil set counts as active in a log when its RMS current exceeds this share of the largest.
ACTIVE_SHARE = 1e-3


# --------------------------------------------------------------------------------------------
# one coil set's samples and the split
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CoilSetData:
    """Measurements of one coil set operated alone (data sets ``Z_1^l ∪ Z_2^l``, eq. DataSets).

    Attributes:
        y: ``(N,)`` positions (m).
        currents: ``(N, 2)`` star currents ``(ia, ib)`` of this coil set (A).
        force: ``(N, 3)`` measured ``[Fy, Fx, Tz]`` (N, N, N·m).
        experiment: ``(N,)`` integer label of the data set ``Z_i`` each sample belongs to.
        name: used in messages, e.g. ``"coil set 2"``.
        velocity: ``(N,)`` velocity (m/s) or ``None``; needed by the direction term. Build it
            with :func:`velocity_from_positions` (non-causal, per experiment), as all builders here do.
    """

    y: np.ndarray
    currents: np.ndarray
    force: np.ndarray
    experiment: np.ndarray | None = None
    name: str = "coil set"
    velocity: np.ndarray | None = None

    def __post_init__(self):
        y = np.asarray(self.y, dtype=float)
        cur = np.asarray(self.currents, dtype=float)
        frc = np.asarray(self.force, dtype=float)
        n = y.shape[0] if y.ndim == 1 else -1
        if y.ndim != 1:
            raise DataError(f"{self.name}: positions y must be 1-D, got shape {y.shape}")
        if cur.shape != (n, 2):
            raise DataError(f"{self.name}: currents must have shape ({n}, 2), got {cur.shape}")
        if frc.shape != (n, 3):
            raise DataError(f"{self.name}: force must have shape ({n}, 3), got {frc.shape}")
        exp = np.zeros(n, dtype=int) if self.experiment is None else np.asarray(self.experiment)
        if exp.shape != (n,):
            raise DataError(f"{self.name}: experiment labels must have shape ({n},), got {exp.shape}")
        for label, arr in (("y", y), ("currents", cur), ("force", frc)):
            bad = ~np.isfinite(arr.reshape(n, int(np.prod(arr.shape[1:])))).all(axis=1)  # n = 0 allowed
            if bad.any():
                raise DataError(f"{self.name}: {label} is not finite in row {int(np.argmax(bad))} "
                                f"({int(bad.sum())} rows)")
        if self.velocity is not None:
            vel = np.asarray(self.velocity, dtype=float)
            if vel.shape != (n,):
                raise DataError(f"{self.name}: velocity must have shape ({n},), got {vel.shape}")
            if not np.isfinite(vel).all():
                raise DataError(f"{self.name}: velocity is not finite in row {int(np.argmax(~np.isfinite(vel)))}")
            object.__setattr__(self, "velocity", vel)
        object.__setattr__(self, "y", y)
        object.__setattr__(self, "currents", cur)
        object.__setattr__(self, "force", frc)
        object.__setattr__(self, "experiment", exp.astype(int))

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.y.shape[0])

    @classmethod
    def from_drive_inputs(cls, y, fy, delta, force, drive: Motor, coil_set: int = 0, experiment=None,
                          name="coil set") -> "CoilSetData":
        """Data logged as drive inputs ``(Fy^l*, Δ^l)`` (the dotted block of Fig. PGNN_Parametrization).

        The currents are ``i = Γ(y) T(Fy*, Δ)`` (:func:`pgcomm.commutation.drive_currents`).

        Args:
            y: ``(N,)`` (m); fy: ``(N,)`` commanded force (N); delta: ``(N,)`` phase offset (rad);
            force: ``(N, 3)``; drive: the drive's fixed commutation ``k̂^l`` (N/A), ``ζ̂^l`` (rad) of coil set
            ``coil_set`` (0-based) and its pole pitch ``d_m`` (m); experiment: ``(N,)`` labels.
        """
        y = np.asarray(y, dtype=float)
        fy = np.asarray(fy, dtype=float)
        delta = np.asarray(delta, dtype=float)
        if fy.shape != y.shape or delta.shape != y.shape:
            raise DataError(f"{name}: fy and delta must have the shape of y {y.shape}, got {fy.shape}, {delta.shape}")
        cur = np.asarray(drive_currents(y, fy[:, None], delta[:, None], drive.k[coil_set], drive.zeta[coil_set],
                                        drive.pole_pitch))[:, 0, :]
        return cls(y, cur, force, experiment, name)

    def take(self, index) -> "CoilSetData":
        """The samples ``index`` (integer array or boolean mask)."""
        return CoilSetData(self.y[index], self.currents[index], self.force[index], self.experiment[index], self.name,
                           None if self.velocity is None else self.velocity[index])

    def with_velocity(self, sample_time: float) -> "CoilSetData":
        """Copy with ``velocity`` from :func:`velocity_from_positions` (per experiment label), ``sample_time`` (s)."""
        return dataclasses.replace(self, velocity=velocity_from_positions(self.y, sample_time, self.experiment))

    # ---- the identification data interface (pgcomm.protocols.IdentificationData): a force sensor's data are
    # the unfiltered case, each output sample one raw sample with all three force rows observed

    @property
    def raw(self) -> "CoilSetData":
        """The samples the model is evaluated on: the data themselves."""
        return self

    #: Rows of ``force`` that are measured: ``Fy``, ``Fx``, ``Tz``.
    observed = (0, 1, 2)

    #: Friction columns fitted with the model: none (the force sensor measures the electromagnetic force).
    n_friction = 0

    def window_index(self) -> np.ndarray:
        """``(N, 1)`` indices into :attr:`raw` of each output sample's regressor samples: itself."""
        return np.arange(self.n)[:, None]

    @property
    def regressor_taps(self) -> np.ndarray:
        """``(1,)`` filter taps of the regressor rows: ``[1]`` (unfiltered)."""
        return np.ones(1)

    def filtered(self, columns) -> np.ndarray:
        """Raw columns ``(N,)``/``(N, k)`` at the output samples: unchanged."""
        return np.asarray(columns, dtype=float)

    def filtered_friction(self) -> np.ndarray:
        """``(N, 0)``: no friction columns."""
        return np.zeros((self.n, 0))

    def physics_nuisance(self, pole_pitch: float) -> np.ndarray:
        """``(N, 0)``: the physics-only fit needs no nuisance columns with force measurements."""
        return np.zeros((self.n, 0))

    def split(self, validation_fraction: float = 0.2, block_size: int = 500):
        """``(train, validation)`` by :func:`train_validation_split`."""
        return train_validation_split(self, validation_fraction, block_size)

    def mechanics(self, friction):
        """``None``: no friction is identified from force measurements."""
        return None


#: Window (s) of the Savitzky–Golay differentiator of :func:`velocity_from_positions`.
VELOCITY_WINDOW = 0.021
#: Polynomial order of that differentiator.
VELOCITY_ORDER = 2


def velocity_from_positions(y, sample_time: float, segments=None, window: float = VELOCITY_WINDOW) -> np.ndarray:
    """Non-causal velocity (m/s) from sampled positions: a zero-phase Savitzky–Golay differentiator.

    Per contiguous segment (label change in ``segments``, e.g. the experiment ``Z_i``; a
    segment never borrows samples across a log boundary) a local polynomial of order 2 is
    fitted by least squares over a centred window of ``window`` seconds (odd number of
    samples) and differentiated at its centre::

        ẏ[k] = Σ_j c_j y[k + j] / T_s,   j = -h..h   (symmetric window: zero phase, no lag)

    Why this filter: the direction term switches with the SIGN of ``ẏ``, so a lag would
    move every reversal; a zero-phase filter does not. A plain central difference of a
    0.1 µm encoder at 1 ms is quantised to 0.05 mm/s steps with noise of that size; the
    21-sample window averages it to ~1 µm/s while its pass band (the fit is exact for
    quadratic motion; first notch near ``1/window`` ≈ 50 Hz) keeps every acceleration
    phase of a jerk-limited profile (>= 10 ms). Segments shorter than the window fall back
    to ``numpy.gradient`` (central differences).

    Args:
        y: ``(N,)`` positions (m); sample_time: ``T_s`` (s); segments: ``(N,)`` labels or ``None``;
        window: window length (s).

    Returns:
        ``(N,)`` velocity (m/s).
    """
    from scipy.signal import savgol_filter  # start-up cost: SciPy loads only when this runs

    y = np.asarray(y, dtype=float)
    if not sample_time > 0:
        raise ValueError(f"sample_time must be positive, got {sample_time}")
    n_win = max(VELOCITY_ORDER + 2, int(round(window / sample_time)))
    n_win += 1 - n_win % 2  # odd
    labels = np.zeros(y.shape[0], int) if segments is None else np.asarray(segments)
    out = np.empty_like(y)
    edges = np.flatnonzero(np.diff(labels) != 0) + 1
    for seg in np.split(np.arange(y.shape[0]), edges):
        if seg.size == 0:
            continue
        ys = y[seg]
        if seg.size >= n_win:
            out[seg] = savgol_filter(ys, n_win, VELOCITY_ORDER, deriv=1, delta=sample_time, mode="interp")
        elif seg.size > 1:
            out[seg] = np.gradient(ys, sample_time)
        else:
            out[seg] = 0.0
    return out


def split_indices(n: int, validation_fraction: float = 0.2, block_size: int = 500):
    """Deterministic train/validation split of ``n`` samples by contiguous blocks.

    Samples are grouped in blocks of ``block_size``; with ``k = round(1 / validation_fraction)``
    the last block of every group of ``k`` goes to validation (``0.2`` -> every 5th block).
    Contiguous blocks keep the strongly correlated neighbouring samples on one side.

    Returns:
        ``(train_index, validation_index)`` integer arrays.
    """
    if not 0.0 <= validation_fraction <= 0.5:
        raise ValueError(f"validation_fraction must be in [0, 0.5], got {validation_fraction}")
    idx = np.arange(n)
    if validation_fraction == 0.0:
        return idx, idx[:0]
    k = max(2, int(round(1.0 / validation_fraction)))
    is_val = (idx // int(block_size)) % k == k - 1
    return idx[~is_val], idx[is_val]


def train_validation_split(data: CoilSetData, validation_fraction: float = 0.2, block_size: int = 500):
    """``(train, validation)`` :class:`CoilSetData` by :func:`split_indices`."""
    tr, va = split_indices(data.n, validation_fraction, block_size)
    return data.take(tr), data.take(va)


# --------------------------------------------------------------------------------------------
# from simulated data sets Z_i^l
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DataSet:
    """One experiment ``Z_i^l``: coil set ``coil_set`` (0-based), phase offset ``delta`` (rad), and its run."""

    coil_set: int
    delta: float
    result: SimResult

    def columns(self) -> dict[str, np.ndarray]:
        """Log columns (DESIGN.md format) plus ``experiment`` and ``active_coil_set`` (1-based)."""
        cols = dict(self.result.columns())
        n = self.result.t.shape[0]
        cols["active_coil_set"] = np.full(n, float(self.coil_set + 1))
        return cols


def generate_datasets(plant, drive: Motor, reference, *, delta: float = np.pi / 4, loop: ClosedLoop = ClosedLoop(),
                      seed: int = 0, coil_sets=None) -> list[list[DataSet]]:
    """Generate ``Z_1^l, Z_2^l`` for every coil set (eq. DataSets).

    Args:
        plant: electromagnetic truth (twin or force map).
        drive: the drive's fixed commutation ``k̂^l``, ``ζ̂^l`` (current estimates), sample time, limit.
        reference: :class:`pgcomm.trajectory.Reference`, e.g. the paper's data-generation reference.
        delta: ``Δ0`` (rad); ``|Δ0| <= π/4`` for safety as in the paper.
        seed: the run's seed; experiment ``(l, i)`` draws its noise from the named stream
            ``stream_seed(seed, "data", l, i)`` (:func:`pgcomm.seeds.stream_seed`).
        coil_sets: which coil sets (0-based), default all.

    Returns:
        ``out[l][i]`` for ``i = 0`` (``Δ = -Δ0``) and ``i = 1`` (``Δ = +Δ0``).
    """
    coil_sets = list(range(drive.n_coil_sets)) if coil_sets is None else list(coil_sets)
    laws, keys = [], []
    for l in coil_sets:
        for i, sgn in enumerate((-1.0, 1.0)):
            laws.append(DriveInputLaw.for_coil_set(drive, l, sgn * delta))
            keys.append((l, sgn * delta, stream_seed(seed, "data", l, i)))
    runs = simulate_many(plant, laws, reference, drive=drive, loop=loop, seeds=[k[2] for k in keys])
    out = []
    for j, l in enumerate(coil_sets):
        out.append([DataSet(l, keys[2 * j + i][1], runs[2 * j + i]) for i in range(2)])
    return out


def coil_set_data_from_runs(datasets) -> list[CoilSetData]:
    """:class:`CoilSetData` per coil set from the ``Z_{1,2}^l`` runs of :func:`generate_datasets` (measured positions, currents, forces)."""
    out = []
    for pair in datasets:
        l = pair[0].coil_set
        ys, cs, fs, ex = [], [], [], []
        for i, ds in enumerate(pair):
            r = ds.result
            ys.append(r.y_meas)
            cs.append(r.currents[:, l, :])
            fs.append(r.f_meas)
            ex.append(np.full(r.t.shape[0], i))
        data = CoilSetData(np.concatenate(ys), np.concatenate(cs), np.concatenate(fs), np.concatenate(ex),
                           name=f"coil set {l + 1}")
        out.append(data.with_velocity(pair[0].result.sample_time))
    return out


# --------------------------------------------------------------------------------------------
# from logs
# --------------------------------------------------------------------------------------------


def log_currents(log, motor: Motor) -> np.ndarray:
    """Star currents ``(N, L, 2)`` (A) of a log: logged currents, or drive inputs converted by ``motor``'s drive."""
    cur = log.currents()
    if cur is not None:
        return cur
    di = log.drive_inputs()
    if di is None:
        raise DataError(f"{log.source}: needs currents ia_l, ib_l or drive inputs Fy_ref_l, delta_l per coil set")
    fy, delta = di
    if fy.shape[1] != motor.n_coil_sets:
        raise DataError(f"{log.source}: {fy.shape[1]} coil sets in the log, the motor has {motor.n_coil_sets}")
    return np.asarray(drive_currents(log["y"], fy, delta, np.asarray(motor.k), np.asarray(motor.zeta),
                                     motor.pole_pitch))


def active_coil_set(log, currents: np.ndarray) -> int:
    """0-based index of the only coil set carrying current in ``log``; refuses logs with none or several."""
    rms = np.sqrt(np.mean(currents**2, axis=(0, 2)))
    if rms.max() <= 0:
        raise DataError(f"{log.source}: no coil set carries current")
    active = np.flatnonzero(rms > ACTIVE_SHARE * rms.max())
    if active.size != 1:
        names = ", ".join(str(a + 1) for a in active)
        raise DataError(f"{log.source}: coil sets {names} all carry current; identification needs logs with one "
                        "coil set active (data sets Z_i^l)")
    return int(active[0])


def coil_set_data_from_logs(logs, motor: Motor, force: bool = True) -> list[CoilSetData]:
    """Group logs by active coil set into :class:`CoilSetData` (one per coil set, in order).

    Each log becomes one experiment label.

    Args:
        logs: :class:`pgcomm.io.logs.Log` list.
        motor: coil-set count; the drive's ``k̂``, ``ζ̂`` for drive-input logs.
        force: ``True``: the measured force ``Fy, Fx, Tz`` of every log (identification with a
            force sensor; a log without it is refused). ``False``: for identification without a
            force sensor (:func:`pgcomm.sensorless.sensorless_data`, which ignores ``force``): the
            ``force`` of the result is zero and must not be used.

    Raises:
        DataError: naming the coil sets that no log excites, or (``force=True``) a log without
            force columns.
    """
    logs = list(logs)
    if force:
        for log in logs:
            if not log.has_force:
                raise DataError(f"{log.source}: no force columns Fy, Fx, Tz (a rig without a force sensor); "
                                "identify such logs without a force sensor (pgcomm identify --no-force-sensor)")
    groups: dict[int, list] = {}
    for log in logs:
        cur = log_currents(log, motor)
        if cur.shape[1] != motor.n_coil_sets:
            raise DataError(f"{log.source}: {cur.shape[1]} coil sets in the log, the motor has {motor.n_coil_sets}")
        l = active_coil_set(log, cur)
        groups.setdefault(l, []).append((log, cur[:, l, :]))
    missing = [l + 1 for l in range(motor.n_coil_sets) if l not in groups]
    if missing:
        raise DataError(f"no log with coil set(s) {', '.join(map(str, missing))} active; "
                        f"got {sum(len(g) for g in groups.values())} log(s)")
    out = []
    for l in range(motor.n_coil_sets):
        ys, cs, fs, ex = [], [], [], []
        for i, (log, cur) in enumerate(groups[l]):
            ys.append(log["y"])
            cs.append(cur)
            fs.append(log.force() if force else np.zeros((len(log["y"]), 3)))
            ex.append(np.full(len(log["y"]), i))
        data = CoilSetData(np.concatenate(ys), np.concatenate(cs), np.concatenate(fs), np.concatenate(ex),
                           name=f"coil set {l + 1} ({', '.join(lg.source for lg, _ in groups[l])})")
        out.append(data.with_velocity(_log_sample_time(groups[l][0][0], motor)))
    return out


def _log_sample_time(log, motor: Motor) -> float:
    """Sample time (s) of a log (its own, else the motor's)."""
    return float(getattr(log, "sample_time", None) or motor.sample_time)
