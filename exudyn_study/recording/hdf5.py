"""The native HDF5 format of recordings (``format`` 'exudyn_study.recording')."""

from __future__ import annotations

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


def _attr(value):
    """h5py attribute -> plain Python value."""
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _read_hdf5(path: Path) -> Recording:
    import h5py

    where = f"recording file {str(path)!r}"
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(
            f"{where} is not a readable HDF5 file ({exc}); expected a file written by "
            "write_recording (use .uff/.unv for UFF58 files)"
        ) from exc
    with f:
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
        metadata = {k: _attr(v) for k, v in f["metadata"].attrs.items()}
        channels = []
        for key in sorted(f["channels"].keys()):
            ds = f["channels"][key]
            a = {k: _attr(v) for k, v in ds.attrs.items()}
            pos = a.get("position_m")
            channels.append(
                Channel(
                    name=a["name"],
                    quantity=a["quantity"],
                    unit=a["unit"],
                    direction=a["direction"],
                    position_m=None if pos is None else tuple(float(v) for v in pos),
                    sample_rate_hz=float(a["sample_rate_hz"]),
                    data=ds[()],
                    role=a["role"],
                    sensitivity=a.get("sensitivity"),
                )
            )
    return Recording(tuple(channels), metadata)
