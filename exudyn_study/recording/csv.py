"""CSV/TSV time data into a :class:`~exudyn_study.recording.types.Recording`, through a column map.

Test software exports time data as delimited text: one column per channel, optionally a
time column, a header row with the column names. :func:`read_csv` takes a *column map*:
for every channel the source column (header name or 0-based index), the quantity, the
unit of the file (converted to SI here), the direction and the role. A shaker test maps
the force gauge with ``role='drive'`` (quantity ``force``); a base-excitation test maps the
table displacement or acceleration as the drive; an open-loop shaker test without a force
gauge may map the amplifier voltage (quantity ``voltage``).

Examples
--------
>>> from exudyn_study.recording.csv import CsvColumn, read_csv
>>> cols = [CsvColumn("force", "F", "force", "N", role="drive"),
...         CsvColumn("DP", "a1", "acceleration", "g")]
>>> rec = read_csv("run.csv", cols, sample_rate_hz=400.0)  # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.recording.types import DIRECTIONS, QUANTITY_UNITS, ROLES, Channel, Recording

__all__ = ["CsvColumn", "UNIT_FACTORS", "parse_column", "read_csv"]

#: file unit -> (quantity, factor to the SI unit of the quantity)
UNIT_FACTORS: dict[str, tuple[str, float]] = {
    "m/s^2": ("acceleration", 1.0),
    "m/s2": ("acceleration", 1.0),
    "mm/s^2": ("acceleration", 1e-3),
    "g": ("acceleration", 9.80665),
    "m": ("displacement", 1.0),
    "mm": ("displacement", 1e-3),
    "um": ("displacement", 1e-6),
    "N": ("force", 1.0),
    "kN": ("force", 1e3),
    "lbf": ("force", 4.4482216152605),
    "V": ("voltage", 1.0),
    "mV": ("voltage", 1e-3),
}


@dataclass(frozen=True)
class CsvColumn:
    """One channel of a CSV/TSV file.

    Parameters
    ----------
    name : str
        Channel name in the recording.
    column : str or int
        Header name of the source column, or its 0-based index.
    quantity : {'acceleration', 'displacement', 'force', 'voltage'}
    unit : str
        Unit of the values in the file, a key of :data:`UNIT_FACTORS` (e.g. ``'g'``, ``'mm'``,
        ``'kN'``); converted to SI on reading.
    direction : {'X', 'Y', 'Z', ''}, optional
        Measuring direction (default 'Z').
    role : {'response', 'drive'}, optional
        'drive' for the excitation (a force gauge, a table displacement/acceleration, a
        shaker voltage); default 'response'.
    position_m : 3-tuple of float or None, optional
        Sensor position in m; the drive-point accelerometer of a shaker test has the force
        gauge's position.
    """

    name: str
    column: str | int
    quantity: str
    unit: str
    direction: str = "Z"
    role: str = "response"
    position_m: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        who = f"column map entry {self.name!r}"
        if self.quantity not in QUANTITY_UNITS:
            raise InputError(
                f"{who}: quantity {self.quantity!r}; expected one of {', '.join(QUANTITY_UNITS)}"
            )
        q = UNIT_FACTORS.get(self.unit)
        if q is None or q[0] != self.quantity:
            ok = [u for u, (qq, _) in UNIT_FACTORS.items() if qq == self.quantity]
            raise InputError(
                f"{who}: unit {self.unit!r} for {self.quantity}; expected one of {', '.join(ok)}"
            )
        if self.direction not in DIRECTIONS:
            raise InputError(f"{who}: direction {self.direction!r}; expected one of X, Y, Z or empty")
        if self.role not in ROLES:
            raise InputError(f"{who}: role {self.role!r}; expected 'response' or 'drive'")


def parse_column(text: str) -> CsvColumn:
    """Parse ``NAME=COLUMN:QUANTITY:UNIT[:DIRECTION[:ROLE]]`` (the CLI's ``--column``).

    ``COLUMN`` is a header name or a 0-based index; e.g. ``force=Fz:force:N:Z:drive`` or
    ``DP=2:acceleration:g``.

    Parameters
    ----------
    text : str
        One ``--column`` value. ``DIRECTION`` defaults to 'Z' and ``ROLE`` to 'response'; a
        ``COLUMN`` of digits only is a 0-based index, anything else a header name.

    Returns
    -------
    CsvColumn
        The column map entry, without a position (``position_m`` None).

    Raises
    ------
    InputError
        On a malformed entry (the message shows the expected form), or a quantity, unit,
        direction or role that :class:`CsvColumn` does not accept.
    """
    form = "NAME=COLUMN:QUANTITY:UNIT[:DIRECTION[:ROLE]], e.g. force=Fz:force:N:Z:drive"
    name, eq, rest = text.partition("=")
    parts = rest.split(":")
    if not eq or not name.strip() or not 3 <= len(parts) <= 5 or not parts[0].strip():
        raise InputError(f"--column {text!r}: expected {form}")
    col: str | int = parts[0].strip()
    if col.isdigit():
        col = int(col)
    direction = parts[3] if len(parts) > 3 else "Z"
    role = parts[4] if len(parts) > 4 else "response"
    return CsvColumn(name.strip(), col, parts[1].strip(), parts[2].strip(), direction.strip(), role.strip())


def _split(line: str, delimiter: str | None) -> list[str]:
    return [c.strip().strip('"') for c in (line.split(delimiter) if delimiter else line.split())]


def read_csv(
    path: str | os.PathLike,
    columns: Sequence[CsvColumn],
    *,
    sample_rate_hz: float | None = None,
    time_column: str | int | None = None,
    delimiter: str | None = None,
    metadata: Mapping[str, str | int | float] | None = None,
) -> Recording:
    """Read delimited time data into a recording.

    Parameters
    ----------
    path : str or path-like
        ``.csv`` (comma; semicolon when the header has more of them), ``.tsv``/``.txt``
        (tab or whitespace), or any file with ``delimiter`` given. Lines starting with
        ``#`` are skipped; a first row that is not all numbers is the header.
    columns : sequence of CsvColumn
        The column map: one entry per channel to read; other columns are ignored.
    sample_rate_hz : float, optional
        Sampling rate in Hz; or give ``time_column`` (equidistant times in s).
    time_column : str or int, optional
        Column of the sample times in s, used for the rate if ``sample_rate_hz`` is not given.
    delimiter : str, optional
        Column separator; default from the suffix (see ``path``).
    metadata : mapping, optional
        Recording metadata (``source`` defaults to the file name).

    Returns
    -------
    Recording
        The mapped channels in SI units, in the order of ``columns``.

    Raises
    ------
    InputError
        A missing file, a column not in the file, a non-numeric or empty value (named with
        its line), rows of unequal length, a missing or non-uniform rate, or no drive/response.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"CSV file {str(path)!r} does not exist; give the path of the exported time data")
    columns = list(columns)
    if not columns:
        raise InputError(f"CSV file {str(path)!r}: empty column map; map at least one channel (--column)")
    names = [c.name for c in columns]
    if len(set(names)) != len(names):
        raise InputError(f"column map: channel names {names} repeat; give every channel its own name")
    lines, delimiter, header, width = _data_lines(path, delimiter)
    idx = [_column_index(path, header, width, c.column, f"channel {c.name!r}") for c in columns]
    t_idx = None if time_column is None else _column_index(path, header, width, time_column, "time")
    data, times = _parse_rows(path, lines, delimiter, width, columns, idx, t_idx)
    if sample_rate_hz is None:
        sample_rate_hz = _rate_from_times(path, times, time_column)
    if not (math.isfinite(float(sample_rate_hz)) and float(sample_rate_hz) > 0):
        raise InputError(f"sample_rate_hz {sample_rate_hz!r}; expected a positive rate in Hz")
    if not any(c.role == "drive" for c in columns) or all(c.role == "drive" for c in columns):
        raise InputError(
            f"column map of {str(path)!r}: {sum(c.role == 'drive' for c in columns)} drive column(s) among "
            f"{len(columns)}; map the excitation with role 'drive' and at least one response"
        )
    chans = tuple(
        Channel(
            c.name,
            c.quantity,
            QUANTITY_UNITS[c.quantity],
            c.direction,
            c.position_m,
            float(sample_rate_hz),
            data[:, k] * UNIT_FACTORS[c.unit][1],
            role=c.role,
        )
        for k, c in enumerate(columns)
    )
    meta = {"source": path.name}
    meta.update(metadata or {})
    return Recording(chans, meta)


def _data_lines(path: Path, delimiter: str | None):
    """Return the numbered data lines, the delimiter, the header (None: none) and the column count."""
    lines = [(i + 1, ln) for i, ln in enumerate(path.read_text(errors="replace").splitlines())]
    lines = [(i, ln) for i, ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"CSV file {str(path)!r} holds no data rows")
    if delimiter is None:
        head = lines[0][1]
        if path.suffix.lower() == ".csv":
            delimiter = ";" if head.count(";") > head.count(",") else ","
        elif "\t" in head:
            delimiter = "\t"
    first = _split(lines[0][1], delimiter)
    try:
        [float(v) for v in first]
        header = None
    except ValueError:
        header, lines = first, lines[1:]
    if len(lines) < 2:
        raise InputError(f"CSV file {str(path)!r}: {len(lines)} data row(s); expected a time series")
    return lines, delimiter, header, len(first)


def _column_index(path: Path, header, width: int, col, what: str) -> int:
    """Return the 0-based index of a column given by name (in the header) or by index."""
    if isinstance(col, int):
        if not 0 <= col < width:
            raise InputError(
                f"CSV file {str(path)!r}: {what} column index {col} is missing (the file has "
                f"{width} columns, 0-{width - 1}); map an existing column"
            )
        return col
    if header is None or col not in header:
        have = ", ".join(header) if header else "no header row"
        raise InputError(
            f"CSV file {str(path)!r}: {what} column {col!r} is missing (columns: {have}); "
            "map an existing column by name or 0-based index"
        )
    return header.index(col)


def _parse_rows(path: Path, lines, delimiter, width: int, columns, idx, t_idx):
    """Return the mapped columns as numbers (rows x channels) and the time column (None: not mapped)."""
    data = np.empty((len(lines), len(idx)))
    times = np.empty(len(lines)) if t_idx is not None else None
    for r, (lineno, ln) in enumerate(lines):
        cells = _split(ln, delimiter)
        if len(cells) != width:
            raise InputError(
                f"CSV file {str(path)!r} line {lineno}: {len(cells)} values, the first row has {width}; "
                "every row needs a value in every column (unequal column lengths)"
            )
        for k, (c, j) in enumerate(zip(columns, idx, strict=True)):
            try:
                data[r, k] = float(cells[j])
            except ValueError:
                raise InputError(
                    f"CSV file {str(path)!r} line {lineno}: channel {c.name!r} (column {c.column!r}) value "
                    f"{cells[j]!r} is not a number; fix or remove the row, or map a numeric column"
                ) from None
        if times is not None:
            try:
                times[r] = float(cells[t_idx])
            except ValueError:
                raise InputError(
                    f"CSV file {str(path)!r} line {lineno}: time value {cells[t_idx]!r} is not a number"
                ) from None
    return data, times


def _rate_from_times(path: Path, times, time_column) -> float:
    """Return the sample rate of an equidistant time column."""
    if times is None:
        raise InputError(
            f"CSV file {str(path)!r}: no sample rate; give sample_rate_hz (--rate) or a time column"
        )
    dt = np.diff(times)
    step = float(np.median(dt))
    if not step > 0 or np.max(np.abs(dt - step)) > 1e-3 * step:
        raise InputError(
            f"CSV file {str(path)!r}: time column {time_column!r} is not equidistant (steps "
            f"{dt.min():.6g}-{dt.max():.6g} s); resample the data or give --rate"
        )
    return 1.0 / step
