"""The native HDF5 format of recordings (``format`` 'exudyn_study.recording').

Integrity: the writer stores ``sha256``, the SHA-256 of the file's content (metadata,
every channel's attributes and samples, in a canonical order), as a root attribute; the
reader recomputes it and refuses a file whose content does not match (flipped bytes, a
dataset overwritten, an attribute edited). A file without the attribute (written by an
older version or another program) is read with a warning that it carries no check.
Every malformed structure (a missing group or attribute, a text where a number belongs)
is an :class:`~exudyn_study.errors.InputError` naming the file and what is wrong.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.recording.types import _FORMAT_NAME, FORMAT_VERSION, Channel, Recording


def _write_hdf5(recording: Recording, path: Path) -> None:
    import h5py

    from exudyn_study import __version__

    with h5py.File(path, "w") as f:
        f.attrs["format"] = _FORMAT_NAME
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["writer"] = f"exudyn_study {__version__}"
        meta = f.create_group("metadata")
        for key, value in recording.metadata.items():
            meta.attrs[key] = value
        group = f.create_group("channels")
        for i, ch in enumerate(recording.channels):
            ds = group.create_dataset(f"{i:04d}", data=ch.data)
            ds.attrs["name"] = ch.name
            ds.attrs["quantity"] = ch.quantity
            ds.attrs["unit"] = ch.unit
            ds.attrs["direction"] = ch.direction
            ds.attrs["sample_rate_hz"] = ch.sample_rate_hz
            ds.attrs["role"] = ch.role
            if ch.position_m is not None:
                ds.attrs["position_m"] = np.asarray(ch.position_m, dtype=np.float64)
            if ch.sensitivity is not None:
                ds.attrs["sensitivity"] = ch.sensitivity
    # the checksum is computed from the file as written, by the reader's own walk
    with h5py.File(path, "r+") as f:
        f.attrs[_CHECKSUM_ATTR] = _content_digest(f)


_CHECKSUM_ATTR = "sha256"


def _plain(value):
    """Attribute value -> JSON-able value, identical for what was written and what is read."""
    value = _attr(value)
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _canon_attrs(attrs) -> bytes:
    items = {k: _plain(v) for k, v in attrs.items() if k != _CHECKSUM_ATTR}
    return json.dumps(items, sort_keys=True, default=repr).encode()


def _content_digest(f) -> str:
    """SHA-256 of the metadata, the channel attributes and samples (float64, little endian)."""
    digest = hashlib.sha256()
    digest.update(_canon_attrs(f.attrs))
    digest.update(_canon_attrs(f["metadata"].attrs))
    group = f["channels"]
    for key in sorted(group.keys()):
        ds = group[key]
        digest.update(key.encode())
        digest.update(_canon_attrs(ds.attrs))
        digest.update(np.ascontiguousarray(ds[()], dtype="<f8").tobytes())
    return digest.hexdigest()


def _attr(value):
    """h5py attribute -> plain Python value."""
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _need(attrs: dict, key: str, where: str, kind=str):
    if key not in attrs:
        raise InputError(f"{where}: attribute {key!r} is missing; the file is not a complete recording")
    value = attrs[key]
    if kind is float:
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise InputError(f"{where}: attribute {key}={value!r} is not a number") from None
    elif not isinstance(value, str):
        raise InputError(f"{where}: attribute {key}={value!r} is not text")
    return value


def _read_hdf5(path: Path) -> Recording:
    import h5py

    where = f"recording file {str(path)!r}"
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(
            f"{where} is not a readable HDF5 file ({' '.join(str(exc).split())}); expected a file "
            "written by write_recording (use .uff/.unv for UFF58 files)"
        ) from None
    try:
        with f:
            return _read_open_hdf5(f, where)
    except InputError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:  # h5py on damaged files
        raise InputError(f"{where}: damaged HDF5 content ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:160]}); rewrite or re-export the file") from None


def _read_open_hdf5(f, where: str) -> Recording:
    import h5py

    fmt = _attr(f.attrs.get("format", ""))
    version = _attr(f.attrs.get("format_version", -1))
    if fmt != _FORMAT_NAME:
        raise InputError(
            f"{where}: HDF5 attribute format={fmt!r}; expected {_FORMAT_NAME!r} "
            "(a file written by exudyn_study.recording.write_recording)"
        )
    if version != FORMAT_VERSION:
        raise InputError(
            f"{where}: format_version {version!r}; this exudyn_study reads version "
            f"{FORMAT_VERSION} (upgrade exudyn_study or rewrite the file)"
        )
    for group in ("metadata", "channels"):
        if not isinstance(f.get(group), h5py.Group):
            raise InputError(f"{where}: group /{group} is missing; the file is not a complete recording")
    metadata = {k: _attr(v) for k, v in f["metadata"].attrs.items()}
    channels = []
    for key in sorted(f["channels"].keys()):
        ds = f["channels"][key]
        here = f"{where}: channel dataset /channels/{key}"
        if not isinstance(ds, h5py.Dataset):
            raise InputError(f"{here} is not a dataset")
        a = {k: _attr(v) for k, v in ds.attrs.items()}
        pos = a.get("position_m")
        if pos is not None:
            try:
                pos = tuple(float(v) for v in np.atleast_1d(pos))
            except (TypeError, ValueError):
                raise InputError(f"{here}: attribute position_m={pos!r} is not 3 numbers") from None
        sens = a.get("sensitivity")
        channels.append(
            Channel(
                name=_need(a, "name", here),
                quantity=_need(a, "quantity", here),
                unit=_need(a, "unit", here),
                direction=_need(a, "direction", here),
                position_m=pos,
                sample_rate_hz=_need(a, "sample_rate_hz", here, float),
                data=ds[()],
                role=_need(a, "role", here),
                sensitivity=None if sens is None else _need(a, "sensitivity", here, float),
            )
        )
    stored = _attr(f.attrs.get(_CHECKSUM_ATTR, ""))
    if not stored:
        warnings.warn(f"{where} carries no integrity checksum (written by another program or an older "
                      "version); its content is not verified", stacklevel=4)
    elif stored != _content_digest(f):
        raise InputError(f"{where}: content does not match its checksum (the file was damaged or edited "
                         "after writing); re-export or rewrite it")
    return Recording(tuple(channels), metadata)
