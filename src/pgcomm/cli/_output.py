"""The output folder of every command: checked before any work, filled in a staging folder, moved into place on
success (``--out DIR``, ``--overwrite``)."""

from __future__ import annotations

import glob
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from pgcomm.errors import ConfigError


#: Folders that ``--out ... --overwrite`` never replaces (the whole folder would be deleted).
def _protected_dirs() -> set[Path]:
    home = Path.home().resolve()
    cwd = Path.cwd().resolve()
    return {home, cwd, *cwd.parents, Path(cwd.anchor)}


def refuse_working_folder(out: Path, option: str = "--out") -> Path:
    """Refuse an output folder that is the current folder or one of its parents; return it resolved.

    Every command replaces its output folder as a whole (or, ``fleet``, fills it): ``--out ''`` or
    ``--out .`` would replace the folder the shell stands in, and a parent would take the current folder
    with it. Symbolic links are followed, so a link to the current folder is refused too.

    Raises:
        ConfigError: one line naming ``option`` and the folder.
    """
    resolved = Path(out).resolve()
    cwd = Path.cwd().resolve()
    if resolved == cwd or resolved in cwd.parents:
        what = "the current folder" if resolved == cwd else f"a parent of the current folder {cwd}"
        raise ConfigError(f"{option} {str(out)!r}: is {what}; the outputs go into a new or empty folder of their "
                          f"own, e.g. {option} results")
    return resolved


def input_paths(args) -> list[Path]:
    """The files and folders a command reads, from its parsed options: every path-valued option but the
    outputs, and the files that ``--data`` / ``--sweep`` patterns match (resolved)."""
    found = []
    for dest, value in vars(args).items():
        if dest in ("out", "report_dir"):
            continue
        if isinstance(value, Path):
            found.append(value)
        elif dest in ("data", "sweep") and isinstance(value, (list, tuple)):
            for pattern in value:
                found += [Path(m) for m in glob.glob(str(pattern))] or [Path(pattern)]
    return [p.resolve() for p in found]


def check_out(out: Path, overwrite: bool = False, inputs=()) -> Path:
    """Check ``--out DIR`` before any work is done; return the nearest existing folder (where staging goes).

    Rules (DESIGN, "--out"): ``DIR`` is never the current folder or one of its parents
    (:func:`refuse_working_folder`); missing parent folders are created (at the end, on success); the
    command fails only where a path component exists as a file or the nearest existing folder is
    not writable. An existing ``DIR`` that holds anything is refused unless ``overwrite``: then the
    whole folder is replaced by the new outputs (never the home or root folder, nor a folder holding
    one of the run's own ``inputs``, which the replacement would delete).

    Args:
        out: the ``--out`` folder; overwrite: ``--overwrite`` given;
        inputs: paths the command reads (:func:`input_paths`).

    Raises:
        ConfigError: one line naming ``--out`` and what to do.
    """
    out = Path(out)
    resolved = refuse_working_folder(out)
    for comp in [resolved, *resolved.parents]:
        if comp.exists() and not comp.is_dir():
            raise ConfigError(f"--out {out}: '{comp}' exists and is a file, not a folder; "
                              "choose another --out or move the file")
    if resolved.exists() and any(resolved.iterdir()):
        if not overwrite:
            names = sorted(p.name for p in resolved.iterdir())
            shown = ", ".join(names[:3]) + (", ..." if len(names) > 3 else "")
            raise ConfigError(f"--out {out}: folder exists and is not empty ({len(names)} entries: {shown}); "
                              "pass --overwrite to replace the whole folder with this run's outputs, "
                              "or choose a new --out")
        if resolved in _protected_dirs():
            raise ConfigError(f"--out {out}: refusing to replace the current, home or root folder with "
                              "--overwrite; give a subfolder")
        for p in inputs:
            if p == resolved or resolved in p.parents:
                raise ConfigError(f"--out {out} --overwrite would delete '{p}', which this run reads; "
                                  "choose another --out")
    base = resolved.parent  # staging goes beside (never inside) DIR, in its nearest existing ancestor
    while not base.exists():
        base = base.parent
    if not os.access(base, os.W_OK | os.X_OK):
        raise ConfigError(f"--out {out}: folder '{base}' is not writable; choose a writable --out")
    return base


@contextmanager
def staged_output(out: Path, overwrite: bool = False, inputs=()):
    """Yield an empty staging folder ``.NAME.xxxxxxxx``; on success it becomes ``out``.

    ``out`` is checked first (:func:`check_out`, with the run's ``inputs``). The staging folder sits in the nearest
    existing folder of ``out`` (same file system, so the final rename is atomic). On success the
    missing parents of ``out`` are created and the staging folder is renamed to ``out``; an
    existing ``out`` (empty, or non-empty with ``overwrite``) is replaced as a whole, so no stale
    file of an earlier run survives beside the new ones. On any exception (including
    ``KeyboardInterrupt`` and ``SystemExit`` from a signal) the staging folder is removed and
    ``out`` is left as it was.
    """
    out = Path(out)
    base = check_out(out, overwrite, inputs)
    resolved = out.resolve()
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{resolved.name}.", dir=base))
    except OSError as e:
        raise ConfigError(f"--out {out}: cannot create a folder in '{base}' ({e.strerror}); "
                          "choose a writable --out") from None
    old = None
    try:
        yield tmp
        try:
            resolved.parent.mkdir(parents=True, exist_ok=True)
            if resolved.exists():
                old = Path(tempfile.mkdtemp(prefix=f".{resolved.name}.old.", dir=resolved.parent))
                os.replace(resolved, old / "out")
            os.replace(tmp, resolved)
        except OSError as e:
            if old is not None and not resolved.exists():
                os.replace(old / "out", resolved)
            raise ConfigError(f"--out {out}: cannot move the outputs into place ({e.strerror})") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
