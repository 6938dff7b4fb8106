"""The ``pgcomm`` command line: one module per command, listed in :data:`COMMANDS`.

User errors (bad files, bad options) print one line ``pgcomm: error: ...`` and exit
with code 2, without a traceback; outputs are staged in a temporary directory and
moved into ``--out`` only when the command succeeds (:func:`pgcomm.cli._output.staged_output`),
so a failed run leaves no half-written files.

Each command module has ``HELP`` (one line), ``configure(parser)`` (its options) and
``run(args, out, progress)``; ``out`` is the staging directory, or ``None`` for commands
without ``--out`` and for those that set ``STAGED_OUT = False`` (``fleet``: a resumable
workspace). The modules import the library lazily, inside ``run``, so that ``pgcomm --help``
stays fast. The front end imports the library, never the reverse.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading

# Process-wide settings belong to the program, not the library; set before NumPy or JAX load.
# OpenBLAS worker threads busy-wait against XLA's thread pool on small machines, which made
# NumPy/SciPy least squares ~20x slower next to JAX work: one BLAS thread is faster here.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

from pgcomm import __version__
from pgcomm._memory import release_compiled_programs
from pgcomm.cli import calibrate, check, evaluate, export, fleet, identify, inspect, plan, reproduce, simulate, zoo
from pgcomm.cli._common import user_error_line
from pgcomm.cli._output import input_paths, staged_output
from pgcomm.errors import PgcommError, SimulationError
from pgcomm.progress import Progress

#: Every subcommand in the order ``pgcomm --help`` lists them: name -> command module.
COMMANDS = {
    "simulate": simulate,
    "plan": plan,
    "calibrate": calibrate,
    "identify": identify,
    "reproduce": reproduce,
    "check": check,
    "evaluate": evaluate,
    "export": export,
    "inspect": inspect,
    "zoo": zoo,
    "fleet": fleet,
}


#: Largest ``--seed``: JAX and NumPy seeds are unsigned 32-bit integers.
MAX_SEED = 2**32 - 1


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``pgcomm: error: ...`` and exit code 2 (no usage block)."""

    def error(self, message):
        print(f"pgcomm: error: {' '.join(message.split())} (see '{self.prog} --help')", file=sys.stderr)
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand of :data:`COMMANDS`."""
    parser = _Parser(prog="pgcomm", description="Physics-guided commutation for linear and rotary permanent-magnet motors.")
    parser.add_argument("--version", action="version", version=f"pgcomm {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                help=", ".join(COMMANDS))
    for name, module in COMMANDS.items():
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.configure(p)
    return parser


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM, raised in the main thread so that staging folders are cleaned up."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: Signals received by this process's :func:`main` (the first decides the exit code).
_PENDING: list[int] = []


def _in_import(frame) -> bool:
    """Whether ``frame`` runs inside an ``import`` (a module body under :mod:`importlib`)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


#: Seconds between retries of an interrupt that arrived during an import.
_RETRY_S = 0.1


def _on_signal(signum, frame):
    # Further signals would interrupt the clean-up; the first one decides the exit code.
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    _PENDING.append(signum)
    if _in_finaliser(frame):
        return  # an exception here would be printed and dropped; the next checkpoint raises it
    if _in_import(frame):
        # An exception thrown through a module body that an extension (pybind11, XLA) is
        # initialising aborted the process (exit -6, once in 20 interrupts); retry after the import.
        signal.signal(signal.SIGALRM, _retry_interrupt)
        signal.setitimer(signal.ITIMER_REAL, _RETRY_S)
        return
    raise Interrupted(signum)


def _in_finaliser(frame) -> bool:
    """Whether ``frame`` runs inside a garbage collector's callback or a finaliser (JAX's ``_xla_gc_callback``, a
    ``__del__``): Python prints an exception raised there as "Exception ignored in ..." with a traceback, and drops
    it."""
    while frame is not None:
        if frame.f_code.co_name in ("_xla_gc_callback", "__del__"):
            return True
        frame = frame.f_back
    return False


def _retry_interrupt(signum, frame):
    """SIGALRM after an interrupt deferred by :func:`_on_signal`: raise it once outside any import and any
    finaliser (the retry, too, can land in a garbage collector's callback)."""
    if _in_import(frame) or _in_finaliser(frame):
        signal.setitimer(signal.ITIMER_REAL, _RETRY_S)
        return
    signal.signal(signal.SIGALRM, signal.SIG_DFL)
    raise Interrupted(_PENDING[0])


def _raise_if_interrupted() -> None:
    """Raise :class:`Interrupted` if a signal arrived whose exception was swallowed.

    A handler's exception that lands in a garbage-collector callback (JAX registers one) is
    printed and dropped by Python; checked at every progress step and before the outputs
    are moved into ``--out``.
    """
    if _PENDING:
        raise Interrupted(_PENDING[0])


def _wait_for_jax() -> None:
    """Block until computations JAX dispatched asynchronously have finished.

    Exiting the interpreter while XLA's threads still run a computation crashed with a
    segfault (exit 139); after this the process can exit normally.
    """
    jax = sys.modules.get("jax")
    if jax is None:
        return
    try:
        for a in jax.live_arrays():
            a.block_until_ready()
    except Exception:  # noqa: BLE001  (best effort on the way out)
        pass


def _where_from(e: Exception, args) -> str:
    """For a :class:`~pgcomm.errors.SimulationError`: the file its cause came from (reference or settings)."""
    if not isinstance(e, SimulationError):
        return ""
    config, reference = getattr(args, "config", None), getattr(args, "reference", None)
    plant = f"--plant {args.plant} with --motor {args.motor}" if getattr(args, "plant", None) else None
    if e.cause == "reference":
        if reference:
            return f" (the reference is --reference {reference})"
        if config:
            return f" (the reference is built from [reference] in --config {config})"
        return " (the default reference; set [reference] stroke in a --config file)"
    where = [w for w in (f"--config {config}" if config else None, plant) if w]
    return f" (settings from {' and '.join(where)})" if where else " (with the default settings)"


def compile_cache_dir() -> str | None:
    """Folder of JAX's persistent compilation cache used by the command line, or ``None`` if disabled.

    ``$PGCOMM_COMPILE_CACHE`` (empty: disabled), else ``$XDG_CACHE_HOME/pgcomm/jax`` (default
    ``~/.cache/pgcomm/jax``). A second run then loads the compiled XLA programs instead of
    compiling them again (``pgcomm reproduce --quick``: about 120 s -> 30 s on 2 cores); the
    compiled code, and so every number, is the same. A few MB.
    """
    env = os.environ.get("PGCOMM_COMPILE_CACHE")
    if env is not None:
        return env or None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "pgcomm", "jax")


def _enable_compile_cache() -> None:
    """Point JAX's persistent compilation cache at :func:`compile_cache_dir` (unless the user set one).

    Before JAX is loaded this only sets the environment variables JAX reads when it loads: a command
    that stops at a bad input before any computation (a damaged log) never loads JAX (~150 MB, 1-3 s).
    """
    path = compile_cache_dir()
    if path is None or os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return  # no writable cache folder: compile every time
    settings = {"jax_compilation_cache_dir": path, "jax_persistent_cache_min_compile_time_secs": 0.0,
                "jax_persistent_cache_min_entry_size_bytes": 0}
    jax = sys.modules.get("jax")
    if jax is None:
        for name, value in settings.items():
            os.environ.setdefault(name.upper(), str(value))
        return
    if jax.config.jax_compilation_cache_dir:
        return
    for name, value in settings.items():
        jax.config.update(name, value)


def main(argv=None) -> int:
    """Entry point of the ``pgcomm`` console script (and ``python -m pgcomm``); returns the exit code.

    Exit codes: 0 success, 1 a finding (``pgcomm check``), 2 bad input (one line
    ``pgcomm: error: ...``), 130 SIGINT, 143 SIGTERM (``--out`` left as it was).
    """
    _PENDING.clear()
    handlers = {}
    if threading.current_thread() is threading.main_thread():  # first thing: no window without a handler
        handlers = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _main(argv, handlers)
    except KeyboardInterrupt as e:  # a signal before the command started: nothing was written
        signum = getattr(e, "signum", signal.SIGINT)
        print(f"pgcomm: interrupted ({signal.Signals(signum).name}); --out left as it was", file=sys.stderr)
        return 128 + int(signum)
    finally:
        if handlers:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
        for s, h in handlers.items():
            signal.signal(s, h)


def _main(argv, handlers) -> int:
    """:func:`main` with the signal handlers installed."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:
        return int(e.code or 0) if not isinstance(e.code, str) else 2
    module = COMMANDS[args.command]
    # between stages: a finished stage's compiled programs go (reloaded from the persistent compile cache if a
    # later stage needs them again), so a command's memory is that of its largest stage, not of all of them
    progress = Progress(enabled=not args.quiet, checkpoint=_raise_if_interrupted,
                        on_stage=release_compiled_programs)
    if args.command not in ("inspect",):
        _enable_compile_cache()
    try:
        out = getattr(args, "out", None)
        if out is None or not getattr(module, "STAGED_OUT", True):
            module.run(args, None, progress)
        else:
            with staged_output(out, getattr(args, "overwrite", False), input_paths(args)) as tmp:
                module.run(args, tmp, progress)
                _raise_if_interrupted()  # never commit the outputs of an interrupted run
    except PgcommError as e:
        print(f"pgcomm: error: {user_error_line(e)}{_where_from(e, args)}", file=sys.stderr)
        return 2
    except FileNotFoundError as e:
        print(f"pgcomm: error: {e.filename}: file not found", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:
        signum = getattr(e, "signum", signal.SIGINT)
        _wait_for_jax()
        print(f"pgcomm: interrupted ({signal.Signals(signum).name}); --out left as it was", file=sys.stderr)
        return 128 + int(signum)
    return 0


def entry() -> None:
    """The ``pgcomm`` console script and ``python -m pgcomm``: :func:`main`, then end the process.

    After SIGINT/SIGTERM (exit 130/143) :func:`main` has already removed the staging folder and
    printed its line; the process then ends with :func:`os._exit`, without the interpreter's
    teardown. That teardown runs into XLA's threads and crashed with SIGSEGV (exit −11 instead of
    130) about once in two full test runs on a loaded 2-core machine; nothing is left
    to flush or close that ``os._exit`` would skip.
    """
    code = main()
    if code in (128 + int(signal.SIGINT), 128 + int(signal.SIGTERM)):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


__all__ = ["COMMANDS", "MAX_SEED", "build_parser", "entry", "main"]
