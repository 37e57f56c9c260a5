"""Atomic file output: write to a temporary file in the target directory, then rename.

Every result file of the package is written this way, so a failure (bad input found late,
a full disk, an interrupt) never leaves a half-written file at the target path; an existing
file there stays unchanged until the new one is complete. The file gets the permissions a
plain ``open(path, 'w')`` would give (``0o666`` minus the umask), not ``mkstemp``'s ``0o600``.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from exudyn_study.errors import InputError

__all__ = ["atomic_write", "write_text_atomic"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write(path: str | os.PathLike, write: Callable[[Path], None], what: str = "output file") -> Path:
    """Call ``write(tmp)`` on a temporary path next to ``path``, then move it to ``path``.

    Parameters
    ----------
    path : path-like
        Target; its directory must exist.
    write : callable
        Writes the complete file at the given temporary path (its suffix is that of ``path``).
    what : str
        Name of the output for the error message (e.g. ``'--json'``).

    Raises
    ------
    InputError
        If the directory of ``path`` does not exist. Errors of ``write`` propagate; the
        temporary file is removed.
    """
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise InputError(
            f"{what} {str(path)!r}: directory {str(directory)!r} does not exist; create it first")
    fd, tmp_name = tempfile.mkstemp(dir=directory, prefix=f".{path.name}.", suffix=f".tmp{path.suffix}")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def write_text_atomic(path: str | os.PathLike, text: str, what: str = "output file") -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_write`).

    Parameters
    ----------
    path : str or os.PathLike
        File to write; an existing file is replaced.
    text : str
        Content to write, encoded as UTF-8.
    what : str, default "output file"
        Description of the file used in error messages.

    Returns
    -------
    pathlib.Path
        The written path.
    """
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"), what)
