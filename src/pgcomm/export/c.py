"""C99 export of the model-based commutation law (eq. Commutation_Model_Currents).

:func:`write_c` turns a :class:`~pgcomm.models.CombinedModel` (or a
:class:`~pgcomm.spline_model.SplineModel`, below) into two files, ``NAME.h``
and ``NAME.c``, that a real-time controller compiles as they are: C99, only ``<math.h>``, ``<stdint.h>``, ``<string.h>``
(``memcpy`` for the non-finite tests that survive ``-ffast-math``, :func:`ieee_finite`),
no dynamic allocation, no global mutable state (the weights are ``static const``
arrays, every function is reentrant). The generated functions are:

* ``int NAME_currents(T y, const T f_star[3], T currents[L][2])`` — star currents
  ``(ia, ib)`` (A) of every coil set for position ``y`` (m) and desired force
  ``F* = [Fy, Fx, Tz]`` (N, N, N·m). The same algorithm as
  ``ModelLaw(model, metric="phase", current_limit=..., det_min=...)`` in
  :mod:`pgcomm.commutation`, operation by operation: the gain ``K̂^l(y)`` and the mean
  cogging force from the networks, the minimum-copper-loss solve with row
  normalisation, determinant-based Tikhonov damping below ``det_min``, and the
  current-limit scaling. Safe for every input (as ``ModelLaw``): beyond the training range
  the model is read at the range's end, a non-finite input gives zero currents, and the
  limit (when exported) bounds every phase current ``ia, ib, ic = -ia - ib``. Return codes:

  - ``0``: ``y`` inside the training range;
  - ``1``: ``y`` outside it: the currents are those of the range's end (``y`` held there);
  - ``2``: a non-finite input (NaN or ±inf in ``y``, ``f_star`` or ``v``), or a finite demand
    so large that the currents overflow: all currents are zero.

* ``int NAME_drive_inputs(T y, const T f_star[3], const T k_hat[L], const T zeta_hat[L],
  T fy[L], T delta[L])`` — the drive inputs ``(Fy^l*, Δ^l) = T^{-1}(Γ(y)^{-1} i^l)``
  (eq. Current_To_ForceDelta) for a drive with fixed commutation ``k̂^l`` (N/A),
  ``ζ̂^l`` (rad), in the package's one convention (:func:`pgcomm.commutation.transform_T_inverse`):
  ``Fy^l*`` signed, ``Δ^l = atan2(F2, F1)`` folded by π onto ``(-π/2, π/2]`` (flipping the sign of
  ``Fy^l*``), zero force as ``(0, 0)``. ``y`` is the drive's actual position (not held: the drive
  commutates where the translator is). The return code of ``NAME_currents``; with code 2 (also
  for a non-finite ``k_hat``/``zeta_hat`` or a position so large that its commutation phase
  overflows) every ``fy`` and ``delta`` is zero.
* ``void NAME_model(T y, T gain[L][3][2], T cogging[3])`` — the model itself
  (``K̂^l(y)`` in N/A, N·m/A and the mean ``F̂_cog(y)`` in N, N, N·m), for verification.

Extensions beyond the paper, present only when the model has them:

* the 5th/7th harmonic gain columns ``H^l`` add ``H0 cos 5θ + H1 sin 5θ + H2 cos 7θ + H3 sin 7θ``
  to ``K̂^l`` inside ``NAME_model`` (same order of operations as :func:`pgcomm.models.harmonic_gain`);
* the direction term: ``NAME_currents`` and ``NAME_drive_inputs`` gain the controller's
  velocity ``v`` (m/s) as their second argument (``NAME_currents(y, v, f_star, currents)``),
  the law subtracts ``mean_l C^l · tanh(v / v_ε)`` after the cogging force (as
  :class:`pgcomm.commutation.ModelLaw` does), and ``void NAME_direction(T v, T force[3])``
  returns that force. ``NAME_HAS_VELOCITY`` is 1 in the header then, else 0.

Spline models (:class:`pgcomm.spline_model.SplineModel`): the same functions and return codes; the
tables ``A^l(y), B^l(y)`` (gain), ``F̂_cog(y)`` and ``C(y)`` (direction) are ``static const`` arrays
on their uniform knots, read by index arithmetic (``i = floor((y - k_0)/h)``, clamped to the grid,
``(1 - w) t[i] + w t[i+1]``), exactly as :func:`pgcomm.interp.interp_linear`, so outside the grid
the end rows are held while the harmonics go on. With a direction table the velocity argument is
as above and ``void NAME_direction(T y, T v, T force[3])`` returns ``C(y) tanh(v / v_ε)``. The law
never reads the tables at a NaN position (return code 2 first); ``NAME_model`` itself, called with
one, reads the first knot (the index conversion must not see a NaN).

Feedforward (``mechanics=``, any model family; ``pgcomm export`` passes a spline file's mechanics):
``T NAME_feedforward_g(T r, T v, T a)`` returns ``g = m a + f_v v + (f_c + D(r)) sign(v)`` (N) for
one reference sample (position m, velocity m/s, acceleration m/s²), ``D`` the Coulomb table on
uniform knots read as above; the controller applies ``u_ff[k] = (g[k] + g[k+1]) / 2``
(:func:`pgcomm.control.feedforward_signal`), which ``T NAME_feedforward(r, v, a, r_next, v_next,
a_next)`` computes.

``T`` is ``double`` or ``float`` (``precision="single"``: float literals with an ``f``
suffix and the float functions ``sinf``, ``tanhf`` ...). In single precision the
3 x 3 normal-equation solve (about 60 flops) still runs in ``double``: with one coil
set the system is always singular and damped with ``ε² = 1e-6``, and float rounding
(6e-8) amplified by ``1/ε²`` left 20 % errors in the currents (measured; 3e-5 with two coil sets),
while the expensive part — the network activations — stays in float.

The numbers printed into the source round-trip exactly: ``%.17g`` for double, ``%.9g``
for float (of the value rounded to float32). The generated code mirrors the Python
evaluation order (sums first, then biases; divisions where Python divides), so the
double export agrees with the Python law to rounding (see tests/test_export_c.py).
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pgcomm.commutation import DEFAULT_DAMPING, DEFAULT_DET_MIN
from pgcomm.export.c_text import DOUBLE, PRECISIONS, SINGLE, check_c_name, ieee_finite, macro_literal
from pgcomm import __version__
from pgcomm.control import Feedforward
from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.model import feedforward_from_metadata
from pgcomm.spline_model import SplineModel

__all__ = ["CLawOptions", "c_source", "write_c", "check_c_name", "PRECISIONS"]

#: Inverse copper-loss metric Q^{-1} = [[2, -1], [-1, 2]] / 3, computed as pgcomm.commutation does.
_QINV = np.array([[2.0, -1.0], [-1.0, 2.0]]) / 3.0


@dataclass(frozen=True)
class CLawOptions:
    """How :func:`c_source` writes the law: its C name, precision, current limit and damping.

    Attributes:
        name: C identifier used as file name and function prefix.
        precision: ``"double"`` or ``"single"``.
        current_limit: peak phase current (A) embedded in the law, or ``None`` (no limit).
        det_min, damping: damping rule of :func:`pgcomm.commutation.min_energy_currents`.
        limit_source: where the limit (or its absence) came from, written after it in the comment
            block, e.g. ``"from the model file"``; ``None``: not said.
        drive_source: where the drive's commutation came from (comment block), e.g. ``"--drive-k, --drive-zeta"``.

    Raises:
        ValueError: a name that is no C identifier, another precision, a limit that is not a positive current,
            ``det_min <= 0`` or ``damping < 0``.
    """

    name: str = "pgcomm_law"
    precision: str = "double"
    current_limit: float | None = None
    det_min: float = DEFAULT_DET_MIN
    damping: float = DEFAULT_DAMPING
    limit_source: str | None = None
    drive_source: str | None = None

    def __post_init__(self):
        check_c_name(self.name)
        if self.precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {PRECISIONS}, got {self.precision!r}")
        limit = self.current_limit
        if limit is not None and not (math.isfinite(limit) and limit > 0):
            raise ValueError(f"current_limit must be a positive number of amperes or None, got {limit}")
        if not (self.det_min > 0 and self.damping >= 0):
            raise ValueError(f"need det_min > 0 and damping >= 0, got {self.det_min}, {self.damping}")


def c_source(model, options: CLawOptions = CLawOptions(), *, metadata: dict | None = None, drive=None,
             mechanics=None) -> tuple[str, str]:
    """Header and source text of the exported law (see the module docstring).

    Args:
        model: :class:`~pgcomm.models.CombinedModel` (any ``L``, any hidden widths and
            depth, any activation of :data:`pgcomm.models.ACTIVATIONS`) or
            :class:`~pgcomm.spline_model.SplineModel` (tables on uniform knots).
        options: :class:`CLawOptions` (name, precision, current limit in A, damping rule).
        metadata: the model file's metadata (named in the comment block: source file,
            date, package version, when present), or ``None``.
        drive: optional fixed commutation of the drive, embedded as the constant arrays
            ``NAME_drive_k_hat[L]`` (N/A) and ``NAME_drive_zeta_hat[L]`` (rad) to pass to
            ``NAME_drive_inputs``: a :class:`~pgcomm.motor.Motor`, a mapping with keys
            ``k_hat``, ``zeta_hat`` or a pair ``(k_hat, zeta_hat)`` (scalars or ``(L,)``).
        mechanics: optional feedforward to export beside the law as ``NAME_feedforward_g`` and
            ``NAME_feedforward`` (module docstring): a :class:`pgcomm.control.Feedforward`, a
            :class:`pgcomm.identify.mechanics.MechanicsFit`, or the plain mechanics dict of a model
            file (``document["mechanics"]`` of :func:`pgcomm.io.model.load_model`). Its Coulomb
            knots (m) must be uniform.

    Returns:
        ``(header_text, source_text)``.

    Raises:
        ValueError: non-finite weights or non-uniform knots.
    """
    o = options
    gen = _SplineGen if isinstance(model, SplineModel) else _Gen
    g = gen(model, o.name, SINGLE if o.precision == "single" else DOUBLE, metadata or {}, drive,
            o.current_limit, float(o.det_min), float(o.damping), _feedforward_of(mechanics))
    g.limit_source, g.drive_source = o.limit_source, o.drive_source
    single = o.precision == "single"
    return ieee_finite(g.header(), o.name, single), ieee_finite(g.source(), o.name, single)


def write_c(model, out_dir, options: CLawOptions = CLawOptions(), *, metadata: dict | None = None, drive=None,
            mechanics=None) -> list[Path]:
    """Write ``NAME.h`` and ``NAME.c`` into ``out_dir`` (created if missing).

    Both texts are generated before anything is written, and each file is written
    atomically (:mod:`pgcomm.io.atomic`), so a failure never leaves half a file. Arguments
    as for :func:`c_source`.

    Returns:
        ``[path_of_header, path_of_source]``.
    """
    header, source = c_source(model, options, metadata=metadata, drive=drive, mechanics=mechanics)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f"{options.name}.h", out / f"{options.name}.c"]
    atomic_write_text(paths[0], header)
    atomic_write_text(paths[1], source)
    return paths


# ----------------------------------------------------------------------------------------------
# generator
# ----------------------------------------------------------------------------------------------


def _arr(x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError("the model has non-finite parameters; refusing to export it")
    return a


def _ascii(text) -> str:
    """Text safe inside a C block comment (ASCII, no comment terminator)."""
    s = str(text).encode("ascii", "replace").decode("ascii")
    return s.replace("*/", "* /").replace("/*", "/ *").replace("\n", " ")


def _drive_params(drive, n: int):
    """``(k_hat, zeta_hat)`` arrays of length ``n`` from the accepted ``drive`` forms."""
    if drive is None:
        return None
    if hasattr(drive, "k") and hasattr(drive, "zeta"):
        k, z = drive.k, drive.zeta
    elif isinstance(drive, dict):
        k, z = drive["k_hat"], drive["zeta_hat"]
    else:
        k, z = drive
    k = np.broadcast_to(_arr(k), (n,)).copy()
    z = np.broadcast_to(_arr(z), (n,)).copy()
    if np.any(k <= 0):
        raise ValueError(f"drive k_hat must be positive, got {k}")
    return k, z


def _feedforward_of(mechanics):
    """A :class:`pgcomm.control.Feedforward` from the accepted ``mechanics`` forms, or ``None``.

    Its Coulomb knots must be uniform: the C reads the table by index arithmetic.
    """
    if mechanics is None:
        return None

    if isinstance(mechanics, Feedforward):
        ff = mechanics
    elif hasattr(mechanics, "feedforward") and callable(mechanics.feedforward):  # MechanicsFit
        ff = mechanics.feedforward()
    elif isinstance(mechanics, dict):
        ff = feedforward_from_metadata(mechanics)
        if ff is None:
            raise ValueError(f"mechanics {sorted(mechanics)} hold no mass and viscous friction")
    else:
        raise ValueError(f"mechanics must be a Feedforward, a MechanicsFit or a dict, got {type(mechanics).__name__}")
    _arr([ff.mass, ff.viscous, ff.coulomb])
    if ff.coulomb_knots:
        knots, table = _arr(ff.coulomb_knots), _arr(ff.coulomb_table)
        if knots.shape != table.shape or knots.shape[0] < 2:
            raise ValueError(f"feedforward Coulomb table: {knots.shape[0]} knots and {table.shape[0]} values; "
                             "need the same number, at least 2")
        _check_uniform("feedforward coulomb_knots", knots)
    return ff


def _check_uniform(what: str, knots: np.ndarray) -> None:
    """``ValueError`` unless ``knots`` (m) increase strictly with one spacing (relative 1e-9)."""
    d = np.diff(knots)
    if knots.ndim != 1 or knots.shape[0] < 2 or not np.all(d > 0):
        raise ValueError(f"{what}: knots must increase strictly (at least 2)")
    h = (knots[-1] - knots[0]) / (knots.shape[0] - 1)
    if np.max(np.abs(d - h)) > 1e-9 * max(abs(knots[0]), abs(knots[-1]), h):
        raise ValueError(f"{what}: knots must be uniform for the exported index arithmetic "
                         f"(spacings {d.min():.6g} to {d.max():.6g} m)")


class _Gen:
    """Builds the C texts of one model (private; see :func:`c_source`)."""

    def __init__(self, model, name, num: CNumbers, metadata, drive, current_limit, det_min, damping, ff=None):
        self.ff = ff  # pgcomm.control.Feedforward to export beside the law, or None
        self.limit_source = self.drive_source = None  # said in the comment block when set (c_source)
        self.m, self.name, self.num, self.meta = model, name, num, metadata
        self.version = __version__
        self.L = int(model.n_coil_sets)
        self.drive = _drive_params(drive, self.L)
        self.limit, self.det_min, self.damping = current_limit, det_min, damping
        self.rng = model.training_range
        self.P = name  # prefix of every C symbol
        self.dir = getattr(model, "C", None) is not None
        self.harm = getattr(model, "H", None) is not None
        # the velocity argument of the law functions (direction term only)
        self.vdecl = f"{num.ctype} v, " if self.dir else ""
        self.varg = "v, " if self.dir else ""
        # arguments of NAME_direction inside the law (a spline's direction force depends on y too)
        self.dir_args = "v"  # the law's call of NAME_direction
        self.T = num.ctype
        # the solve runs in double even in single precision (see the module docstring)
        self.S = "double"

    # --- small helpers ---------------------------------------------------------------------

    def lit(self, x) -> str:
        return self.num.lit(x)

    def dlit(self, x) -> str:
        return DOUBLE.lit(x)

    def f(self, fn: str) -> str:
        return self.num.fn(fn)

    def array(self, cname: str, a, ctype: str | None = None) -> str:
        """``static const T cname[d0][d1]... = {...};`` with one innermost row per line."""
        a = _arr(a)
        lit = self.dlit if ctype == "double" else self.lit
        dims = "".join(f"[{d}]" for d in a.shape)

        def rec(x, indent):
            if x.ndim == 1:
                return "{" + ", ".join(lit(v) for v in x) + "}"
            inner = [rec(v, indent + 1) for v in x]
            pad = "    " * (indent + 1)
            return "{\n" + ",\n".join(pad + s for s in inner) + "\n" + "    " * indent + "}"

        return f"static const {ctype or self.T} {cname}{dims} = {rec(a, 0)};\n"

    # --- model description -----------------------------------------------------------------

    def _meta(self, *keys, default="unknown"):
        for k in keys:
            v = self.meta.get(k) if isinstance(self.meta, dict) else None
            if v not in (None, ""):
                return _ascii(v)
        return default

    def _net_desc(self, net) -> str:
        if net is None:
            return "none"
        return f"hidden widths {tuple(net.widths)}, activation {net.activation}"

    def banner(self, kind: str) -> str:
        m = self.m
        rng = (f"[{self.rng[0]:.6g}, {self.rng[1]:.6g}] m (outside it y is held at the range's end and the "
               "functions return 1)" if self.rng is not None else "unknown (y is not held; the functions return 0)")
        src = f" ({self.limit_source})" if self.limit_source else ""
        limit = f"{self.limit:.6g} A peak phase current{src}" if self.limit is not None else "none"
        now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
        lines = [
            f"{self.name}.{kind} -- model-based commutation law, generated by pgcomm {self.version}.",
            "Do not edit: regenerate with `pgcomm export --format c`.",
            "",
            f"Model:        source {self._meta('source', 'model_file', 'path', 'file')}, "
            f"created {self._meta('created', 'date', 'timestamp')}, "
            f"pgcomm {self._meta('pgcomm_version', 'version', 'package_version')}",
            f"Exported:     {now}, precision {'single (float)' if self.num.single else 'double'}",
            f"Coil sets:    L = {self.L}; pole pitch d_m = {m.pole_pitch:.9g} m",
            f"Training range: y in {rng}",
            *self._banner_model_lines(),
            "  Khat^+ minimises sum_l (ia^2 + ib^2 + ic^2), ic = -ia - ib, i.e. i^T W i with",
            "  W = blockdiag([[2,1],[1,2]]): i = W^-1 K^T D (D A D + eps2 I)^-1 D F,",
            "  A = K W^-1 K^T (3 x 3), D = diag(A)^(-1/2) (row normalisation).",
            f"Damping:      c = det(D A D) in [0, 1]; eps2 = {self.damping:g} * (1 - c/{self.det_min:g})^2",
            f"              when c < {self.det_min:g}, else 0 (bounded where Khat loses rank, e.g. L = 1).",
            *([f"Current limit: {limit}; all coil sets are scaled by one factor",
               "              so that max(|ia|, |ib|, |ic|) <= limit (force direction kept)."]
              if self.limit is not None else
              [f"Current limit: none ({self.limit_source or 'the currents are not limited'})."]),
            "Drive inputs: (Fy^l*, Delta^l) = T^-1(Gamma(y)^-1 i^l) (eq. Current_To_ForceDelta),",
            "              Fy^l* signed, Delta = atan2(F2, F1) folded by pi onto (-pi/2, pi/2]",
            "              (the sign of Fy^l* flipped when folded); zero force gives (0, 0).",
            *self._banner_drive_lines(),
            "Units:        y in m; F* = [Fy N, Fx N, Tz N m]; currents in A (star: ia, ib);",
            "              k_hat in N/A, zeta_hat and Delta in rad, Fy^l* in N.",
            "Return codes: 0 = y inside the training range;",
            "              1 = y outside it: the currents of the range's end (y held there);",
            "              2 = a non-finite input (NaN or inf in y, f_star" + (", v" if self.dir else "")
            + "), or a demand so large",
            "                  that the currents overflow: all currents (and drive inputs) are zero.",
            *self._banner_extra_lines(),
            *self._ff_lines(),
        ]
        return "/*\n" + "".join((" * " + _ascii(s)).rstrip() + "\n" for s in lines) + " */\n"

    def _banner_drive_lines(self) -> list[str]:
        """The drive's fixed commutation embedded as constants (only with ``drive``)."""
        if self.drive is None:
            return []
        k, z = self.drive
        src = f" ({self.drive_source})" if self.drive_source else ""
        return [f"Drive:        {self.P}_drive_k_hat = {', '.join(f'{x:.6g}' for x in k)} N/A,",
                f"              {self.P}_drive_zeta_hat = {', '.join(f'{x:.6g}' for x in z)} rad{src}."]

    def _banner_model_lines(self) -> list[str]:
        """The banner's description of the model (PGNN: networks and the law's terms)."""
        m = self.m
        return [
            f"Networks:     gain columns: {self._net_desc(m.gain_nets)};",
            f"              cogging:      {self._net_desc(m.cog_nets)};",
            "              input s = (y - y_center_l) / y_scale_l per coil set l.",
            "",
            "Law (paper eq. Commutation_Model_Currents), minimum copper loss:",
            "  i = Khat(y)^+ (F* - Fcog(y)),  Khat = [Khat^1 .. Khat^L] (3 x 2L),",
            "  Khat^l(y) = A^l cos(2 pi y/d_m) + B^l sin(2 pi y/d_m) + [f_1^l(s), f_2^l(s)],",
            "  Fcog(y) = (1/L) sum_l f_cog^l(s) (mean over coil sets).",
        ]

    def _banner_extra_lines(self) -> list[str]:
        """Lines after the common banner (none for a PGNN)."""
        return []

    # --- header ----------------------------------------------------------------------------

    def header(self) -> str:
        P, T, L = self.P, self.T, self.L
        guard = P.upper() + "_H_INCLUDED"
        out = [self.banner("h"), f"#ifndef {guard}\n#define {guard}\n\n",
               "#ifdef __cplusplus\nextern \"C\" {\n#endif\n\n",
               f"/** Number of coil sets L. */\n#define {P.upper()}_L {L}\n",
               f"/** 1 if {P} was exported in single precision (float), 0 for double. */\n"
               f"#define {P.upper()}SINGLE {1 if self.num.single else 0}\n\n",
               f"/** 1 if the law takes the controller's velocity v (m/s) (direction term), else 0. */\n"
               f"#define {P.upper()}_HAS_VELOCITY {1 if self.dir else 0}\n\n",
               f"/** Scalar type of the interface ({T}). */\ntypedef {T} {P}_real;\n\n",
               "/**\n"
               " * Star currents of all coil sets (eq. Commutation_Model_Currents).\n"
               " * y: position (m); " + ("v: velocity (m/s) the controller has (reference velocity);\n * "
                                         if self.dir else "") + "f_star: desired [Fy (N), Fx (N), Tz (N m)];\n"
               " * currents: output, currents[l] = {ia, ib} of coil set l (A), ic = -ia - ib.\n"
               " * Returns 0 (y inside the training range), 1 (y outside: the currents of the range's end,\n"
               " * y held there) or 2 (a non-finite input, or currents that would overflow: all zero).\n"
               " */\n",
               f"int {P}_currents({T} y, {self.vdecl}const {T} f_star[3], {T} currents[{P.upper()}_L][2]);\n\n",
               "/**\n"
               " * Drive inputs (Fy^l* (N, signed), Delta^l (rad) in (-pi/2, pi/2]) that make a\n"
               " * fixed-commutation drive with k_hat[l] (N/A), zeta_hat[l] (rad) produce the currents of\n"
               f" * {P}_currents at the actual position y (eq. Current_To_ForceDelta). The return code of\n"
               f" * {P}_currents; 2 (all fy, delta zero) also for a non-finite k_hat or zeta_hat.\n"
               " */\n",
               f"int {P}_drive_inputs({T} y, {self.vdecl}const {T} f_star[3], const {T} k_hat[{P.upper()}_L],\n"
               f"    const {T} zeta_hat[{P.upper()}_L], {T} fy[{P.upper()}_L], {T} delta[{P.upper()}_L]);\n\n",
               "/**\n"
               " * The model: gain[l] = Khat^l(y) (3 x 2; rows Fy, Fx, Tz in N/A, N/A, N m/A;\n"
               " * columns ia, ib) and the mean cogging force [Fy, Fx, Tz] (N, N, N m).\n"
               " */\n",
               f"void {P}_model({T} y, {T} gain[{P.upper()}_L][3][2], {T} cogging[3]);\n\n"]
        out += self._header_model_decls() + self._header_ff_decls()
        if self.drive is not None:
            out.append(f"/** The drive's fixed commutation at export: k_hat (N/A), zeta_hat (rad) per coil set. */\n"
                       f"extern const {T} {P}_drive_k_hat[{P.upper()}_L];\n"
                       f"extern const {T} {P}_drive_zeta_hat[{P.upper()}_L];\n\n")
        out.append(f"#ifdef __cplusplus\n}}\n#endif\n\n#endif /* {guard} */\n")
        return "".join(out)

    def _header_model_decls(self) -> list[str]:
        """Declarations of the model-specific functions (PGNN: the direction force)."""
        if not self.dir:
            return []
        return ["/** The direction force mean_l C^l tanh(v / v_eps) [Fy, Fx, Tz] (N, N, N m), v in m/s. */\n"
                f"void {self.P}_direction({self.T} v, {self.T} force[3]);\n\n"]

    # --- source ----------------------------------------------------------------------------

    def _solve_single_coil_set(self, solve: list, cast: str, dl) -> list:
        """``L = 1``: meet the ``Fy`` and ``Fx`` rows exactly (pgcomm.commutation._single_coil_set_currents).

        Replaces the ``3 x 3`` normalised solve of ``solve`` (the generic law's lines) by the
        row-normalised, damped ``2 x 2`` solve; the rest (range flag, limit, outputs) is kept.
        """
        U = self.P.upper()
        start = next(j for j, line in enumerate(solve) if line.startswith("    /* kw = K^l"))
        stop = next(j for j, line in enumerate(solve) if "i[l][j] = kw[l][0][j]" in line) + 1
        decl = next(j for j, line in enumerate(solve) if line.startswith("    double kw["))
        body = [
            "    /* L = 1: two currents for three rows; meet Fy and Fx exactly (Tz = d Fx - x Fy follows).\n"
            "       Rows normalised; Tikhonov eps2 where they become parallel (e.g. mu = 0). */\n",
            f"    ka = {cast}gain[0][0][0];\n    kb = {cast}gain[0][0][1];\n",
            f"    kc = {cast}gain[0][1][0];\n    kd = {cast}gain[0][1][1];\n",
            "    t = ka * ka + kb * kb;\n",
            f"    r0 = 1.0 / sqrt(t > {dl(1e-300)} ? t : {dl(1e-300)});\n",
            "    t = kc * kc + kd * kd;\n",
            f"    r1 = 1.0 / sqrt(t > {dl(1e-300)} ? t : {dl(1e-300)});\n",
            "    ka *= r0;\n    kb *= r0;\n    kc *= r1;\n    kd *= r1;\n",
            *([f"    f0 = (({cast}f_star[0] - {cast}cog[0]) - {cast}dirf[0]) * r0;\n",
               f"    f1 = (({cast}f_star[1] - {cast}cog[1]) - {cast}dirf[1]) * r1;\n"] if self.dir else
              [f"    f0 = ({cast}f_star[0] - {cast}cog[0]) * r0;\n",
               f"    f1 = ({cast}f_star[1] - {cast}cog[1]) * r1;\n"]),
            "    det = ka * kd - kb * kc;\n",
            f"    t = 1.0 - det * det / {U}_DET_MIN;\n",
            "    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);\n",
            f"    eps2 = {U}_DAMPING * (t * t);\n",
            "    g00 = ka * ka + kb * kb + eps2;\n    g01 = ka * kc + kb * kd;\n    g11 = kc * kc + kd * kd + eps2;\n",
            "    det = g00 * g11 - g01 * g01;\n",
            "    z0 = (g11 * f0 - g01 * f1) / det;\n    z1 = (g00 * f1 - g01 * f0) / det;\n",
            "    i[0][0] = ka * z0 + kc * z1;\n    i[0][1] = kb * z0 + kd * z1;\n\n",
        ]
        out = list(solve)
        out[start:stop] = body
        out[decl:decl + 3] = ["    double i[1][2], ka, kb, kc, kd, r0, r1, f0, f1, det, t, eps2, g00, g01, g11, z0, z1;\n"]
        ints = "    int l, q, j, ret;\n\n" if self.limit is not None else "    int l, j, ret;\n\n"
        return [ints if line == "    int l, q, r, j, ret;\n\n" else line for line in out]

    def _act(self, which: str, activation: str) -> str:
        """``static T P_act_which(T x)`` for one activation of :data:`pgcomm.models.ACTIVATIONS`."""
        T, f, lit = self.T, self.f, self.lit
        body = {
            "tanh": f"return {f('tanh')}(x);",
            # jax.nn.sigmoid = lax.logistic = 1 / (1 + exp(-x))
            "sigmoid": f"return {lit(1)} / ({lit(1)} + {f('exp')}(-x));",
            "relu": f"return x > {lit(0)} ? x : {lit(0)};",
            # jax.nn.softplus = logaddexp(x, 0) = max(x, 0) + log1p(exp(-|x|)), overflow-free
            "softplus": f"return {f('fmax')}(x, {lit(0)}) + {f('log1p')}({f('exp')}(-{f('fabs')}(x)));",
            # jax.nn.gelu(approximate=True)
            "gelu": (f"return x * ({lit(0.5)} * ({lit(1)} + {f('tanh')}({lit(np.sqrt(2 / np.pi))} * "
                     f"(x + {lit(0.044715)} * (x * x * x)))));"),
            "linear": "return x;",
        }
        if activation not in body:
            raise ValueError(f"activation {activation!r} cannot be exported; expected one of {sorted(body)}")
        return f"static {T} {self.P}_act_{which}({T} x)\n{{\n    {body[activation]}\n}}\n\n"

    def _mlp(self, which: str, net, idx_params: str, idx: str, doc: str) -> tuple[str, str]:
        """Weight arrays and the evaluation function of one stacked network family.

        ``idx_params``: C parameters selecting the network (``"int l, int j"``); ``idx``: the
        matching subscripts (``"[l][j]"``). Mirrors :func:`pgcomm.models.hidden_features`
        and :meth:`pgcomm.models.MLP.__call__` (products summed first, then the bias).
        """
        P, T, lit = self.P, self.T, self.lit
        arrays = []
        widths = [int(b.shape[-1]) for _, b in net.hidden]
        for i, (w, b) in enumerate(net.hidden, start=1):
            w = _arr(w)
            if i == 1:
                w = w[..., 0, :]  # one input: (.., 1, n1) -> (.., n1)
            arrays.append(self.array(f"{P}_{which}_w{i}", w))
            arrays.append(self.array(f"{P}_{which}_b{i}", b))
        arrays.append(self.array(f"{P}_{which}_wo", net.W_out))
        arrays.append(self.array(f"{P}_{which}_bo", net.b_out))
        act = f"{P}_act_{which}"
        decl = ", ".join(f"h{i}[{n}]" for i, n in enumerate(widths, start=1))
        code = [f"/* {doc} */\nstatic void {P}_{which}_net({idx_params}, {T} s, {T} out[3])\n{{\n",
                f"    {T} {decl};\n    {T} acc;\n    int k, m, q;\n\n",
                f"    for (k = 0; k < {widths[0]}; ++k)\n"
                f"        h1[k] = {act}(s * {P}_{which}_w1{idx}[k] + {P}_{which}_b1{idx}[k]);\n"]
        for i in range(2, len(widths) + 1):
            code.append(f"    for (k = 0; k < {widths[i - 1]}; ++k) {{\n"
                        f"        acc = {lit(0)};\n"
                        f"        for (m = 0; m < {widths[i - 2]}; ++m)\n"
                        f"            acc += h{i - 1}[m] * {P}_{which}_w{i}{idx}[m][k];\n"
                        f"        h{i}[k] = {act}(acc + {P}_{which}_b{i}{idx}[k]);\n    }}\n")
        n_last = len(widths)
        code.append(f"    for (q = 0; q < 3; ++q) {{\n"
                    f"        acc = {lit(0)};\n"
                    f"        for (m = 0; m < {widths[-1]}; ++m)\n"
                    f"            acc += h{n_last}[m] * {P}_{which}_wo{idx}[m][q];\n"
                    f"        out[q] = acc + {P}_{which}_bo{idx}[q];\n    }}\n}}\n\n")
        return "".join(arrays), self._act(which, net.activation) + "".join(code)

    def _model_arrays(self) -> tuple[list[str], list[str]]:
        """``(arrays, functions)``: the model's ``static const`` tables and helper functions (PGNN)."""
        m, P = self.m, self.P
        arrays = ["/* ---- model parameters (rows Fy, Fx, Tz; columns ia, ib) ---- */\n",
                  self.array(f"{P}_A", m.A), self.array(f"{P}_B", m.B)]
        if self.harm:
            arrays += ["/* higher harmonics [coil set][cos 5t, sin 5t, cos 7t, sin 7t][row][column] (N/A) */\n",
                       self.array(f"{P}_H", m.H)]
        if self.dir:
            # mean over coil sets, summed in the order pgcomm.models.CombinedModel.direction_force sums
            c = np.asarray(m.C, dtype=float)
            c_mean = sum(c[l] for l in range(c.shape[0])) / c.shape[0]
            arrays += ["/* direction term: mean_l C^l (N, N, N m) */\n", self.array(f"{P}_C_MEAN", c_mean)]
        if m.gain_nets is not None or m.cog_nets is not None:  # the input scaling only feeds networks
            arrays += ["/* network input s = (y - y_center[l]) / y_scale[l] (m, m) */\n",
                       self.array(f"{P}_y_center", m.y_center), self.array(f"{P}_y_scale", m.y_scale)]
        funcs = []
        if m.gain_nets is not None:
            a, c = self._mlp("gain", m.gain_nets, "int l, int j", "[l][j]",
                             "column j (0: ia, 1: ib) of the gain correction of coil set l, [Fy, Fx, Tz] (N/A)")
            arrays += ["\n/* gain-correction networks, indexed [coil set][current column] */\n", a]
            funcs.append(c)
        if m.cog_nets is not None:
            a, c = self._mlp("cog", m.cog_nets, "int l", "[l]", "cogging force of coil set l, [Fy, Fx, Tz] (N)")
            arrays += ["\n/* cogging networks, indexed [coil set] */\n", a]
            funcs.append(c)
        return arrays, funcs

    def source(self) -> str:
        """The ``.c`` text: constants, tables, the model, the law (:meth:`_assemble`)."""
        self._locate_done = False  # NAME_locate is emitted once per source text
        m, P, T, lit = self.m, self.P, self.T, self.lit
        Lm = P.upper() + "_L"
        arrays, funcs = self._model_arrays()
        if self.drive is not None:
            arrays.append("\n/* the drive's fixed commutation at export (see the header) */\n")
            for nm, v in (("k_hat", self.drive[0]), ("zeta_hat", self.drive[1])):
                arrays.append(f"const {T} {P}_drive_{nm}[{Lm}] = {{{', '.join(lit(x) for x in v)}}};\n")

        omega = 2.0 * np.pi / m.pole_pitch  # harmonic_basis: (2π / d_m) * y
        consts = [
            f"/* 2 pi / d_m (rad/m), as pgcomm.models.harmonic_basis computes it */\n"
            f"#define {P.upper()}_OMEGA {macro_literal(lit(omega))}\n",
            f"/* 2 pi and d_m (m) for the drive's phase (2 pi y) / d_m + zeta, as pgcomm.motor.commutation_phase */\n"
            f"#define {P.upper()}_TWO_PI {macro_literal(lit(2.0 * np.pi))}\n"
            f"#define {P.upper()}_POLE_PITCH {macro_literal(lit(m.pole_pitch))}\n"
            f"#define {P.upper()}_TWO_PI_3 {macro_literal(lit(2 * np.pi / 3))}\n#define {P.upper()}_PI {macro_literal(lit(np.pi))}\n"
            f"#define {P.upper()}_HALF_PI {macro_literal(lit(np.pi / 2))}\n"
            f"/* det of [[sin e, cos e], [sin(e + 2pi/3), cos(e + 2pi/3)]] = -sin(2 pi/3) */\n"
            f"#define {P.upper()}_GAMMA_DET {macro_literal(lit(-np.sin(2 * np.pi / 3)))}\n",
            f"/* inverse copper-loss metric Q^-1 = [[2, -1], [-1, 2]] / 3 (Q: ia^2 + ib^2 + ic^2) */\n"
            f"#define {P.upper()}_QI_D {macro_literal(self.dlit(_QINV[0, 0]))}\n"
            f"#define {P.upper()}_QI_O {macro_literal(self.dlit(_QINV[0, 1]))}\n",
            f"/* damping rule of pgcomm.commutation.min_energy_currents */\n"
            f"#define {P.upper()}_DET_MIN {macro_literal(self.dlit(self.det_min))}\n"
            f"#define {P.upper()}_DAMPING {macro_literal(self.dlit(self.damping))}\n",
        ]
        if self.harm:
            consts.append(f"/* 2 pi n / d_m (rad/m) of the 5th and 7th harmonics (pgcomm.models.harmonic_basis) */\n"
                          f"#define {P.upper()}_OMEGA5 {macro_literal(lit(2.0 * np.pi * 5 / m.pole_pitch))}\n"
                          f"#define {P.upper()}_OMEGA7 {macro_literal(lit(2.0 * np.pi * 7 / m.pole_pitch))}\n")
        if self.dir:
            consts.append(f"/* v_eps (m/s) of the smooth sign tanh(v / v_eps) */\n"
                          f"#define {P.upper()}_V_EPS {macro_literal(lit(m.direction_velocity))}\n")
        if self.rng is not None:
            consts.append(f"/* training range (m) */\n#define {P.upper()}_Y_MIN {macro_literal(lit(self.rng[0]))}\n"
                          f"#define {P.upper()}_Y_MAX {macro_literal(lit(self.rng[1]))}\n")
        if self.limit is not None:
            consts.append(f"/* peak phase current limit (A) */\n"
                          f"#define {P.upper()}_CURRENT_LIMIT {macro_literal(self.dlit(self.limit))}\n")

        consts += self._model_consts()
        model_fn = self._model_fn()
        extra_fn = self._extra_fns()
        return self._assemble(consts, arrays, funcs, model_fn, extra_fn)

    def _model_consts(self) -> list[str]:
        """Model-specific ``#define``s (none for a PGNN)."""
        return []

    # --- feedforward (any model family, only with mechanics) ----------------------------------

    def _ff_knots(self):
        """``(knots, table)`` of the feedforward's Coulomb table ``D(r)``, or ``None`` (constant only)."""
        ff = self.ff
        if ff is None or not ff.coulomb_knots:
            return None
        return _arr(ff.coulomb_knots), _arr(ff.coulomb_table)

    def _ff_lines(self) -> list[str]:
        """Banner lines of the feedforward."""
        if self.ff is None:
            return []
        ff, kt = self.ff, self._ff_knots()
        tab = ([] if kt is None else
               [f"  D(r): Coulomb table, {kt[0].shape[0]} uniform knots on [{kt[0][0]:.6g}, {kt[0][-1]:.6g}] m,",
                "  linear, held at the ends;"])
        return ["",
                "Feedforward (eq. FeedforwardController with a Coulomb table along the stroke):",
                f"  g(r, v, a) = m a + f_v v + (f_c{' + D(r)' if kt is not None else ''}) sign(v),",
                *tab,
                f"  m = {ff.mass:.9g} kg, f_v = {ff.viscous:.9g} N s/m, f_c = {ff.coulomb:.9g} N;",
                "  r, v, a: reference position (m), velocity (m/s), acceleration (m/s^2) of sample k.",
                "  The controller applies u_ff[k] = (g[k] + g[k+1]) / 2 (the zero-order hold's half-sample",
                f"  average, pgcomm.control.feedforward_signal): {self.P}_feedforward takes both samples."]

    def _header_ff_decls(self) -> list[str]:
        """Declarations of the feedforward functions (only with mechanics)."""
        if self.ff is None:
            return []
        P, T = self.P, self.T
        return ["/**\n"
                " * Feedforward force g = m a + f_v v + (f_c + D(r)) sign(v) (N) of one reference sample:\n"
                " * r position (m), v velocity (m/s), a acceleration (m/s^2); sign(0) = 0.\n"
                f" * The controller applies u_ff[k] = (g[k] + g[k+1]) / 2 (see {P}_feedforward).\n"
                " */\n"
                f"{T} {P}_feedforward_g({T} r, {T} v, {T} a);\n\n"
                "/**\n"
                " * Feedforward u_ff[k] = (g(r[k], v[k], a[k]) + g(r[k+1], v[k+1], a[k+1])) / 2 (N), with g of\n"
                f" * {P}_feedforward_g: the reference of this sample and of the next one.\n"
                " */\n"
                f"{T} {P}_feedforward({T} r, {T} v, {T} a, {T} r_next, {T} v_next, {T} a_next);\n\n"]

    def _ff_fns(self) -> list[str]:
        """Tables, constants and functions of the feedforward (only with mechanics)."""
        if self.ff is None:
            return []
        P, T, U, lit, ff = self.P, self.T, self.P.upper(), self.lit, self.ff
        kt = self._ff_knots()
        out = ["\n/* ---- feedforward (see the header) ---- */\n",
               f"#define {U}_FF_MASS {macro_literal(lit(ff.mass))}\n#define {U}_FF_VISCOUS {macro_literal(lit(ff.viscous))}\n"
               f"#define {U}_FF_COULOMB {macro_literal(lit(ff.coulomb))}\n"]
        d_expr = ""
        if kt is not None:
            knots, table = kt
            out += [self._grid_consts("FF", knots),
                    "/* Coulomb table D(r) (N) at its knots (m) */\n",
                    self.array(f"{P}_ff_knots", knots), self.array(f"{P}_ff_coulomb", table), "\n",
                    self._locate_fn()]
            d_expr = " + d"
        out.append(f"{T} {P}_feedforward_g({T} r, {T} v, {T} a)\n{{\n")
        if kt is not None:
            out.append(f"    {T} w, d;\n    const int i = {P}_locate(r, {P}_ff_knots, {U}_FF_M, {U}_FF_H, &w);\n"
                       f"    const {T} sg = (v > {lit(0)}) ? {lit(1)} : ((v < {lit(0)}) ? {lit(-1)} : {lit(0)});\n\n"
                       f"    d = ({lit(1)} - w) * {P}_ff_coulomb[i] + w * {P}_ff_coulomb[i + 1];\n")
        else:
            out.append(f"    const {T} sg = (v > {lit(0)}) ? {lit(1)} : ((v < {lit(0)}) ? {lit(-1)} : {lit(0)});\n\n")
        out.append(f"    /* as pgcomm.control.feedforward_signal: m a + f_v v + (f_c + D(r)) sign(v) */\n"
                   f"    return {U}_FF_MASS * a + {U}_FF_VISCOUS * v + ({U}_FF_COULOMB{d_expr}) * sg;\n}}\n\n"
                   f"{T} {P}_feedforward({T} r, {T} v, {T} a, {T} r_next, {T} v_next, {T} a_next)\n{{\n"
                   f"    return {lit(0.5)} * ({P}_feedforward_g(r, v, a) + {P}_feedforward_g(r_next, v_next, a_next));\n"
                   "}\n")
        return out

    def _grid_consts(self, tag: str, knots: np.ndarray) -> str:
        """``#define``s of one uniform knot grid: number of knots ``M`` and spacing ``H`` (m)."""
        U, m = self.P.upper(), int(knots.shape[0])
        # the spacing exactly as pgcomm.interp.interp_linear computes it: (g[-1] - g[0]) / (m - 1)
        h = (float(knots[-1]) - float(knots[0])) / (m - 1)
        return f"#define {U}_{tag}_M {m}\n#define {U}_{tag}_H {macro_literal(self.lit(h))}\n"

    def _locate_fn(self) -> str:
        """``static int NAME_locate(...)``: cell and weight on a uniform grid, as interp_linear (once per file)."""
        if getattr(self, "_locate_done", False):
            return ""
        self._locate_done = True
        P, T, lit, f = self.P, self.T, self.lit, self.f
        return (f"/* Cell i and weight w of y on uniform knots (m knots, spacing h), exactly as\n"
                f"   pgcomm.interp.interp_linear: y clamped to the grid (NaN -> first knot), i = floor((y - k0) / h)\n"
                f"   clamped to [0, m - 2], w = (y - k[i]) / (k[i + 1] - k[i]) clamped to [0, 1]; the caller forms\n"
                f"   (1 - w) t[i] + w t[i + 1], exact at the knots. O(1): no search. */\n"
                f"static int {P}_locate({T} y, const {T} *knots, int m, {T} h, {T} *w)\n{{\n"
                f"    int i;\n    {T} g0, t;\n\n"
                f"    if (!(y >= knots[0]))\n        y = knots[0];\n"
                f"    if (y > knots[m - 1])\n        y = knots[m - 1];\n"
                f"    i = (int){f('floor')}((y - knots[0]) / h);\n"
                f"    if (i > m - 2)\n        i = m - 2;\n    if (i < 0)\n        i = 0;\n"
                f"    g0 = knots[i];\n    t = (y - g0) / (knots[i + 1] - g0);\n"
                f"    *w = t < {lit(0)} ? {lit(0)} : (t > {lit(1)} ? {lit(1)} : t);\n"
                f"    return i;\n}}\n\n")

    def _extra_fns(self) -> list[str]:
        """Functions after the law: the feedforward when mechanics were given."""
        return self._ff_fns()

    def _model_fn(self) -> list[str]:
        """``NAME_model`` (and ``NAME_direction``) of a PGNN."""
        m, P, T, L, lit, f = self.m, self.P, self.T, self.L, self.lit, self.f
        Lm, U = P.upper() + "_L", P.upper()
        # ---- the model ----
        # in single precision the harmonic argument is reduced by the pole pitch first (see _reduce)
        yh = f"{P}_reduce(y)" if self.num.single else "y"
        model_fn = [f"void {P}_model({T} y, {T} gain[{Lm}][3][2], {T} cogging[3])\n{{\n",
                    f"    const {T} yh = {yh};\n" if self.num.single else "",
                    f"    const {T} c = {f('cos')}({U}_OMEGA * {'yh' if self.num.single else 'y'}), "
                    f"sn = {f('sin')}({U}_OMEGA * {'yh' if self.num.single else 'y'});\n",
                    "    int l, q, j;\n"]
        if self.harm:
            yy = "yh" if self.num.single else "y"  # the reduction by d_m keeps 5θ, 7θ (periods d_m/5, d_m/7)
            model_fn.append(f"    const {T} c5 = {f('cos')}({U}_OMEGA5 * {yy}), s5 = {f('sin')}({U}_OMEGA5 * {yy});\n"
                            f"    const {T} c7 = {f('cos')}({U}_OMEGA7 * {yy}), s7 = {f('sin')}({U}_OMEGA7 * {yy});\n")
        if m.gain_nets is not None or m.cog_nets is not None:
            model_fn.append(f"    {T} s, out[3];\n")
        model_fn.append(f"\n    for (q = 0; q < 3; ++q)\n        cogging[q] = {lit(0)};\n"
                        f"    for (l = 0; l < {Lm}; ++l) {{\n")
        if m.gain_nets is not None or m.cog_nets is not None:
            model_fn.append(f"        s = (y - {P}_y_center[l]) / {P}_y_scale[l];\n")
        model_fn.append("        for (q = 0; q < 3; ++q)\n            for (j = 0; j < 2; ++j)\n"
                        f"                gain[l][q][j] = {P}_A[l][q][j] * c + {P}_B[l][q][j] * sn;\n")
        if self.harm:
            model_fn.append("        for (q = 0; q < 3; ++q)\n            for (j = 0; j < 2; ++j)\n"
                            f"                gain[l][q][j] += {P}_H[l][0][q][j] * c5 + {P}_H[l][1][q][j] * s5"
                            f" + {P}_H[l][2][q][j] * c7 + {P}_H[l][3][q][j] * s7;\n")
        if m.gain_nets is not None:
            model_fn.append(f"        for (j = 0; j < 2; ++j) {{\n            {P}_gain_net(l, j, s, out);\n"
                            "            for (q = 0; q < 3; ++q)\n                gain[l][q][j] += out[q];\n"
                            "        }\n")
        if m.cog_nets is not None:
            model_fn.append(f"        {P}_cog_net(l, s, out);\n"
                            "        for (q = 0; q < 3; ++q)\n            cogging[q] += out[q];\n")
        model_fn.append("    }\n")
        if m.cog_nets is not None:
            # jnp.mean divides the sum by L
            model_fn.append(f"    for (q = 0; q < 3; ++q)\n        cogging[q] /= {lit(L)};\n")
        model_fn.append("}\n\n")
        if self.dir:
            model_fn.append(f"void {P}_direction({T} v, {T} force[3])\n{{\n"
                            f"    const {T} sg = {f('tanh')}(v / {U}_V_EPS);\n    int q;\n\n"
                            f"    for (q = 0; q < 3; ++q)\n        force[q] = {P}_C_MEAN[q] * sg;\n}}\n\n")
        return model_fn

    def _assemble(self, consts, arrays, funcs, model_fn, extra_fn) -> str:
        """The source text: the shared law (solve, drive inputs) around the model's parts."""
        P, T, f = self.P, self.T, self.f
        Lm, U = P.upper() + "_L", P.upper()
        # ---- the solve (double: see the module docstring) ----

        dl = self.dlit
        cast = "(double)" if self.num.single else ""
        limit_code = ""
        if self.limit is not None:
            limit_code = (
                "    /* current limit: one factor for all coil sets keeps the force direction\n"
                "       (pgcomm.commutation.limit_currents; ic = -(ia + ib)) */\n"
                "    peak = 0.0;\n"
                f"    for (l = 0; l < {Lm}; ++l) {{\n"
                "        const double ph[3] = {i[l][0], i[l][1], -(i[l][0] + i[l][1])};\n"
                "        for (q = 0; q < 3; ++q)\n"
                "            if (fabs(ph[q]) > peak)\n                peak = fabs(ph[q]);\n    }\n"
                f"    sc = {U}_CURRENT_LIMIT / (peak > {dl(1e-300)} ? peak : {dl(1e-300)});\n"
                "    if (sc > 1.0)\n        sc = 1.0;\n"
                f"    for (l = 0; l < {Lm}; ++l)\n        for (j = 0; j < 2; ++j)\n            i[l][j] *= sc;\n")
        range_check = (f"    ret = (y >= {U}_Y_MIN && y <= {U}_Y_MAX) ? 0 : 1;\n"
                       if self.rng is not None else "    ret = 0; /* training range unknown at export */\n")
        finite = " && ".join(["isfinite(y)"] + [f"isfinite(f_star[{q}])" for q in range(3)]
                             + (["isfinite(v)"] if self.dir else []))
        safe = ("    /* safe for every input, as pgcomm.commutation.ModelLaw: a non-finite position, demand"
                + (" or velocity" if self.dir else "") + "\n"
                "       gives zero currents; beyond the training range the model is read at the range's end */\n"
                f"    if (!({finite})) {{\n"
                f"        for (l = 0; l < {Lm}; ++l)\n            for (j = 0; j < 2; ++j)\n"
                f"                currents[l][j] = {self.lit(0)};\n        return 2;\n    }}\n"
                + (f"    yc = y < {U}_Y_MIN ? {U}_Y_MIN : (y > {U}_Y_MAX ? {U}_Y_MAX : y);\n\n"
                   if self.rng is not None else "    yc = y;\n\n"))
        solve = [
            f"int {P}_currents({T} y, {self.vdecl}const {T} f_star[3], {T} currents[{Lm}][2])\n{{\n",
            f"    {T} gain[{Lm}][3][2], cog[3], yc;\n",
            f"    {T} dirf[3];\n" if self.dir else "",
            f"    double kw[{Lm}][3][2], i[{Lm}][2], a[3][3], dinv[3], fs[3], z[3];\n",
            "    double scale, c00, c01, c02, c11, c12, c22, det, t, eps2;\n",
            "    double b00, b11, b22, d00, d01, d02, d11, d12, d22;\n",
            "    double peak, sc;\n" if self.limit is not None else "",
            "    int l, q, r, j, ret;\n\n",
            range_check,
            safe,
            f"    {P}_model(yc, gain, cog);\n" + (f"    {P}_direction({self.dir_args}, dirf);\n" if self.dir else "")
            + "\n",
            "    /* kw = K^l Q^-1 and A = sum_l K^l Q^-1 K^lT (upper triangle, as _inv3_sym reads it) */\n",
            f"    for (l = 0; l < {Lm}; ++l)\n        for (q = 0; q < 3; ++q) {{\n",
            f"            kw[l][q][0] = {cast}gain[l][q][0] * {U}_QI_D + {cast}gain[l][q][1] * {U}_QI_O;\n",
            f"            kw[l][q][1] = {cast}gain[l][q][0] * {U}_QI_O + {cast}gain[l][q][1] * {U}_QI_D;\n",
            "        }\n",
            "    for (q = 0; q < 3; ++q)\n        for (r = q; r < 3; ++r) {\n",
            "            a[q][r] = 0.0;\n",
            f"            for (l = 0; l < {Lm}; ++l)\n",
            "                for (j = 0; j < 2; ++j)\n",
            f"                    a[q][r] += kw[l][q][j] * {cast}gain[l][r][j];\n",
            "        }\n\n",
            "    /* row normalisation D = diag(A)^(-1/2): units of N and N m do not matter */\n",
            "    scale = a[0][0];\n    if (a[1][1] > scale)\n        scale = a[1][1];\n",
            "    if (a[2][2] > scale)\n        scale = a[2][2];\n",
            "    for (q = 0; q < 3; ++q) {\n",
            f"        t = {dl(1e-30)} * scale + {dl(1e-300)};\n",
            "        dinv[q] = 1.0 / sqrt(a[q][q] > t ? a[q][q] : t);\n    }\n",
            "    for (q = 0; q < 3; ++q)\n        for (r = q; r < 3; ++r)\n",
            "            a[q][r] = a[q][r] * dinv[q] * dinv[r];\n\n",
            "    /* c = det(D A D) in [0, 1] measures conditioning; below DET_MIN add eps2 I (Tikhonov) */\n",
            "    c00 = a[1][1] * a[2][2] - a[1][2] * a[1][2];\n",
            "    c01 = a[0][2] * a[1][2] - a[0][1] * a[2][2];\n",
            "    c02 = a[0][1] * a[1][2] - a[0][2] * a[1][1];\n",
            "    det = a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02;\n",
            f"    t = 1.0 - det / {U}_DET_MIN;\n",
            "    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);\n",
            f"    eps2 = {U}_DAMPING * (t * t);\n\n",
            "    /* inverse of the damped matrix by its adjugate */\n",
            "    b00 = a[0][0] + eps2;\n    b11 = a[1][1] + eps2;\n    b22 = a[2][2] + eps2;\n",
            "    c00 = b11 * b22 - a[1][2] * a[1][2];\n",
            "    c01 = a[0][2] * a[1][2] - a[0][1] * b22;\n",
            "    c02 = a[0][1] * a[1][2] - a[0][2] * b11;\n",
            "    c11 = b00 * b22 - a[0][2] * a[0][2];\n",
            "    c12 = a[0][1] * a[0][2] - b00 * a[1][2];\n",
            "    c22 = b00 * b11 - a[0][1] * a[0][1];\n",
            "    det = b00 * c00 + a[0][1] * c01 + a[0][2] * c02;\n",
            "    d00 = c00 / det;\n    d01 = c01 / det;\n    d02 = c02 / det;\n",
            "    d11 = c11 / det;\n    d12 = c12 / det;\n    d22 = c22 / det;\n\n",
            "    /* z = D inv D (F* - Fcog); i^l = Q^-1 K^lT z */\n",
            "    for (q = 0; q < 3; ++q)\n",
            (f"        fs[q] = (({cast}f_star[q] - {cast}cog[q]) - {cast}dirf[q]) * dinv[q];\n" if self.dir else
             f"        fs[q] = ({cast}f_star[q] - {cast}cog[q]) * dinv[q];\n"),
            "    z[0] = (d00 * fs[0] + d01 * fs[1] + d02 * fs[2]) * dinv[0];\n",
            "    z[1] = (d01 * fs[0] + d11 * fs[1] + d12 * fs[2]) * dinv[1];\n",
            "    z[2] = (d02 * fs[0] + d12 * fs[1] + d22 * fs[2]) * dinv[2];\n",
            f"    for (l = 0; l < {Lm}; ++l)\n        for (j = 0; j < 2; ++j)\n",
            "            i[l][j] = kw[l][0][j] * z[0] + kw[l][1][j] * z[1] + kw[l][2][j] * z[2];\n\n",
            "    /* a finite demand so large that the solve overflows (|F*| near the largest double) must not\n"
            "       reach the amplifier either: zero currents, code 2 (ModelLaw does the same) */\n",
            f"    for (l = 0; l < {Lm}; ++l)\n        for (j = 0; j < 2; ++j)\n"
            "            if (!isfinite(i[l][j])) {\n"
            f"                for (l = 0; l < {Lm}; ++l)\n                    for (j = 0; j < 2; ++j)\n"
            f"                        currents[l][j] = {self.lit(0)};\n"
            "                return 2;\n            }\n\n",
            limit_code,
            f"    for (l = 0; l < {Lm}; ++l)\n        for (j = 0; j < 2; ++j)\n",
            f"            currents[l][j] = {'(float)' if self.num.single else ''}i[l][j];\n",
            "    return ret;\n}\n\n",
        ]

        if self.L == 1:
            solve = self._solve_single_coil_set(solve, cast, dl)

        # ---- drive inputs ----
        # the drive's phase is taken at the actual y (the drive commutates where the translator is)
        finite_drive = " && ".join(f"isfinite({a}[l])" for a in ("k_hat", "zeta_hat"))
        drive_fn = [
            f"int {P}_drive_inputs({T} y, {self.vdecl}const {T} f_star[3], const {T} k_hat[{Lm}],\n"
            f"    const {T} zeta_hat[{Lm}], {T} fy[{Lm}], {T} delta[{Lm}])\n{{\n",
            f"    {T} i[{Lm}][2], eta, e2, kd, f1, f2, d, m;\n    int l;\n",
            f"    int ret = {P}_currents(y, {self.varg}f_star, i);\n",
            f"    const {T} yh = {P}_reduce(y);\n" if self.num.single else "",
            "\n",
            f"    for (l = 0; l < {Lm}; ++l)\n",
            f"        if (!({finite_drive}))\n            ret = 2;\n",
            f"    for (l = 0; l < {Lm} && ret != 2; ++l) {{\n",
            "        /* Gamma(y)^-1 = (k_hat / det) [[cos e2, -cos eta], [-sin e2, sin eta]], e2 = eta + 2pi/3 */\n",
            f"        eta = {U}_TWO_PI * {'yh' if self.num.single else 'y'} / {U}_POLE_PITCH + zeta_hat[l];\n",
            "        if (!isfinite(eta)) {  /* |y| so large that the phase overflows */\n"
            "            ret = 2;\n            break;\n        }\n",
            f"        e2 = eta + {U}_TWO_PI_3;\n",
            f"        kd = k_hat[l] / {U}_GAMMA_DET;\n",
            f"        f1 = {f('cos')}(e2) * kd * i[l][0] - {f('cos')}(eta) * kd * i[l][1];\n",
            f"        f2 = {f('sin')}(eta) * kd * i[l][1] - {f('sin')}(e2) * kd * i[l][0];\n",
            "        /* T^-1 with atan2 (never a bare atan), then the one sign convention of pgcomm\n"
            "           (transform_T_inverse): Delta folded by pi onto (-pi/2, pi/2], the sign kept in Fy, so a\n"
            "           reversing force keeps its Delta; zero force is (0, 0) */\n",
            f"        m = {f('hypot')}(f1, f2);\n",
            f"        d = {f('atan2')}(f2, f1);\n",
            f"        if (d > {U}_HALF_PI) {{\n            d -= {U}_PI;\n            m = -m;\n        }}"
            f" else if (d <= -{U}_HALF_PI) {{\n            d += {U}_PI;\n            m = -m;\n        }}\n",
            f"        if (m == {self.lit(0)})\n            d = m = {self.lit(0)};\n",
            "        fy[l] = m;\n        delta[l] = d;\n",
            "    }\n",
            "    if (ret == 2)\n",
            f"        for (l = 0; l < {Lm}; ++l)\n            fy[l] = delta[l] = {self.lit(0)};\n",
            "    return ret;\n}\n",
        ]

        reduce_fn = [self._reduce()] if self.num.single else []
        return "".join([self.banner("c"), "\n#include <math.h>\n\n", f"#include \"{P}.h\"\n\n", *consts, "\n",
                        *arrays, "\n", *reduce_fn, *funcs, *model_fn, *solve, *drive_fn, *extra_fn])

    def _reduce(self) -> str:
        """Single precision only: ``y - n d_m`` with ``|.| <= d_m/2`` (Cody-Waite reduction).

        ``cosf(ω y)`` at ``y = 0.1 m`` rounds its argument (about 21 rad) to half an ulp, 1e-6 rad,
        which became 1e-5 relative current errors on a two-coil-set model; reducing ``y`` by whole
        pole pitches first keeps the argument below π and its error near 1e-7 rad. ``d_m`` is split
        into ``DM_HI`` (12 significant bits, so ``n * DM_HI`` is exact for ``|n| < 4096``) and
        ``DM_LO``; ``y - n * DM_HI`` is then exact (Sterbenz). The harmonic terms have period
        ``d_m``, so the gain is unchanged mathematically.
        """
        P, U = self.P, self.P.upper()
        d = float(self.m.pole_pitch)
        hi = np.array([np.float32(d)]).view(np.uint32) & np.uint32(0xFFFFF000)
        hi = float(hi.view(np.float32)[0])
        lo = float(np.float32(d - hi))
        return (f"/* y - n d_m, |.| <= d_m/2 (exact for |y| < 4096 d_m): keeps the float harmonic argument\n"
                f"   below pi, with ~1e-7 rad error instead of half an ulp of 2 pi y/d_m */\n"
                f"#define {U}_INV_DM {macro_literal(self.lit(1.0 / d))}\n#define {U}_DM_HI {macro_literal(self.lit(hi))}\n"
                f"#define {U}_DM_LO {macro_literal(self.lit(lo))}\n"
                f"static float {P}_reduce(float y)\n{{\n"
                f"    const float n = floorf(y * {U}_INV_DM + 0.5f);\n"
                f"    return (y - n * {U}_DM_HI) - n * {U}_DM_LO;\n}}\n\n")


class _SplineGen(_Gen):
    """Builds the C texts of a :class:`~pgcomm.spline_model.SplineModel` (private; see :func:`c_source`).

    Only the model differs from the PGNN export: the tables ``A^l(y), B^l(y)`` (gain), ``F̂_cog(y)``
    and ``C(y)`` (direction) are ``static const`` arrays on uniform knots, read by :func:`_locate_fn`'s
    index arithmetic exactly as :func:`pgcomm.interp.interp_linear` reads them (clamped to the
    grid, ``(1 - w) t[i] + w t[i+1]``); the 5th/7th harmonic columns ``H^l`` are always there. The
    law (solve, damping, current limit, drive inputs, return codes) is the shared one.
    """

    def __init__(self, model, *args):
        super().__init__(model, *args)
        self.dir = model.dir_table is not None
        self.harm = True
        self.vdecl = f"{self.T} v, " if self.dir else ""
        self.varg = "v, " if self.dir else ""
        self.dir_args = "yc, v"  # C(y) depends on the (held) position too
        self.tables = {"GAIN": _arr(model.gain_knots), "COG": _arr(model.cog_knots)}
        if self.dir:
            self.tables["DIR"] = _arr(model.dir_knots)
        for tag, knots in self.tables.items():
            _check_uniform(f"{tag.lower()}_knots", knots)

    def _grid_desc(self, tag: str) -> str:
        k = self.tables[tag]
        return f"{k.shape[0]} knots on [{k[0]:.6g}, {k[-1]:.6g}] m, spacing {(k[-1] - k[0]) / (k.shape[0] - 1):.6g} m"

    def _banner_model_lines(self) -> list[str]:
        lines = [
            "Family:       physics-guided spline (pgcomm.spline_model.SplineModel), tables on uniform knots:",
            f"              gain A^l(y), B^l(y): {self._grid_desc('GAIN')};",
            f"              cogging Fcog(y):      {self._grid_desc('COG')};",
        ]
        if self.dir:
            lines.append(f"              direction C(y):       {self._grid_desc('DIR')};")
        return lines + [
            "              read by linear interpolation, held at the grid's ends (pgcomm.interp.interp_linear).",
            "",
            "Law (paper eq. Commutation_Model_Currents), minimum copper loss:",
            "  i = Khat(y)^+ (F* - Fcog(y)" + (" - C(y) tanh(v / v_eps)" if self.dir else "")
            + "),  Khat = [Khat^1 .. Khat^L] (3 x 2L),",
            "  Khat^l(y) = A^l(y) cos t + B^l(y) sin t + H^l_0 cos 5t + H^l_1 sin 5t + H^l_2 cos 7t",
            "              + H^l_3 sin 7t,  t = 2 pi y / d_m.",
        ]

    def _header_model_decls(self) -> list[str]:
        if not self.dir:
            return []
        return ["/** The direction force C(y) tanh(v / v_eps) [Fy, Fx, Tz] (N, N, N m); y in m, v in m/s. */\n"
                f"void {self.P}_direction({self.T} y, {self.T} v, {self.T} force[3]);\n\n"]

    def _model_consts(self) -> list[str]:
        return ["/* uniform knot grids: number of knots and spacing (m) */\n"
                + "".join(self._grid_consts(tag, k) for tag, k in self.tables.items())]

    def _model_arrays(self) -> tuple[list[str], list[str]]:
        m, P = self.m, self.P
        arrays = ["/* ---- model tables (rows Fy, Fx, Tz; columns ia, ib) ---- */\n",
                  "/* gain knots (m) and [knot][coil set][A: cos t, B: sin t][row][column] (N/A, N m/A) */\n",
                  self.array(f"{P}_gain_knots", m.gain_knots), self.array(f"{P}_gain_table", m.gain_table),
                  "/* higher harmonics [coil set][cos 5t, sin 5t, cos 7t, sin 7t][row][column] (N/A) */\n",
                  self.array(f"{P}_H", m.H),
                  "/* cogging knots (m) and force [knot][Fy, Fx, Tz] (N, N, N m) */\n",
                  self.array(f"{P}_cog_knots", m.cog_knots), self.array(f"{P}_cog_table", m.cog_table)]
        if self.dir:
            arrays += ["/* direction knots (m) and C(y) [knot][Fy, Fx, Tz] (N, N, N m) */\n",
                       self.array(f"{P}_dir_knots", m.dir_knots), self.array(f"{P}_dir_table", m.dir_table)]
        return arrays, [self._locate_fn()]

    def _model_fn(self) -> list[str]:
        P, T, lit, f = self.P, self.T, self.lit, self.f
        Lm, U = P.upper() + "_L", P.upper()
        single = self.num.single
        yy = "yh" if single else "y"  # single: the harmonic argument reduced by whole pole pitches (_reduce)
        one = lit(1)
        out = [f"void {P}_model({T} y, {T} gain[{Lm}][3][2], {T} cogging[3])\n{{\n",
               f"    const {T} yh = {P}_reduce(y);\n" if single else "",
               f"    const {T} c = {f('cos')}({U}_OMEGA * {yy}), sn = {f('sin')}({U}_OMEGA * {yy});\n",
               # 5θ and 7θ from e^{iθ} by complex products (e^{2iθ}, e^{4iθ}, e^{5iθ}, e^{7iθ}) instead of four
               # more sin/cos calls: a third of the call's time; a few ulp of the harmonics' 1 % share of the gain
               f"    const {T} c2 = c * c - sn * sn, s2 = {lit(2)} * c * sn;\n",
               f"    const {T} c4 = c2 * c2 - s2 * s2, s4 = {lit(2)} * c2 * s2;\n",
               f"    const {T} c5 = c4 * c - s4 * sn, s5 = s4 * c + c4 * sn;\n",
               f"    const {T} c7 = c5 * c2 - s5 * s2, s7 = s5 * c2 + c5 * s2;\n",
               f"    {T} w, u;\n    int i, l, q, j;\n\n",
               "    /* gain: A^l(y) cos t + B^l(y) sin t (SplineModel.gain), then the harmonics in the order of\n"
               "       pgcomm.models.harmonic_gain */\n",
               f"    i = {P}_locate(y, {P}_gain_knots, {U}_GAIN_M, {U}_GAIN_H, &w);\n",
               f"    u = {one} - w;\n",
               f"    for (l = 0; l < {Lm}; ++l)\n        for (q = 0; q < 3; ++q)\n            for (j = 0; j < 2; ++j)\n",
               f"                gain[l][q][j] = (u * {P}_gain_table[i][l][0][q][j] + w * {P}_gain_table[i + 1][l][0][q][j]) * c\n"
               f"                    + (u * {P}_gain_table[i][l][1][q][j] + w * {P}_gain_table[i + 1][l][1][q][j]) * sn\n"
               f"                    + ({P}_H[l][0][q][j] * c5 + {P}_H[l][1][q][j] * s5 + {P}_H[l][2][q][j] * c7\n"
               f"                       + {P}_H[l][3][q][j] * s7);\n\n",
               "    /* cogging: one table for the combined model */\n",
               f"    i = {P}_locate(y, {P}_cog_knots, {U}_COG_M, {U}_COG_H, &w);\n",
               f"    u = {one} - w;\n",
               f"    for (q = 0; q < 3; ++q)\n        cogging[q] = u * {P}_cog_table[i][q] + w * {P}_cog_table[i + 1][q];\n"
               "}\n\n"]
        if self.dir:
            out.append(f"void {P}_direction({T} y, {T} v, {T} force[3])\n{{\n"
                       f"    const {T} sg = {f('tanh')}(v / {U}_V_EPS);\n    {T} w, u;\n    int q;\n"
                       f"    const int i = {P}_locate(y, {P}_dir_knots, {U}_DIR_M, {U}_DIR_H, &w);\n\n"
                       f"    u = {one} - w;\n"
                       f"    for (q = 0; q < 3; ++q)\n"
                       f"        force[q] = (u * {P}_dir_table[i][q] + w * {P}_dir_table[i + 1][q]) * sg;\n}}\n\n")
        return out
