"""The one read/write API of recordings.

The format follows the file's suffix (``.h5``/``.hdf5`` or ``.uff``/``.unv``). Every
recording read is checked: the file (regular, readable, not empty, size), its structure
and integrity (see the format modules) and the range of its samples (:data:`MAX_ABS`).
"""

from __future__ import annotations

import os
from pathlib import Path

from exudyn_study.errors import InputError
from exudyn_study.recording.hdf5 import _read_hdf5, _write_hdf5
from exudyn_study.recording.types import _HDF5_SUFFIXES, Recording
from exudyn_study.recording.uff import _UFF_SUFFIXES, _check_uff_writable, _read_uff, _write_uff

#: largest magnitude of a sample per quantity (SI): 1e5 m/s^2 is 10 000 g, beyond any
#: accelerometer; 10 m beyond any rig stroke; 1e8 N beyond any actuator. A larger value is
#: a damaged file or a unit error, not a measurement.
MAX_ABS = {"acceleration": 1e5, "displacement": 10.0, "force": 1e8}


def _check_ranges(recording: Recording, path: Path) -> None:
    import numpy as np

    for ch in recording.channels:
        limit = MAX_ABS.get(ch.quantity)
        if limit is None:
            continue
        peak = float(np.max(np.abs(ch.data)))
        if peak > limit:
            raise InputError(
                f"recording file {str(path)!r}: channel {ch.name!r} reaches {peak:.3g} {ch.unit}, beyond "
                f"the {limit:g} {ch.unit} any {ch.quantity} sensor gives (a damaged file or a unit error)")


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in _HDF5_SUFFIXES + _UFF_SUFFIXES:
        raise InputError(
            f"recording file {str(path)!r}: unknown suffix {path.suffix!r}; expected "
            ".h5/.hdf5 (native HDF5) or .uff/.unv (UFF58)"
        )
    return suffix


def read_recording(path: str | os.PathLike) -> Recording:
    """Read a recording from a native HDF5 or a UFF58 file.

    Parameters
    ----------
    path : str or path-like
        ``.h5``/``.hdf5`` (native) or ``.uff``/``.unv`` (UFF dataset 58, time data).

    Returns
    -------
    Recording
        The channels in file order and the metadata stored in the file (nothing is
        added, so a write/read round trip gives an equal recording).

    Raises
    ------
    InputError
        If the file is missing, empty, not a regular file, the suffix is unknown, the
        file is not in the format its suffix says (or of another format version), its
        structure is incomplete, its content fails the integrity check (a native file's
        checksum; a UFF file cut short or holding unreadable sets), or a UFF file has no
        type-58 time-data sets.
    """
    from exudyn_study.infra.files import MAX_RECORDING_BYTES, check_input_file

    path = Path(path)
    suffix = _suffix(path)
    check_input_file(path, "recording file", max_bytes=MAX_RECORDING_BYTES)
    rec = _read_hdf5(path) if suffix in _HDF5_SUFFIXES else _read_uff(path)
    _check_ranges(rec, path)
    return rec


def write_recording(recording: Recording, path: str | os.PathLike) -> Path:
    """Write a recording atomically to a native HDF5 or a UFF58 file.

    The file is written to a temporary file in the same directory and moved into
    place with :func:`os.replace`; on any error nothing is left at ``path`` (an
    existing file there is kept unchanged).

    Parameters
    ----------
    recording : Recording
        The recording to write.
    path : str or path-like
        Target; the suffix chooses the format (``.h5``/``.hdf5`` or ``.uff``/``.unv``).

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    InputError
        On an unknown suffix, a missing directory, or (UFF) a channel name or metadata
        that does not fit the 80-character ID lines.
    """
    if not isinstance(recording, Recording):
        raise InputError(f"write_recording: got {type(recording).__name__}; expected a Recording")
    from exudyn_study.infra.atomic import atomic_write

    path = Path(path)
    suffix = _suffix(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise InputError(
            f"recording file {str(path)!r}: directory {str(directory)!r} does not exist; "
            "create it first"
        )
    writer = _write_hdf5 if suffix in _HDF5_SUFFIXES else _write_uff
    if writer is _write_uff:
        _check_uff_writable(recording)  # before touching the disk
    return atomic_write(path, lambda tmp: writer(recording, tmp), "recording file")
