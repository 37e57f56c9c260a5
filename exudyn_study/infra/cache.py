"""Content-addressed disk cache for expensive artefacts (reduced bodies).

An entry is keyed by the SHA-256 of a canonical JSON "recipe" (geometry parameters,
mesh size, materials, reduction settings, code version) and stored as two files:

- ``<key>.npz``: the arrays (uncompressed NumPy archive);
- ``<key>.json``: the manifest, a JSON object: format version, the recipe, and the
  SHA-256 of the npz.

Concurrency: every change of an entry happens under an exclusive lock on ``<key>.lock``
(``fcntl.flock``), and each file is written to a temporary file and renamed (npz first,
manifest last). A builder takes the lock, looks again (another process may have built the
entry meanwhile), builds, writes and releases, so concurrent builders of one key build it
once and never remove each other's files. A reader reads without the lock, holding the
npz bytes in memory so the checksum and the arrays come from the same bytes; when what it
reads is inconsistent (a manifest and data out of step, caught while a writer renames
them), it takes the lock, waits for the writer and reads again. Only an entry that is still
corrupt or stale under the lock (manifest not a JSON object, recipe or format differs,
checksum mismatch, npz unreadable) is logged, deleted and rebuilt, never used.

The cache directory is ``$EXUDYN_STUDY_CACHE`` if set, else ``~/.cache/exudyn_study``;
a path that is a file or cannot be created is an :class:`~exudyn_study.errors.InputError`.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import logging
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: entries are still written whole, unlocked
    fcntl = None

__all__ = ["cache_dir", "recipe_key", "load_entry", "store_entry", "cached", "entry_lock"]

log = logging.getLogger(__name__)

#: Bump when the stored layout changes: older entries are then rebuilt.
CACHE_FORMAT_VERSION = 1


def cache_dir(directory: str | os.PathLike | None = None) -> Path:
    """Return (and create) the cache directory.

    Parameters
    ----------
    directory : str or os.PathLike, optional
        Cache directory to use. None uses ``$EXUDYN_STUDY_CACHE`` if set, else
        ``~/.cache/exudyn_study``.

    Returns
    -------
    pathlib.Path
        The existing, writable cache directory.

    Raises
    ------
    InputError
        If the path (or a parent) is a file, or the directory cannot be created or written.
    """
    source = "--cache-dir"
    if directory is None:
        env = os.environ.get("EXUDYN_STUDY_CACHE")
        directory, source = (env, "$EXUDYN_STUDY_CACHE") if env else (
            Path.home() / ".cache" / "exudyn_study", "cache directory")
    path = Path(directory)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise InputError(f"{source} {str(path)!r}: a file is in the way; give a directory") from None
    except OSError as exc:
        raise InputError(f"{source} {str(path)!r} cannot be created ({exc.strerror}); give a writable "
                         "directory") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{source} {str(path)!r} is not writable; give a writable directory")
    return path


def _canonical(recipe: Mapping) -> str:
    return json.dumps(recipe, sort_keys=True, separators=(",", ":"), default=str)


def recipe_key(recipe: Mapping) -> str:
    """SHA-256 hex digest of the canonical JSON of ``recipe``.

    Parameters
    ----------
    recipe : Mapping
        JSON-serialisable description of what an entry is built from.

    Returns
    -------
    str
        64-character hex digest that names the entry.
    """
    return hashlib.sha256(_canonical(recipe).encode()).hexdigest()


def _remove(*paths: Path) -> None:
    for p in paths:
        try:
            p.unlink()
        except FileNotFoundError:
            pass


@contextlib.contextmanager
def entry_lock(root: Path, key: str) -> Iterator[None]:
    """Hold the exclusive lock of cache entry ``key`` in ``root`` (blocks until it is free).

    A context manager: the lock (``fcntl.flock`` on ``<key>.lock``, created when missing) is
    held for the body of the ``with`` block and released when it ends, also on an exception.
    Every change of an entry happens under it, so concurrent builders of one key build it once
    and never remove each other's files. Without ``fcntl`` (not POSIX) nothing is locked.

    Parameters
    ----------
    root : Path
        The cache directory (as returned by :func:`cache_dir`); it must exist.
    key : str
        The entry's key, the SHA-256 hex digest of its recipe (:func:`recipe_key`).

    Yields
    ------
    None
        Control, while the lock is held.
    """
    if fcntl is None:  # pragma: no cover
        yield
        return
    with open(root / f"{key}.lock", "a+b") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def _try_load(root: Path, key: str, recipe: Mapping) -> tuple[dict[str, np.ndarray] | None, str | None]:
    """Return ``(arrays, None)`` on a hit, ``(None, None)`` on a miss, ``(None, problem)`` otherwise."""
    manifest_path, data_path = root / f"{key}.json", root / f"{key}.npz"
    try:
        text = manifest_path.read_bytes()
    except FileNotFoundError:
        return None, None
    try:
        manifest = json.loads(text.decode("utf-8"))
        if not isinstance(manifest, dict):
            return None, f"manifest is a JSON {type(manifest).__name__}, not an object"
        if manifest.get("format_version") != CACHE_FORMAT_VERSION:
            return None, f"format {manifest.get('format_version')!r} != {CACHE_FORMAT_VERSION}"
        if _canonical(manifest.get("recipe", {})) != _canonical(json.loads(_canonical(recipe))):
            return None, "recipe differs from the request"
        try:
            raw = data_path.read_bytes()
        except FileNotFoundError:
            return None, "data file missing"
        if hashlib.sha256(raw).hexdigest() != manifest.get("sha256"):
            return None, "checksum mismatch"
        with np.load(io.BytesIO(raw), allow_pickle=False) as npz:
            return {name: npz[name] for name in npz.files}, None
    except (OSError, ValueError, KeyError, TypeError, RecursionError, UnicodeDecodeError) as exc:
        return None, f"unreadable ({type(exc).__name__}: {exc})"


def load_entry(recipe: Mapping, directory: str | os.PathLike | None = None) -> dict[str, np.ndarray] | None:
    """Return the cached arrays for ``recipe``, or None on a miss.

    An entry found inconsistent is read again under the entry's lock (a writer may have
    been renaming its files); one that is still corrupt or stale is logged, deleted and
    reported as a miss.

    Parameters
    ----------
    recipe : Mapping
        JSON-serialisable description of the entry (see :func:`recipe_key`).
    directory : str or os.PathLike, optional
        Cache directory (None: the default of :func:`cache_dir`).

    Returns
    -------
    dict of str to numpy.ndarray or None
        The stored arrays by name, or None if there is no valid entry.
    """
    root = cache_dir(directory)
    key = recipe_key(recipe)
    arrays, problem = _try_load(root, key, recipe)
    if arrays is not None or problem is None:
        return arrays
    with entry_lock(root, key):
        return _load_locked(root, key, recipe)


def _load_locked(root: Path, key: str, recipe: Mapping) -> dict[str, np.ndarray] | None:
    arrays, problem = _try_load(root, key, recipe)
    if problem is not None:
        log.warning("cache entry %s is corrupt or stale (%s); rebuilding it", key[:12], problem)
        _remove(root / f"{key}.json", root / f"{key}.npz")
    return arrays


def _atomic_write(path: Path, write: Callable[[Path], None]) -> None:
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        write(tmp_path)
        os.replace(tmp_path, path)
    except BaseException:
        _remove(tmp_path)
        raise


def _store_locked(root: Path, key: str, recipe: Mapping, arrays: Mapping[str, np.ndarray]) -> None:
    buffer = io.BytesIO()
    np.savez(buffer, **{k: np.asarray(v) for k, v in arrays.items()})
    raw = buffer.getvalue()
    _atomic_write(root / f"{key}.npz", lambda tmp: tmp.write_bytes(raw))
    manifest = {
        "format_version": CACHE_FORMAT_VERSION,
        "recipe": json.loads(_canonical(recipe)),
        "sha256": hashlib.sha256(raw).hexdigest(),
    }
    _atomic_write(root / f"{key}.json", lambda tmp: tmp.write_text(json.dumps(manifest, indent=1)))


def store_entry(recipe: Mapping, arrays: Mapping[str, np.ndarray],
                directory: str | os.PathLike | None = None) -> str:
    """Store ``arrays`` under ``recipe`` (under the entry's lock); returns the key.

    Parameters
    ----------
    recipe : Mapping
        JSON-serialisable description of the entry (see :func:`recipe_key`).
    arrays : Mapping[str, numpy.ndarray]
        Arrays to store, by name.
    directory : str or os.PathLike, optional
        Cache directory (None: the default of :func:`cache_dir`).

    Returns
    -------
    str
        Key of the stored entry (:func:`recipe_key` of ``recipe``).
    """
    root = cache_dir(directory)
    key = recipe_key(recipe)
    with entry_lock(root, key):
        _store_locked(root, key, recipe, arrays)
    return key


def cached(
    recipe: Mapping,
    build: Callable[[], Mapping[str, np.ndarray]],
    directory: str | os.PathLike | None = None,
) -> tuple[dict[str, np.ndarray], bool]:
    """Return ``(arrays, hit)``: the cached arrays for ``recipe``, building them on a miss.

    The build runs under the entry's lock: a second process asking for the same key waits
    and then reads the first one's entry instead of building it again.

    Parameters
    ----------
    recipe : Mapping
        JSON-serialisable description of the entry (see :func:`recipe_key`).
    build : callable
        Function without arguments that returns the arrays by name; called only on a miss.
    directory : str or os.PathLike, optional
        Cache directory (None: the default of :func:`cache_dir`).

    Returns
    -------
    arrays : dict of str to numpy.ndarray
        The cached or newly built arrays by name.
    hit : bool
        True if the arrays came from the cache, False if ``build`` ran.
    """
    arrays = load_entry(recipe, directory)
    if arrays is not None:
        return arrays, True
    root = cache_dir(directory)
    key = recipe_key(recipe)
    with entry_lock(root, key):
        arrays = _load_locked(root, key, recipe)
        if arrays is not None:
            return arrays, True
        built = {k: np.asarray(v) for k, v in build().items()}
        _store_locked(root, key, recipe, built)
    return built, False
