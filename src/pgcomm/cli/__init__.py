"""The ``pgcomm`` command line: one module per command, listed in :data:`COMMANDS`.

User errors (bad files, bad options) print one line ``pgcomm: error: ...`` and exit
with code 2, without a traceback; outputs are staged in a temporary directory and
moved into ``--out`` only when the command succeeds (:func:`pgcomm.cli._common.staged_output`),
so a failed run leaves no half-written files.

Each command module has ``HELP`` (one line), ``configure(parser)`` (its options) and
``run(args, out, progress)``; ``out`` is the staging directory, or ``None`` for commands
without ``--out`` and for those that set ``STAGED_OUT = False`` (``fleet``: a resumable
workspace). The modules import the library lazily, inside ``run``, so that ``pgcomm --help``
stays fast. The front end imports the library, never the reverse.
"""

from __future__ import annotations

import argparse
import sys

from pgcomm.cli import calibrate, check, evaluate, export, fleet, identify, inspect, reproduce, simulate, zoo
from pgcomm.cli._common import staged_output, user_error_line
from pgcomm.errors import PgcommError

#: Every subcommand in the order ``pgcomm --help`` lists them: name -> command module.
COMMANDS = {
    "simulate": simulate,
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


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand of :data:`COMMANDS`."""
    from pgcomm import __version__

    parser = argparse.ArgumentParser(prog="pgcomm", description="Physics-guided commutation for linear motors.")
    parser.add_argument("--version", action="version", version=f"pgcomm {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, module in COMMANDS.items():
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.configure(p)
    return parser


def main(argv=None) -> int:
    """Entry point of the ``pgcomm`` console script (and ``python -m pgcomm``); returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    module = COMMANDS[args.command]
    from pgcomm.progress import Progress

    progress = Progress(enabled=not args.quiet)
    try:
        out = getattr(args, "out", None)
        if out is None or not getattr(module, "STAGED_OUT", True):
            module.run(args, None, progress)
        else:
            with staged_output(out) as tmp:
                module.run(args, tmp, progress)
    except PgcommError as e:
        print(f"pgcomm: error: {user_error_line(e)}", file=sys.stderr)
        return 2
    except FileNotFoundError as e:
        print(f"pgcomm: error: {e.filename}: file not found", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pgcomm: interrupted", file=sys.stderr)
        return 130
    return 0


__all__ = ["COMMANDS", "build_parser", "main"]
