"""``pgcomm zoo``: write random, physically plausible zoo motors (force maps with their truth), optionally with logs."""

from __future__ import annotations

from pathlib import Path

from pgcomm.cli._common import add_common_options, seed_value
from pgcomm.defaults import MAX_MOTORS
from pgcomm.errors import ConfigError

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = ("Write N random zoo motors (force map, motor.toml, config.toml, truth.json per folder); "
        "--logs also writes the data sets a production line records.")


def configure(p) -> None:
    """Options of ``pgcomm zoo``."""
    p.add_argument("--motors", type=int, required=True, metavar="N", help=f"number of motors (1 to {MAX_MOTORS})")
    p.add_argument("--seed", type=seed_value, default=0,
                   help="zoo seed, also the noise seed of --logs, 0 to 2**32-1 (default 0)")
    p.add_argument("--logs", action="store_true",
                   help="also write logs/Z{i}_coilset{l}.csv per motor (as pgcomm calibrate --save-data)")
    p.add_argument("--kind", choices=("linear", "rotary"), default="linear",
                   help="linear motors (force maps, default) or rotary PMSM/BLDC motors (motor.toml with "
                        "kind = \"rotary\" and truth.json; --logs writes running logs t, theta, velocity, iq_1, id_1, vq_1, vd_1)")
    p.add_argument("--control-per-log", type=int, default=None, metavar="K",
                   help="rotary: the drives control K times per logged sample and log a snapshot of every K-th cycle "
                        "(8 for an ODrive's 8 kHz loop logged at 1 kHz; 1: they control at their log rate; default: "
                        "drawn per motor, 4-16 kHz)")
    p.add_argument("--real-drive", action="store_true",
                   help="rotary: give every drive a real drive's and host's habits (current-sensor offsets and gain "
                        "mismatch, a filtered current report, a PLL angle, a host's jittered stamps, an index that "
                        "moves between power-ups), drawn per motor")
    p.add_argument("--stall", action="store_true",
                   help="rotary, with --logs: also write logs/stall.csv, a low-speed run in a speed loop too soft for "
                        "the cogging that stalls about halfway")
    add_common_options(p, out=True, plant=False)


def run(args, out: Path, progress) -> None:
    """Write ``out/motor_NN/`` for every motor (and its ``logs/`` with ``--logs``)."""
    from pgcomm.experiment import write_production_logs
    from pgcomm.zoo import draw_motor, motor_folder_name, write_motor

    n = args.motors
    if not 1 <= n <= MAX_MOTORS:
        raise ConfigError(f"--motors {n}: expected 1 to {MAX_MOTORS} motors")
    k = getattr(args, "control_per_log", None)
    if getattr(args, "kind", "linear") == "rotary":
        if k is not None and not 1 <= k <= 64:
            raise ConfigError(f"--control-per-log {k}: expected 1 to 64 control cycles per logged sample")
        if getattr(args, "stall", False) and not args.logs:
            raise ConfigError("--stall writes a log: give it with --logs")
        return _run_rotary(args, out, progress, n)
    if k is not None:
        raise ConfigError("--control-per-log: a rotary drive's control rate (--kind rotary)")
    for flag, name in (("real_drive", "--real-drive"), ("stall", "--stall")):
        if getattr(args, flag, False):
            raise ConfigError(f"{name}: a rotary drive's option (--kind rotary)")
    for i in range(1, n + 1):
        name = motor_folder_name(i, n)
        what = "force map and truth" + (", logs" if args.logs else "")
        with progress.stage(f"{name} ({i}/{n}): {what}"):
            m = draw_motor(args.seed, i - 1)
            folder = write_motor(m, out / name)
            if args.logs:
                write_production_logs(folder, seed=args.seed)
            progress.info(f"L = {m.n_coil_sets}, d_m = {m.pole_pitch * 1e3:.1f} mm, k ≈ {sum(m.k) / len(m.k):.1f} "
                          f"N/A, stroke {m.stroke:.3f} m, effects: {', '.join(m.effects) or 'none'}")
    if not args.quiet:
        print(f"wrote {n} motor folder(s) to {args.out}")


def _run_rotary(args, out: Path, progress, n: int) -> None:
    """``--kind rotary``: ``out/motor_NN/motor.toml`` + ``truth.json`` (+ ``logs/run{k}.csv`` and
    ``sweep/sweep.csv``, a slow standstill sweep for ``pgcomm identify --sweep``)."""
    from pgcomm.io.rotary_zoo import write_rotary_motor, write_running_logs, write_sweep_log
    from pgcomm.rotary.zoo import draw_rotary
    from pgcomm.zoo import motor_folder_name

    for i in range(1, n + 1):
        name = motor_folder_name(i, n)
        with progress.stage(f"{name} ({i}/{n}): rotary motor and truth"
                            + (", running logs, standstill sweep" if args.logs else "")):
            t = draw_rotary(args.seed, i - 1, args.control_per_log, real_drive=getattr(args, "real_drive", False))
            folder = write_rotary_motor(t, out / name)
            if args.logs:
                write_running_logs(t, folder / "logs", seed=args.seed, stall=getattr(args, "stall", False))
                write_sweep_log(t, folder / "sweep", seed=args.seed)
            progress.info(f"{t.motor.name}, k_t = {t.k_t:.3g} N·m/A, J = {t.inertia:.3g} kg·m², cogging "
                          f"{100 * t.cogging.rms() / (t.k_t * 0.5 * t.motor.current_limit):.1f} % of rated torque, "
                          f"ripple {100 * t.ripple.rms():.2f} %"
                          + (f", drive at {t.control_per_log} control cycles per logged sample"
                             if t.control_per_log > 1 else "")
                          + (f"; habits: {', '.join(t.habits())}" if t.habits() else ""))
    if not args.quiet:
        print(f"wrote {n} rotary motor folder(s) to {args.out}")
