"""Content-addressed disk cache for expensive artefacts (reduced bodies).

An entry is keyed by the SHA-256 of a canonical JSON "recipe" (geometry parameters,
mesh size, materials, reduction settings, code version) and stored as two files:

- ``<key>.npz``: the arrays (uncompressed NumPy archive);
- ``<key>.json``: the manifest: format version, the recipe, and the SHA-256 of the npz.

Both are written to temporary files and renamed (npz first, manifest last), so a reader
never sees a half-written entry. On read the manifest's recipe must equal the request and
the npz checksum must match; otherwise the entry is corrupt or stale, it is removed and
rebuilt, never used.

The cache directory is ``$EXUDYN_STUDY_CACHE`` if set, else ``~/.cache/exudyn_study``.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

__all__ = ["cache_dir", "recipe_key", "load_entry", "store_entry", "cached"]

log = logging.getLogger(__name__)

#: Bump when the stored layout changes: older entries are then rebuilt.
CACHE_FORMAT_VERSION = 1


def cache_dir(directory: str | os.PathLike | None = None) -> Path:
    """Return (and create) the cache directory."""
    if directory is None:
        directory = os.environ.get("EXUDYN_STUDY_CACHE") or Path.home() / ".cache" / "exudyn_study"
    path = Path(directory)
    path.mkdir(parents=True, exist_ok=True)
    return path


def _canonical(recipe: Mapping) -> str:
    return json.dumps(recipe, sort_keys=True, separators=(",", ":"), default=str)


def recipe_key(recipe: Mapping) -> str:
    """SHA-256 hex digest of the canonical JSON of ``recipe``."""
    return hashlib.sha256(_canonical(recipe).encode()).hexdigest()


def _file_sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 22), b""):
            digest.update(block)
    return digest.hexdigest()


def _remove(*paths: Path) -> None:
    for p in paths:
        try:
            p.unlink()
        except FileNotFoundError:
            pass


def load_entry(recipe: Mapping, directory: str | os.PathLike | None = None) -> dict[str, np.ndarray] | None:
    """Return the cached arrays for ``recipe``, or None on a miss.

    A corrupt or stale entry (manifest unreadable, recipe or format differs, checksum
    mismatch, npz unreadable) is logged, deleted and reported as a miss.
    """
    root = cache_dir(directory)
    key = recipe_key(recipe)
    manifest_path, data_path = root / f"{key}.json", root / f"{key}.npz"
    if not manifest_path.exists():
        return None
    try:
        manifest = json.loads(manifest_path.read_text())
        problem = None
        if manifest.get("format_version") != CACHE_FORMAT_VERSION:
            problem = f"format {manifest.get('format_version')} != {CACHE_FORMAT_VERSION}"
        elif _canonical(manifest.get("recipe", {})) != _canonical(json.loads(_canonical(recipe))):
            problem = "recipe differs from the request"
        elif not data_path.exists():
            problem = "data file missing"
        elif _file_sha256(data_path) != manifest.get("sha256"):
            problem = "checksum mismatch"
        if problem is None:
            with np.load(data_path, allow_pickle=False) as npz:
                return {name: npz[name] for name in npz.files}
    except (OSError, ValueError, KeyError) as exc:
        problem = f"unreadable ({exc})"
    log.warning("cache entry %s is corrupt or stale (%s); rebuilding it", key[:12], problem)
    _remove(manifest_path, data_path)
    return None


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


def store_entry(recipe: Mapping, arrays: Mapping[str, np.ndarray], directory: str | os.PathLike | None = None) -> str:
    """Store ``arrays`` under ``recipe``; returns the key."""
    root = cache_dir(directory)
    key = recipe_key(recipe)
    data_path, manifest_path = root / f"{key}.npz", root / f"{key}.json"

    def write_npz(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, **{k: np.asarray(v) for k, v in arrays.items()})

    _atomic_write(data_path, write_npz)
    manifest = {
        "format_version": CACHE_FORMAT_VERSION,
        "recipe": json.loads(_canonical(recipe)),
        "sha256": _file_sha256(data_path),
    }
    _atomic_write(manifest_path, lambda tmp: tmp.write_text(json.dumps(manifest, indent=1)))
    return key


def cached(
    recipe: Mapping,
    build: Callable[[], Mapping[str, np.ndarray]],
    directory: str | os.PathLike | None = None,
) -> tuple[dict[str, np.ndarray], bool]:
    """Return ``(arrays, hit)``: the cached arrays for ``recipe``, building them on a miss."""
    arrays = load_entry(recipe, directory)
    if arrays is not None:
        return arrays, True
    built = {k: np.asarray(v) for k, v in build().items()}
    store_entry(recipe, built, directory)
    return built, False
