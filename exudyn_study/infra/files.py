"""Checked file input and transactional file output for the command line and the studies.

Inputs
------
:func:`check_input_file` is the one entry for every file a command reads: the path must
name an existing regular file that is readable, not empty and not larger than a limit
(so a FIFO, a device or a directory is refused before a reader blocks on it or reads
gigabytes). :func:`read_text_input`, :func:`load_json_input` and :func:`load_toml_input`
add a strict UTF-8 decode and a parse whose every failure (syntax, NaN/Infinity, integers
of thousands of digits, nesting deep enough for a ``RecursionError``) is an
:class:`~exudyn_study.errors.InputError` naming the option and the file.

Outputs
-------
:class:`OutputSet` is the one entry for every file a command writes. Each output is
declared before any computation: it is refused when it is one of the inputs (same
resolved path or same inode), when it names an existing directory where a file is
expected (or the other way round), when two outputs are the same path, or when its
directory cannot be written (tested by creating the staging directory there, which also
works for root and on read-only file systems). The command writes into staging paths;
when it finishes, every staged file is renamed onto its target (missing directories are
created then); when it fails, the staging directories and any directory it would have
created are removed, so nothing is left behind and no existing file is touched.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from exudyn_study.errors import InputError

__all__ = [
    "MAX_TEXT_BYTES",
    "MAX_RECORDING_BYTES",
    "OutputSet",
    "check_input_file",
    "read_text_input",
    "load_json_input",
    "load_toml_input",
    "parse_json_text",
    "nearest_existing_dir",
]

#: largest JSON/TOML input read (bytes): configuration and result files are kilobytes; a
#: larger file is not one of them and would be parsed into memory whole
MAX_TEXT_BYTES = 64 * 1024 * 1024
#: largest recording read (bytes): 43 channels x 1000 Hz x 3 h x 8 B is 3.7 GB
MAX_RECORDING_BYTES = 8 * 1024**3
#: largest integer literal accepted in JSON (digits); Python refuses > 4300 digits with a
#: ValueError anyway, and no quantity of this package needs more than a few dozen
MAX_INT_DIGITS = 30
#: deepest JSON/TOML nesting accepted; the package's files nest 4 levels
MAX_NESTING = 64


def check_input_file(path: str | os.PathLike, option: str, *, max_bytes: int = MAX_TEXT_BYTES,
                     suffixes: Iterable[str] | None = None) -> Path:
    """Return ``path`` as a Path after checking it names a readable, non-empty regular file.

    Parameters
    ----------
    path : path-like
        The file given on the command line.
    option : str
        The option that named it (``'--target'``), for the message.
    max_bytes : int
        Largest accepted size in bytes.
    suffixes : iterable of str, optional
        Accepted suffixes (lower case, with the dot); None accepts any.

    Raises
    ------
    InputError
        Missing file, a directory or special file, unreadable, empty, too large, wrong suffix.
    """
    p = Path(path)
    where = f"{option} {str(p)!r}"
    if not str(path):
        raise InputError(f"{option}: empty file name; give the path of the file")
    if suffixes is not None:
        allowed = tuple(suffixes)
        if p.suffix.lower() not in allowed:
            raise InputError(f"{where}: suffix {p.suffix!r} not accepted; expected {', '.join(allowed)}")
    try:
        st = p.stat()
    except FileNotFoundError:
        raise InputError(f"{where} does not exist; check the path") from None
    except OSError as exc:
        raise InputError(f"{where} cannot be read ({exc.strerror}); check the path") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{where} is a directory; expected a file")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{where} is not a regular file (a pipe or device); expected a file")
    if not os.access(p, os.R_OK):
        raise InputError(f"{where} is not readable (permissions); check its mode")
    if st.st_size == 0:
        raise InputError(f"{where} is empty; expected the file's content")
    if st.st_size > max_bytes:
        raise InputError(
            f"{where} holds {st.st_size} bytes, more than the {max_bytes} accepted for this kind of file")
    return p


def read_text_input(path: str | os.PathLike, option: str, *, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """Read a checked input file as strict UTF-8 (see :func:`check_input_file`).

    Parameters
    ----------
    path : path-like
        The file given on the command line.
    option : str
        The option that named it (``'--config'``), for the message.
    max_bytes : int, optional
        Largest accepted size in bytes; a larger file is refused before it is read.

    Returns
    -------
    str
        The file's whole content.

    Raises
    ------
    InputError
        If the file fails :func:`check_input_file`, cannot be read, or is not valid UTF-8 (the
        message names the offending byte's position).
    """
    p = check_input_file(path, option, max_bytes=max_bytes)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(f"{option} {str(p)!r} cannot be read ({exc.strerror})") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{option} {str(p)!r}: not UTF-8 text (byte {exc.start}: {raw[exc.start:exc.start + 1]!r}); "
            "save the file as UTF-8") from None


def _depth(value: Any, limit: int) -> int:
    """Nesting depth of lists/dicts, iterative (no recursion on hostile input)."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, (list, dict)):
            deepest = max(deepest, d)
            if deepest > limit:
                return deepest
            stack.extend((c, d + 1) for c in (v.values() if isinstance(v, dict) else v))
    return deepest


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows; write a finite number or null")


def _parse_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise ValueError(f"an integer of {len(text.lstrip('-'))} digits; at most {MAX_INT_DIGITS} accepted")
    return int(text)


def _parse_float(text: str) -> float:
    value = float(text)
    if value in (float("inf"), float("-inf")):
        raise ValueError(f"{text[:20]} overflows a double; write a finite number")
    return value


def parse_json_text(text: str, where: str) -> Any:
    """Parse JSON text strictly (no NaN/Infinity, bounded integers and nesting); InputError on failure.

    Parameters
    ----------
    text : str
        The JSON document.
    where : str
        Where the text comes from, the start of every message (e.g. ``"--json 'result.json'"``).

    Returns
    -------
    Any
        The parsed value (dict, list, str, int, float, bool or None).

    Raises
    ------
    InputError
        If the text is not valid JSON, holds ``NaN``/``Infinity`` or a float that overflows a
        double, an integer of more than ``MAX_INT_DIGITS`` digits, or nests more than
        ``MAX_NESTING`` levels.
    """
    try:
        value = json.loads(text, parse_constant=_reject_constant, parse_int=_parse_int,
                           parse_float=_parse_float)
    except RecursionError:
        raise InputError(f"{where}: nested too deeply to parse; at most {MAX_NESTING} levels") from None
    except ValueError as exc:  # JSONDecodeError is a ValueError
        raise InputError(f"{where}: not valid JSON ({_one_line(exc)})") from None
    if _depth(value, MAX_NESTING) > MAX_NESTING:
        raise InputError(f"{where}: nested more than {MAX_NESTING} levels; not a file of this package")
    return value


def load_json_input(path: str | os.PathLike, option: str, *, max_bytes: int = MAX_TEXT_BYTES) -> Any:
    """Read and parse a JSON input file strictly (see :func:`parse_json_text`).

    Parameters
    ----------
    path : path-like
        The file given on the command line.
    option : str
        The option that named it (``'--json'``), for the message.
    max_bytes : int, optional
        Largest accepted size in bytes; a larger file is refused before it is read.

    Returns
    -------
    Any
        The parsed value.

    Raises
    ------
    InputError
        If the file fails :func:`read_text_input` or its text fails :func:`parse_json_text`.
    """
    text = read_text_input(path, option, max_bytes=max_bytes)
    return parse_json_text(text, f"{option} {str(path)!r}")


def load_toml_input(path: str | os.PathLike, option: str, *, max_bytes: int = MAX_TEXT_BYTES) -> dict:
    """Read and parse a TOML input file; every parse failure is an InputError.

    Parameters
    ----------
    path : path-like
        The file given on the command line.
    option : str
        The option that named it (``'--config'``), for the message.
    max_bytes : int, optional
        Largest accepted size in bytes; a larger file is refused before it is read.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    InputError
        If the file fails :func:`read_text_input`, is not valid TOML, or nests more than
        ``MAX_NESTING`` levels.
    """
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib

    text = read_text_input(path, option, max_bytes=max_bytes)
    where = f"{option} {str(path)!r}"
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise InputError(f"{where}: nested too deeply to parse; at most {MAX_NESTING} levels") from None
    except (tomllib.TOMLDecodeError, ValueError) as exc:
        raise InputError(f"{where}: TOML syntax error: {_one_line(exc)}") from None
    if _depth(data, MAX_NESTING) > MAX_NESTING:
        raise InputError(f"{where}: nested more than {MAX_NESTING} levels; not a file of this package")
    return data


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:200]


def nearest_existing_dir(path: Path, option: str) -> Path:
    """Return the deepest existing ancestor of ``path``; InputError if it is a file.

    This is the directory in which an output that does not exist yet will be created, so its
    writability can be checked before any work.

    Parameters
    ----------
    path : Path
        An output path, which need not exist; a relative path is taken from the working
        directory.
    option : str
        The option that named it (``'--out'``), for the message.

    Returns
    -------
    Path
        The absolute path of ``path`` itself when it exists, else of its deepest existing
        ancestor.

    Raises
    ------
    InputError
        If that existing path is not a directory (a file is in the way).
    """
    current = Path(os.path.abspath(path))
    while not current.exists():
        if current.parent == current:
            break
        current = current.parent
    if not current.is_dir():
        raise InputError(f"{option} {str(path)!r}: {str(current)!r} is a file, not a directory; "
                         "choose a path inside a directory")
    return current


def _same_file(a: Path, b: Path) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        sa, sb = a.stat(), b.stat()
    except OSError:
        return False
    return (sa.st_dev, sa.st_ino) == (sb.st_dev, sb.st_ino)


@dataclass(frozen=True)
class _Output:
    target: Path
    staged: Path
    option: str
    is_dir: bool


class OutputSet:
    """Every output of one run: declared and checked first, written staged, renamed together at the end.

    Use as a context manager::

        with OutputSet(inputs={"--measured": args.measured}) as outputs:
            json_path = outputs.file(args.json, "--json")     # checked now, before any work
            plots = outputs.directory(args.plots, "--plots")
            ... compute, write to json_path and into plots ...
        # on success every staged file is now at its target; on an exception nothing is

    Parameters
    ----------
    inputs : mapping of option -> path or list of paths, optional
        Files the run reads; an output that is one of them is refused.
    """

    def __init__(self, inputs: dict[str, Any] | None = None) -> None:
        self._inputs: list[tuple[str, Path]] = []
        for option, value in (inputs or {}).items():
            self.add_input(option, value)
        self._outputs: list[_Output] = []
        self._staging: dict[Path, Path] = {}  # existing ancestor -> its staging directory
        self._committed = False

    def add_input(self, option: str, value: Any) -> None:
        """Register input file(s) that no output may overwrite.

        Parameters
        ----------
        option : str
            The option that named the input(s) (``'--measured'``), for the message.
        value : path-like, list or tuple of path-like, or None
            The input path(s); None, None entries and empty paths are ignored.
        """
        if value is None:
            return
        values = value if isinstance(value, (list, tuple)) else [value]
        self._inputs.extend((option, Path(v)) for v in values if v is not None and str(v))

    def _stage_dir(self, where: Path, target: Path, option: str) -> Path:
        """Return the staging directory in the deepest existing ancestor of ``where`` (a write test)."""
        anchor = nearest_existing_dir(where, option)
        if anchor not in self._staging:
            try:
                self._staging[anchor] = Path(tempfile.mkdtemp(prefix=".exudyn-study-", suffix=".tmp",
                                                              dir=anchor))
            except OSError as exc:
                raise InputError(f"{option} {str(target)!r}: directory {str(anchor)!r} is not writable "
                                 f"({exc.strerror}); choose another location") from None
        return self._staging[anchor]

    def _check_target(self, target: Path, option: str, is_dir: bool) -> None:
        if not str(target):
            raise InputError(f"{option}: empty path; give a file name")
        if is_dir:
            if target.exists() and not target.is_dir():
                raise InputError(f"{option} {str(target)!r} is a file; expected a directory (it is created "
                                 "when missing)")
        else:
            if target.is_dir():
                raise InputError(f"{option} {str(target)!r} is a directory; give a file name inside it")
            if target.exists() and not target.is_file():
                raise InputError(f"{option} {str(target)!r} is not a regular file; choose another name")
        for in_option, src in self._inputs:
            if _same_file(src, target):
                raise InputError(f"{option} {str(target)!r} is the input {in_option} {str(src)!r}; "
                                 "writing it would destroy the input: choose another name")
        for out in self._outputs:
            if os.path.realpath(out.target) == os.path.realpath(target):
                raise InputError(f"{option} {str(target)!r} and {out.option} {str(out.target)!r} are the "
                                 "same output; give them different paths")

    def file(self, path: str | os.PathLike | None, option: str) -> Path | None:
        """Declare an output file; return the staging path to write it to (None stays None).

        Parameters
        ----------
        path : path-like or None
            The output file's target path; None (an output not asked for) declares nothing.
        option : str
            The option that named it (``'--json'``), for the messages.

        Returns
        -------
        Path or None
            Where to write the file now: inside a staging directory, named after the target
            with its suffix kept (so a writer that picks the format by suffix still works); it
            is renamed onto ``path`` at :meth:`commit`. None if ``path`` is None.

        Raises
        ------
        InputError
            The path is an input, a directory, another output, or in an unwritable place.
        """
        if path is None:
            return None
        target = Path(path)
        self._check_target(target, option, is_dir=False)
        stage = self._stage_dir(target.parent, target, option)
        staged = stage / f"{len(self._outputs):03d}-{target.name}"  # keeps the suffix (format)
        self._outputs.append(_Output(target, staged, option, False))
        return staged

    def directory(self, path: str | os.PathLike | None, option: str) -> Path | None:
        """Declare an output directory (created at the end when missing); return its staging directory.

        Files written into the staging directory are moved into ``path`` at the end,
        replacing files of the same name there; other files in ``path`` are kept.

        Parameters
        ----------
        path : path-like or None
            The output directory's target path; None (an output not asked for) declares nothing.
        option : str
            The option that named it (``'--plots'``), for the messages.

        Returns
        -------
        Path or None
            The staging directory to write into now; None if ``path`` is None.

        Raises
        ------
        InputError
            The path is empty, a file, an input, another output, or in an unwritable place.
        """
        if path is None:
            return None
        target = Path(path)
        self._check_target(target, option, is_dir=True)
        staged = self._stage_dir(target, target, option) / f"{len(self._outputs):03d}-dir"
        staged.mkdir()
        self._outputs.append(_Output(target, staged, option, True))
        return staged

    # ------------------------------------------------------------------ transaction

    def commit(self) -> list[Path]:
        """Move every staged output onto its target; return the targets written."""
        written: list[Path] = []
        for out in self._outputs:
            if out.is_dir:
                out.target.mkdir(parents=True, exist_ok=True)
                for src in sorted(out.staged.rglob("*")):
                    if src.is_dir():
                        continue
                    dest = out.target / src.relative_to(out.staged)
                    dest.parent.mkdir(parents=True, exist_ok=True)
                    os.chmod(src, 0o666 & ~_umask())
                    os.replace(src, dest)
                    written.append(dest)
            elif out.staged.exists():
                out.target.parent.mkdir(parents=True, exist_ok=True)
                os.chmod(out.staged, 0o666 & ~_umask())
                os.replace(out.staged, out.target)
                written.append(out.target)
        self._committed = True
        self.discard()
        return written

    def discard(self) -> None:
        """Remove the staging directories (and everything staged in them)."""
        for stage in self._staging.values():
            shutil.rmtree(stage, ignore_errors=True)
        self._staging.clear()

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            try:
                self.commit()
            finally:
                self.discard()
        else:
            self.discard()
        return False


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
