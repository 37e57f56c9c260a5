"""The recording type shared by measured and simulated data, and its files.

A :class:`Recording` is a tuple of :class:`Channel` objects plus a small metadata
mapping. A measured recording (read from test software) and a simulated one (written
by the rig simulation) are the same type; everything downstream (identification,
fatigue, diagnosis) takes recordings and never asks where they came from.

Units are SI inside: accelerations in m/s^2, displacements in m, forces in N,
positions in m (local rig coordinates of the thesis, Appendix A), rates in Hz.

File formats, chosen by the suffix of the path:

``.h5`` / ``.hdf5``
    The native format (h5py). One dataset per channel under ``/channels`` with the
    channel fields as attributes; the recording metadata as attributes of
    ``/metadata``; the root carries ``format`` and ``format_version``, which
    :func:`read_recording` verifies.
``.uff`` / ``.unv``
    Universal File Format dataset 58 (function type 1, time response), the exchange
    format of test software such as Simcenter Testlab, through ``pyuff``. One
    type-58 set per channel, the channel named by ID line 1. Direction, unit and
    quantity use the UFF58 fields (response direction, ordinate data type, axis
    label); positions go into a type-2411 node set (one node per channel, metres,
    with a type-164 SI units set). The fields UFF58 has no place for (role, exact
    sample rate, sensitivity, recording metadata) are written as ``key=value`` tags
    in ID lines 2-5. Data are written binary (``58b``, float64) so values round-trip
    exactly.

Examples
--------
>>> import numpy as np
>>> from exudyn_study.recording import Channel, Recording
>>> acc = Channel("ARFVZ", "acceleration", "m/s^2", "Z", (-0.315, -0.455, 0.19),
...               1000.0, np.zeros(8))
>>> rec = Recording((acc,), {"source": "example"})
>>> rec.time_data()[0].shape
(1, 8)
"""

from __future__ import annotations

import dataclasses
import difflib
import gc
import json
import logging
import math
import os
import types
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError

__all__ = [
    "Channel",
    "Recording",
    "read_recording",
    "write_recording",
    "QUANTITY_UNITS",
    "FORMAT_VERSION",
]

logger = logging.getLogger(__name__)

#: quantity -> its SI unit (the only unit a Channel accepts)
QUANTITY_UNITS: dict[str, str] = {"acceleration": "m/s^2", "displacement": "m", "force": "N"}
ROLES = ("response", "drive")
DIRECTIONS = ("X", "Y", "Z", "")

#: version of the native HDF5 layout written by :func:`write_recording`
FORMAT_VERSION = 1
_FORMAT_NAME = "exudyn_study.recording"

_HDF5_SUFFIXES = (".h5", ".hdf5")
_UFF_SUFFIXES = (".uff", ".unv")


def _closest(name: str, candidates: Sequence[str], n: int = 5) -> str:
    """Return a short human-readable list of candidates close to ``name``."""
    close = difflib.get_close_matches(name, list(candidates), n=n, cutoff=0.4)
    shown = close or list(candidates)[:n]
    more = "" if len(candidates) <= len(shown) else f", ... ({len(candidates)} in all)"
    return ", ".join(repr(c) for c in shown) + more


# ---------------------------------------------------------------------------------------
# Channel and Recording
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Channel:
    """One sampled signal with its physical description.

    Parameters
    ----------
    name : str
        Channel name, unique within a recording (e.g. the sensor name ``'ARFVZ'``).
    quantity : {'acceleration', 'displacement', 'force'}
        Physical quantity.
    unit : str
        SI unit of ``data``; must be the unit of ``quantity``: ``'m/s^2'``, ``'m'``
        or ``'N'``.
    direction : {'X', 'Y', 'Z', ''}
        Positive measuring direction in the local rig coordinates ('' if none).
    position_m : tuple of 3 float or None
        Sensor position in m, local rig coordinates (thesis Appendix A), or None.
    sample_rate_hz : float
        Sampling rate in Hz, > 0.
    data : array_like, shape (n_samples,)
        Samples in ``unit``; stored as a read-only float64 copy. Must be finite.
    role : {'response', 'drive'}, optional
        'drive' for the actuator displacement, 'response' otherwise.
    sensitivity : float or None, optional
        Transducer sensitivity in V per SI unit (e.g. V/(m/s^2)), > 0, or None.

    Raises
    ------
    InputError
        On an unknown quantity, role or direction, a unit that is not the SI unit of
        the quantity, a non-positive rate, a malformed position, or non-finite data
        (the message names the channel and the first bad sample index).

    Notes
    -----
    Two channels compare equal when all fields are equal and the data are
    element-wise identical. Channels are not hashable (they hold an array).
    """

    name: str
    quantity: str
    unit: str
    direction: str
    position_m: tuple[float, float, float] | None
    sample_rate_hz: float
    data: np.ndarray = field(repr=False)
    role: str = "response"
    sensitivity: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"channel name {self.name!r}: expected a non-empty string")
        who = f"channel {self.name!r}"
        if self.quantity not in QUANTITY_UNITS:
            raise InputError(
                f"{who}: quantity {self.quantity!r} is unknown; "
                f"expected one of {', '.join(QUANTITY_UNITS)}"
            )
        if self.unit != QUANTITY_UNITS[self.quantity]:
            raise InputError(
                f"{who}: unit {self.unit!r} for {self.quantity}; expected the SI unit "
                f"{QUANTITY_UNITS[self.quantity]!r} (convert at input)"
            )
        if self.direction not in DIRECTIONS:
            raise InputError(
                f"{who}: direction {self.direction!r}; expected one of 'X', 'Y', 'Z', ''"
            )
        if self.role not in ROLES:
            raise InputError(f"{who}: role {self.role!r}; expected 'response' or 'drive'")
        try:
            rate = float(self.sample_rate_hz)
        except (TypeError, ValueError):
            rate = math.nan
        if not (math.isfinite(rate) and rate > 0):
            raise InputError(
                f"{who}: sample_rate_hz {self.sample_rate_hz!r}; expected a finite rate > 0 Hz"
            )
        object.__setattr__(self, "sample_rate_hz", rate)
        if self.position_m is not None:
            try:
                pos = tuple(float(v) for v in self.position_m)
            except (TypeError, ValueError):
                pos = ()
            if len(pos) != 3 or not all(math.isfinite(v) for v in pos):
                raise InputError(
                    f"{who}: position_m {self.position_m!r}; expected 3 finite "
                    "coordinates in m or None"
                )
            object.__setattr__(self, "position_m", pos)
        if self.sensitivity is not None:
            try:
                sens = float(self.sensitivity)
            except (TypeError, ValueError):
                sens = math.nan
            if not (math.isfinite(sens) and sens > 0):
                raise InputError(
                    f"{who}: sensitivity {self.sensitivity!r}; expected a positive number "
                    "in V per SI unit, or None"
                )
            object.__setattr__(self, "sensitivity", sens)
        try:
            data = np.array(self.data, dtype=np.float64, copy=True)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{who}: data could not be converted to float64 ({exc})") from exc
        if data.ndim != 1 or data.size == 0:
            raise InputError(f"{who}: data of shape {data.shape}; expected a non-empty 1-D array")
        bad = np.flatnonzero(~np.isfinite(data))
        if bad.size:
            raise InputError(
                f"{who}: data has {bad.size} non-finite sample(s), the first at index "
                f"{int(bad[0])} (value {data[bad[0]]}); expected finite values"
            )
        data.flags.writeable = False
        object.__setattr__(self, "data", data)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Channel):
            return NotImplemented
        return all(
            getattr(self, f.name) == getattr(other, f.name)
            for f in dataclasses.fields(self)
            if f.name != "data"
        ) and np.array_equal(self.data, other.data)

    __hash__ = None  # type: ignore[assignment]

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.data.size)

    @property
    def duration_s(self) -> float:
        """Length in s, ``n_samples / sample_rate_hz``."""
        return self.n_samples / self.sample_rate_hz

    @property
    def time_s(self) -> np.ndarray:
        """Sample times in s, shape (n_samples,), starting at 0."""
        return np.arange(self.n_samples) / self.sample_rate_hz


def _check_metadata(metadata: Mapping) -> types.MappingProxyType:
    if not isinstance(metadata, Mapping):
        raise InputError(
            f"recording metadata of type {type(metadata).__name__}; expected a mapping "
            "str -> str | int | float"
        )
    out: dict[str, str | int | float] = {}
    for key, value in metadata.items():
        if not isinstance(key, str):
            raise InputError(f"recording metadata key {key!r}: expected a string")
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            raise InputError(
                f"recording metadata {key!r} = {value!r} of type {type(value).__name__}; "
                "expected str, int or float"
            )
        out[key] = value
    return types.MappingProxyType(out)


@dataclass(frozen=True, eq=False)
class Recording:
    """A set of channels recorded (or simulated) together, plus metadata.

    Parameters
    ----------
    channels : sequence of Channel
        The channels; names must be unique. Stored as a tuple in the given order.
    metadata : mapping str -> str | int | float, optional
        Free description, e.g. ``model``, ``damping``, ``signal``, ``seed``,
        ``package_version``, ``source``. Stored read-only.

    Raises
    ------
    InputError
        If a channel is not a :class:`Channel`, names repeat, or metadata values are
        not str, int or float.

    See Also
    --------
    read_recording, write_recording
    """

    channels: tuple[Channel, ...]
    metadata: Mapping[str, str | int | float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if isinstance(self.channels, Channel):
            channels: tuple = (self.channels,)
        else:
            try:
                channels = tuple(self.channels)
            except TypeError as exc:
                raise InputError(
                    f"recording channels of type {type(self.channels).__name__}; "
                    "expected a sequence of Channel"
                ) from exc
        for i, ch in enumerate(channels):
            if not isinstance(ch, Channel):
                raise InputError(
                    f"recording channel {i} of type {type(ch).__name__}; expected Channel"
                )
        names = [ch.name for ch in channels]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InputError(f"recording channel names must be unique; repeated: {', '.join(dup)}")
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "metadata", _check_metadata(self.metadata))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Recording):
            return NotImplemented
        return self.channels == other.channels and dict(self.metadata) == dict(other.metadata)

    __hash__ = None  # type: ignore[assignment]

    def __len__(self) -> int:
        return len(self.channels)

    def __iter__(self):
        return iter(self.channels)

    def __contains__(self, name: object) -> bool:
        return name in self.names

    @classmethod
    def from_arrays(
        cls,
        x: np.ndarray,
        sample_rate_hz: float,
        names: Sequence[str],
        *,
        quantity: str = "acceleration",
        directions: Sequence[str] | None = None,
        positions_m: Sequence[tuple[float, float, float] | None] | None = None,
        drive: np.ndarray | None = None,
        drive_rate_hz: float | None = None,
        drive_name: str = "drive",
        metadata: Mapping[str, str | int | float] | None = None,
    ) -> Recording:
        """Build a recording from time data ``x[n_channels, n_samples]``.

        Parameters
        ----------
        x : ndarray, shape (n_channels, n_samples)
            Response time data in the SI unit of ``quantity``.
        sample_rate_hz : float
            Rate of ``x`` in Hz.
        names : sequence of str, length n_channels
            Channel names.
        quantity : str, optional
            Quantity of all response channels (default 'acceleration').
        directions : sequence of str, optional
            Direction per channel; default: the last letter of the name if it is
            X, Y or Z, else ''.
        positions_m : sequence of (3-tuple or None), optional
            Position per channel in m; default None for all.
        drive : ndarray, shape (n_drive_samples,), optional
            Actuator displacement in m, added as a channel with role 'drive'.
        drive_rate_hz : float, optional
            Rate of ``drive`` in Hz; default ``sample_rate_hz``.
        drive_name : str, optional
            Name of the drive channel (default 'drive').
        metadata : mapping, optional
            Recording metadata.

        Returns
        -------
        Recording
        """
        x = np.atleast_2d(np.asarray(x, dtype=np.float64))
        if x.ndim != 2 or x.shape[0] != len(names):
            raise InputError(
                f"x of shape {x.shape} for {len(names)} names; expected (n_channels, n_samples)"
            )
        if directions is None:
            directions = [n[-1] if n and n[-1] in "XYZ" else "" for n in names]
        if positions_m is None:
            positions_m = [None] * len(names)
        if len(directions) != len(names) or len(positions_m) != len(names):
            raise InputError(
                f"from_arrays: {len(names)} names, {len(directions)} directions and "
                f"{len(positions_m)} positions; expected one of each per channel"
            )
        unit = QUANTITY_UNITS.get(quantity, "")
        chans = [
            Channel(n, quantity, unit, d, p, sample_rate_hz, row)
            for n, d, p, row in zip(names, directions, positions_m, x, strict=True)
        ]
        if drive is not None:
            chans.append(
                Channel(
                    drive_name,
                    "displacement",
                    "m",
                    "Z",
                    None,
                    sample_rate_hz if drive_rate_hz is None else drive_rate_hz,
                    drive,
                    role="drive",
                )
            )
        return cls(tuple(chans), dict(metadata or {}))

    @property
    def names(self) -> tuple[str, ...]:
        """Channel names in order."""
        return tuple(ch.name for ch in self.channels)

    def channel(self, name: str) -> Channel:
        """Return the channel called ``name``.

        Raises
        ------
        InputError
            If there is no such channel; the message lists close or first names.
        """
        for ch in self.channels:
            if ch.name == name:
                return ch
        available = _closest(str(name), self.names)
        raise InputError(f"channel {name!r} is not in the recording; available: {available}")

    def select(self, names: Iterable[str] | str) -> Recording:
        """Return a recording with only ``names``, in that order, same metadata.

        Raises
        ------
        InputError
            If a name is unknown.
        """
        if isinstance(names, str):
            names = [names]
        return Recording(tuple(self.channel(n) for n in names), self.metadata)

    @property
    def response_channels(self) -> tuple[Channel, ...]:
        """Channels with role 'response', in order."""
        return tuple(ch for ch in self.channels if ch.role == "response")

    @property
    def drive_channels(self) -> tuple[Channel, ...]:
        """Channels with role 'drive', in order."""
        return tuple(ch for ch in self.channels if ch.role == "drive")

    @property
    def drive(self) -> Channel:
        """The drive channel (actuator displacement).

        Raises
        ------
        InputError
            If the recording has no drive channel, or more than one.
        """
        drives = self.drive_channels
        if not drives:
            raise InputError("recording has no drive channel")
        if len(drives) > 1:
            raise InputError(
                f"recording has {len(drives)} drive channels "
                f"({', '.join(d.name for d in drives)}); select one by name with channel()"
            )
        return drives[0]

    def time_data(self, names: Iterable[str] | str | None = None) -> tuple[np.ndarray, float]:
        """Stack channels into time data.

        Parameters
        ----------
        names : sequence of str, optional
            Channels to stack, in this order. Default: all response channels (the
            drive is usually sampled at another rate; ask for it by name).

        Returns
        -------
        x : ndarray, shape (n_channels, n_samples)
            Time data in SI units (a new, writable array).
        sample_rate_hz : float
            Common sampling rate in Hz.

        Raises
        ------
        InputError
            If no channel is selected, or channels differ in rate or length (the
            message names the channels and their rates or lengths).
        """
        if names is None:
            chans = self.response_channels
        else:
            if isinstance(names, str):
                names = [names]
            chans = tuple(self.channel(n) for n in names)
        if not chans:
            raise InputError(
                "time_data: no channels selected (the recording has no response channels)"
            )
        rates = {ch.sample_rate_hz for ch in chans}
        if len(rates) > 1:
            desc = ", ".join(f"{ch.name} at {ch.sample_rate_hz:g} Hz" for ch in chans[:8])
            raise InputError(
                f"time_data: channels have mixed sample rates ({desc}); select channels "
                "with one rate or resample first"
            )
        lengths = {ch.n_samples for ch in chans}
        if len(lengths) > 1:
            desc = ", ".join(f"{ch.name}: {ch.n_samples}" for ch in chans[:8])
            raise InputError(
                f"time_data: channels have different numbers of samples ({desc}); "
                "expected equal lengths"
            )
        return np.stack([ch.data for ch in chans]), chans[0].sample_rate_hz

    @property
    def duration_s(self) -> float:
        """Duration in s: the longest channel's ``n_samples / sample_rate_hz``."""
        return max((ch.duration_s for ch in self.channels), default=0.0)


# ---------------------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------------------


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
        If the file is missing, the suffix is unknown, the file is not in the format
        its suffix says (or of another format version), or a UFF file has no
        type-58 time-data sets.
    """
    path = Path(path)
    suffix = _suffix(path)
    if not path.is_file():
        raise InputError(f"recording file {str(path)!r} does not exist; check the path")
    if suffix in _HDF5_SUFFIXES:
        return _read_hdf5(path)
    return _read_uff(path)


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
    from .atomic import atomic_write

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


# --- HDF5 ------------------------------------------------------------------------------


def _write_hdf5(recording: Recording, path: Path) -> None:
    import h5py

    from . import __version__

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


# --- UFF58 -----------------------------------------------------------------------------

#: UFF "specific data type" codes (record 9, field 1) for the quantities we carry
_UFF_SPEC_TYPE = {"acceleration": 12, "displacement": 8, "force": 13}
_UFF_SPEC_TYPE_INV = {12: "acceleration", 8: "displacement", 9: "force", 13: "force"}
#: (length, force) unit exponents of each quantity (record 9, fields 2-3)
_UFF_EXPONENTS = {"acceleration": (1, 0), "displacement": (1, 0), "force": (0, 1)}
_UFF_DIR = {"X": 1, "Y": 2, "Z": 3, "": 0}
#: accepted axis unit labels -> (quantity, factor to SI)
_UNIT_LABELS = {
    "m/s^2": ("acceleration", 1.0),
    "m/s2": ("acceleration", 1.0),
    "m/s**2": ("acceleration", 1.0),
    "m/s²": ("acceleration", 1.0),
    "m s^-2": ("acceleration", 1.0),
    "mm/s^2": ("acceleration", 1e-3),
    "mm/s2": ("acceleration", 1e-3),
    "g": ("acceleration", 9.80665),
    "m": ("displacement", 1.0),
    "mm": ("displacement", 1e-3),
    "um": ("displacement", 1e-6),
    "µm": ("displacement", 1e-6),
    "n": ("force", 1.0),
    "kn": ("force", 1e3),
}
_META_TAG = "meta="
_ID_LINE_LEN = 80


def _meta_chunks(recording: Recording) -> list[str]:
    text = json.dumps(dict(recording.metadata), separators=(",", ":"), ensure_ascii=True)
    width = _ID_LINE_LEN - len(_META_TAG)
    return [text[i : i + width] for i in range(0, len(text), width)] if text != "{}" else []


def _check_uff_writable(recording: Recording) -> None:
    if not recording.channels:
        raise InputError("write_recording: a UFF58 file needs at least one channel")
    for ch in recording.channels:
        if len(ch.name) > _ID_LINE_LEN or not ch.name.isascii():
            raise InputError(
                f"channel {ch.name!r}: UFF ID lines hold at most {_ID_LINE_LEN} ASCII "
                "characters; rename the channel or write .h5"
            )
    chunks = _meta_chunks(recording)
    if len(chunks) > len(recording.channels):
        raise InputError(
            f"recording metadata needs {len(chunks)} UFF ID lines of {_ID_LINE_LEN} "
            f"characters but the file has {len(recording.channels)} channel(s) to carry "
            "them; shorten the metadata or write .h5"
        )


def _write_uff(recording: Recording, path: Path) -> None:
    import pyuff

    from . import __version__

    chunks = _meta_chunks(recording)
    sets: list[dict] = [
        pyuff.prepare_151(
            model_name=str(recording.metadata.get("model", "exudyn_study recording"))[:80],
            description="exudyn_study recording (UFF58 time data)",
            db_app="exudyn_study",
            program=f"exudyn_study {__version__}"[:80],
        ),
        pyuff.prepare_164(
            units_code=1,
            units_description="SI",
            temp_mode=2,
            length=1.0,
            force=1.0,
            temp=1.0,
            temp_offset=273.15,
        ),
    ]
    nodes = [(i + 1, ch.position_m) for i, ch in enumerate(recording.channels) if ch.position_m]
    if nodes:
        num = np.array([n for n, _ in nodes], dtype=int)
        xyz = np.array([p for _, p in nodes], dtype=np.float64)
        # built by hand: pyuff.prepare_2411 mis-checks array arguments (pyuff 2.5)
        sets.append(
            {
                "type": 2411,
                "node_nums": num,
                "def_cs": np.zeros(len(num), dtype=int),
                "disp_cs": np.zeros(len(num), dtype=int),
                "color": np.ones(len(num), dtype=int),
                "x": xyz[:, 0],
                "y": xyz[:, 1],
                "z": xyz[:, 2],
            }
        )
    for i, ch in enumerate(recording.channels):
        len_exp, force_exp = _UFF_EXPONENTS[ch.quantity]
        tags3 = f"fs={ch.sample_rate_hz!r}"
        if ch.sensitivity is not None:
            tags3 += f" sensitivity={ch.sensitivity!r}"
        sets.append(
            pyuff.prepare_58(
                binary=1,
                id1=ch.name,
                id2=f"quantity={ch.quantity} role={ch.role} direction={ch.direction or '-'}",
                id3=tags3,
                id4=f"unit={ch.unit} exudyn_study={__version__}",
                id5=_META_TAG + chunks[i] if i < len(chunks) else "NONE",
                func_type=1,
                rsp_ent_name=ch.name[:10],
                rsp_node=i + 1,
                rsp_dir=_UFF_DIR[ch.direction],
                ref_ent_name="NONE",
                ref_node=0,
                ref_dir=0,
                ord_data_type=4,  # real, double precision
                abscissa_spacing=1,
                abscissa_min=0.0,
                abscissa_inc=1.0 / ch.sample_rate_hz,
                abscissa_spec_data_type=17,  # time
                abscissa_axis_units_lab="s",
                ordinate_spec_data_type=_UFF_SPEC_TYPE[ch.quantity],
                ordinate_len_unit_exp=len_exp,
                ordinate_force_unit_exp=force_exp,
                ordinate_temp_unit_exp=0,
                ordinate_axis_units_lab=ch.unit,
                orddenom_spec_data_type=0,
                data=np.ascontiguousarray(ch.data),
                x=ch.time_s,
            )
        )
    with warnings.catch_warnings():
        # pyuff 2.5 re-opens the file for binary 58 data and leaves that handle to the
        # garbage collector; collect here so it is flushed and closed before os.replace
        warnings.simplefilter("ignore", ResourceWarning)
        pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
        gc.collect()


def _tags(*lines: str) -> dict[str, str]:
    out = {}
    for line in lines:
        for word in str(line).split():
            if "=" in word and not word.startswith(_META_TAG):
                key, _, value = word.partition("=")
                out[key] = value
    return out


def _rate_from_increment(inc: float) -> float:
    # UFF record 7 holds the increment as E13.5 (6 significant digits): 1/204.8 Hz is
    # written 4.88281e-03 -> 204.8001 Hz. Round the rate to 6 significant digits.
    rate = 1.0 / inc
    return float(f"{rate:.6g}")


def _read_uff(path: Path) -> Recording:
    import pyuff

    where = f"recording file {str(path)!r}"
    try:
        uff = pyuff.UFF(str(path))
        set_types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises plain Exception on malformed files
        raise InputError(
            f"{where} is not a readable UFF file ({exc}); expected UFF dataset 58 time data"
        ) from exc
    idx58 = [i for i, t in enumerate(set_types) if t == 58]
    if not idx58:
        raise InputError(
            f"{where} has no type-58 datasets (found types {sorted(set(set_types)) or 'none'}); "
            "export the time data as UFF58 (function type 1, time response)"
        )
    try:
        sets = [uff.read_sets(i) for i in range(len(set_types))]
    except Exception as exc:  # pyuff raises plain Exception on malformed files
        raise InputError(f"{where}: a dataset could not be read by pyuff ({exc})") from exc

    length_factor = force_factor = 1.0  # UFF 164: SI = file value / factor
    for s in sets:
        if s["type"] == 164:
            length_factor, force_factor = float(s["length"]), float(s["force"])
    nodes: dict[int, tuple[float, float, float]] = {}
    for s in sets:
        if s["type"] in (15, 2411):
            for n, x, y, z in zip(s["node_nums"], s["x"], s["y"], s["z"], strict=True):
                nodes[int(n)] = (x / length_factor, y / length_factor, z / length_factor)

    channels, meta_text, skipped = [], [], []
    for s in (sets[i] for i in idx58):
        name = str(s.get("id1", "")).strip()
        if int(s.get("func_type", 0)) != 1:
            skipped.append(f"{name or '?'} (function type {s.get('func_type')})")
            continue
        if not name or name == "NONE":
            name = f"{s.get('rsp_ent_name', 'node')}:{s.get('rsp_node')}:{s.get('rsp_dir')}"
        tags = _tags(s.get("id2", ""), s.get("id3", ""), s.get("id4", ""))
        id5 = str(s.get("id5", "")).strip()
        if id5.startswith(_META_TAG):
            meta_text.append(id5[len(_META_TAG) :])
        data = np.asarray(s["data"])
        if np.iscomplexobj(data):
            raise InputError(
                f"{where}: channel {name!r} holds complex data; expected real time data"
            )
        data = data.astype(np.float64)
        # quantity and unit: our tag, else the UFF data type / axis label
        label = str(s.get("ordinate_axis_units_lab", "")).strip()
        quantity = tags.get("quantity") or _UFF_SPEC_TYPE_INV.get(
            int(s.get("ordinate_spec_data_type", 0))
        )
        label_q, factor = _UNIT_LABELS.get(
            label if label in _UNIT_LABELS else label.lower(), (None, None)
        )
        if quantity is None:
            quantity = label_q
        if quantity is None:
            raise InputError(
                f"{where}: channel {name!r} has ordinate data type "
                f"{s.get('ordinate_spec_data_type')} and unit label {label!r}; expected "
                "acceleration (12), displacement (8) or force (9, 13)"
            )
        if factor is None or label_q != quantity:
            len_exp = int(s.get("ordinate_len_unit_exp", _UFF_EXPONENTS[quantity][0]))
            force_exp = int(s.get("ordinate_force_unit_exp", _UFF_EXPONENTS[quantity][1]))
            factor = 1.0 / (length_factor**len_exp * force_factor**force_exp)
            if label not in ("", "NONE") and label_q != quantity:
                warnings.warn(
                    f"{where}: channel {name!r} unit label {label!r} not recognised; "
                    "converted with the UFF 164 unit factors",
                    stacklevel=3,
                )
        if factor != 1.0:
            data = data * factor
        # direction: sign of the UFF direction flips the data into the +axis
        rsp_dir = int(s.get("rsp_dir", 0))
        direction = {1: "X", 2: "Y", 3: "Z"}.get(abs(rsp_dir), "")
        if rsp_dir < 0 and direction:
            data = -data
        if abs(rsp_dir) > 3:
            warnings.warn(
                f"{where}: channel {name!r} has rotational direction {rsp_dir}; stored "
                "with direction ''",
                stacklevel=3,
            )
        if "direction" in tags:
            tagged = tags["direction"].replace("-", "")
            if tagged != direction:
                raise InputError(
                    f"{where}: channel {name!r} direction tag {tagged!r} disagrees with "
                    f"UFF response direction {rsp_dir}; the file was edited inconsistently"
                )
        if "fs" in tags:
            rate = float(tags["fs"])
        else:
            inc = float(s.get("abscissa_inc", 0.0))
            if not inc > 0:
                raise InputError(
                    f"{where}: channel {name!r} has abscissa increment {inc!r}; expected "
                    "evenly sampled time data with an increment > 0 s"
                )
            rate = _rate_from_increment(inc)
        sens = tags.get("sensitivity")
        channels.append(
            Channel(
                name=name,
                quantity=quantity,
                unit=QUANTITY_UNITS[quantity],
                direction=direction,
                position_m=nodes.get(int(s.get("rsp_node", -1))),
                sample_rate_hz=rate,
                data=data,
                role=tags.get("role", "response"),
                sensitivity=None if sens is None else float(sens),
            )
        )
    if skipped:
        warnings.warn(
            f"{where}: skipped {len(skipped)} type-58 set(s) that are not time data: "
            + ", ".join(skipped[:5]),
            stacklevel=3,
        )
    if not channels:
        raise InputError(
            f"{where} has type-58 datasets but none with time data (function type 1); "
            "export time histories, not spectra or FRFs"
        )
    metadata: dict = {}
    if meta_text:
        try:
            metadata = json.loads("".join(meta_text))
        except json.JSONDecodeError as exc:
            raise InputError(
                f"{where}: the metadata in ID line 5 is not valid JSON ({exc})"
            ) from exc
    return Recording(tuple(channels), metadata)
