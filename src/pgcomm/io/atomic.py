"""Atomic file writing: a file is either fully written or not there at all.

Every writer in :mod:`pgcomm.io` writes to a temporary file in the *same*
directory as the target and then renames it over the target with
:func:`os.replace`. A rename within one file system is atomic on POSIX and
Windows, so a crash, an exception or Ctrl-C half way never leaves a truncated
results file, log or force map behind (DESIGN, "Bad input": no half-written
output files). The temporary file lives next to the target (not in ``/tmp``)
because a rename across file systems would be a copy, which is not atomic.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from pgcomm.errors import ConfigError

__all__ = ["atomic_path", "atomic_open", "atomic_write_text", "atomic_write_bytes"]


def _read_umask() -> int:
    """The process umask (read by setting and restoring it; there is no getter)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


# Read once at import: os.umask briefly changes process state, which other threads could observe.
_UMASK = _read_umask()


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path next to ``path``; on success rename it to ``path``.

    For libraries that insist on writing to a path themselves (pyarrow, h5py,
    ``numpy.savez``). The temporary name keeps ``path``'s suffix so that such
    libraries do not append their own. If the body raises, the temporary file
    is removed and ``path`` is left untouched.

    Args:
        path: target file (str or Path). Its directory must exist.

    Yields:
        :class:`pathlib.Path` of the temporary file (already created, empty).

    Raises:
        ConfigError: the directory does not exist or is not writable.
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=directory)
    except FileNotFoundError:
        raise ConfigError(f"{path}: cannot write, directory '{directory}' does not exist") from None
    except NotADirectoryError:
        raise ConfigError(f"{path}: cannot write, '{directory}' is not a directory") from None
    except PermissionError:
        raise ConfigError(f"{path}: cannot write, no permission to create files in '{directory}'") from None
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        # Flush the data to disk before the rename makes it visible under the real name.
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        # mkstemp creates the file with mode 0600; give it the mode a plain open() would.
        os.chmod(tmp, 0o666 & ~_UMASK)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_open(path, mode: str = "w", encoding: str | None = "utf-8", newline: str | None = None):
    """Open a temporary file next to ``path`` for writing; rename it to ``path`` on success.

    The data is fsync-ed before the rename (in :func:`atomic_path`) so that the
    rename never exposes a file whose contents are still only in the page cache.

    Args:
        path: target file.
        mode: ``"w"`` (text) or ``"wb"`` (binary).
        encoding, newline: as for :func:`open` (ignored in binary mode).

    Yields:
        the open file object.
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open mode must be 'w' or 'wb', not {mode!r}")
    with atomic_path(path) as tmp:
        kwargs = {} if "b" in mode else {"encoding": encoding, "newline": newline}
        with open(tmp, mode, **kwargs) as f:
            yield f


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_open(path, "w", encoding=encoding, newline="") as f:
        f.write(text)


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_open(path, "wb") as f:
        f.write(data)
