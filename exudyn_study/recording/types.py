"""The recording type shared by measured and simulated data (files: ``hdf5``, ``uff``, ``io``).

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
import logging
import math
import types
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from exudyn_study.errors import InputError

__all__ = [
    "Channel",
    "Recording",
    "QUANTITY_UNITS",
    "FORMAT_VERSION",
]

logger = logging.getLogger(__name__)

#: quantity -> its SI unit (the only unit a Channel accepts)
#: ('voltage': a drive signal in V, e.g. an open-loop shaker amplifier's input, when no force was measured)
QUANTITY_UNITS: dict[str, str] = {"acceleration": "m/s^2", "displacement": "m", "force": "N", "voltage": "V"}
ROLES = ("response", "drive")
DIRECTIONS = ("X", "Y", "Z", "")

#: version of the native HDF5 layout written by :func:`write_recording`
FORMAT_VERSION = 1
_FORMAT_NAME = "exudyn_study.recording"

_HDF5_SUFFIXES = (".h5", ".hdf5")


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
    quantity : {'acceleration', 'displacement', 'force', 'voltage'}
        Physical quantity.
    unit : str
        SI unit of ``data``; must be the unit of ``quantity``: ``'m/s^2'``, ``'m'``,
        ``'N'`` or ``'V'``.
    direction : {'X', 'Y', 'Z', ''}
        Positive measuring direction in the local rig coordinates ('' if none).
    position_m : tuple of 3 float or None
        Sensor position in m, local rig coordinates (thesis Appendix A), or None.
    sample_rate_hz : float
        Sampling rate in Hz, > 0.
    data : array_like, shape (n_samples,)
        Samples in ``unit``; stored as a read-only float64 copy. Must be finite.
    role : {'response', 'drive'}, optional
        'drive' for the excitation: a base (table) displacement in m, a shaker force in N
        (the force gauge at the drive point), a table acceleration, or a shaker's input
        voltage in V when no force was measured; 'response' otherwise.
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
        drive_quantity: str = "displacement",
        drive_position_m: tuple[float, float, float] | None = None,
        drive_direction: str = "Z",
        metadata: Mapping[str, str | int | float] | None = None,
    ) -> Recording:
        """Build a recording from time data ``x[n_channels, n_samples]``.

        A base-excitation test gives the table displacement as ``drive``; a shaker test
        gives the measured force (``drive_quantity='force'``, N) with the force gauge's
        position, and the drive-point accelerometer among ``x`` at the same position
        (the generic diagnosis finds the drive point by position)::

            rec = Recording.from_arrays(acc, 400.0, ["DP", "A", "B"], positions_m=[p_dp, p_a, p_b],
                                        drive=force_n, drive_quantity="force", drive_name="force",
                                        drive_position_m=p_dp)

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
            The excitation in the SI unit of ``drive_quantity``, added as a channel with
            role 'drive'.
        drive_rate_hz : float, optional
            Rate of ``drive`` in Hz; default ``sample_rate_hz``.
        drive_name : str, optional
            Name of the drive channel (default 'drive').
        drive_quantity : {'displacement', 'force', 'acceleration', 'voltage'}, optional
            What ``drive`` is: a table displacement in m (default), a shaker force in N,
            a table acceleration in m/s^2, or a shaker input voltage in V.
        drive_position_m : (3-tuple) or None, optional
            Position of the drive (the force gauge) in m; default None.
        drive_direction : str, optional
            Direction of the drive (default 'Z').
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
                    drive_quantity,
                    QUANTITY_UNITS.get(drive_quantity, "?"),
                    drive_direction,
                    drive_position_m,
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


# --- HDF5 ------------------------------------------------------------------------------


# --- UFF58 -----------------------------------------------------------------------------

