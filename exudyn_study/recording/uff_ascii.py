"""Fast reading of the data blocks of ASCII UFF58 datasets.

pyuff parses ASCII dataset-58 ordinates one Python ``float`` at a time (about 2.5 us a value:
seconds for a 25-channel, 200 s, 1 kHz recording). The ordinates of an evenly spaced dataset
are fixed-width fields (``E13.5`` single, ``E20.12`` double precision, real or interleaved
real/imaginary), so a block is cut into fields and converted by NumPy in one call. The headers
still come from pyuff (``header_only=True``); any dataset this reader cannot take exactly (binary
58b, uneven abscissa, a field count that does not match ``num_pts``, a field NumPy cannot parse)
is read by pyuff as before.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["read_sets"]

#: field width of the ordinates per UFF58 ordinate data type (2/5 single, 4/6 double)
_WIDTH = {2: 13, 5: 13, 4: 20, 6: 20}


def _blocks(raw: bytes) -> list[list[bytes]]:
    """Lines between consecutive delimiter pairs (``-1`` lines): one list per dataset."""
    lines = raw.split(b"\n")
    marks = [k for k, ln in enumerate(lines) if len(ln) < 12 and ln.strip() == b"-1"]
    return [lines[marks[k] + 1:marks[k + 1]] for k in range(0, len(marks) - 1, 2)]


def _parse(lines: list[bytes], header: dict) -> np.ndarray | None:
    """Ordinates of one ASCII 58 block, or None when it cannot be read exactly."""
    kind = int(header.get("ord_data_type", 0))
    if int(header.get("binary", 0)) or int(header.get("abscissa_spacing", 1)) != 1 or kind not in _WIDTH:
        return None
    # line 0: the dataset number; lines 1-11: records 1-11 of the header; then the ordinates
    if len(lines) < 13 or lines[0].strip() != b"58":
        return None
    w = _WIDTH[kind]
    data = [ln.rstrip(b"\r") for ln in lines[12:]]
    full = 80 if w == 20 else 78  # 4 E20.12 or 6 E13.5 fields a line
    if set(map(len, data[:-1])) <= {full}:
        body = b"".join(data[:-1]) + data[-1].ljust(-(-len(data[-1]) // w) * w) if data else b""
    else:
        body = b"".join(ln.ljust(-(-len(ln) // w) * w) for ln in data)
    fields = np.frombuffer(body, dtype=f"S{w}")
    fields = fields[fields != b" " * w]
    try:
        values = fields.astype(np.float64)
    except ValueError:
        return None
    n = int(header.get("num_pts", -1))
    if kind in (5, 6):
        if values.size != 2 * n:
            return None
        return values[0::2] + 1j * values[1::2]
    return values if values.size == n else None


def read_sets(uff, path: str | Path, set_types: list[int]) -> list[dict]:
    """Return every dataset of an open ``pyuff.UFF`` like ``uff.read_sets(i)`` would.

    Parameters
    ----------
    uff : pyuff.UFF
        The file, opened by pyuff.
    path : str or Path
        Its path (read once more as bytes).
    set_types : list of int
        ``uff.get_set_types()``.

    Returns
    -------
    list of dict
        The datasets; the ordinates of ASCII, evenly spaced type-58 datasets are parsed here
        (``data`` and ``x`` as pyuff gives them), all others by pyuff.
    """
    if 58 not in set_types:
        return [uff.read_sets(i) for i in range(len(set_types))]
    headers = {i: uff.read_sets(i, header_only=True) for i, t in enumerate(set_types) if t == 58}
    if any(int(h.get("binary", 0)) for h in headers.values()):
        return [uff.read_sets(i) for i in range(len(set_types))]
    blocks = _blocks(Path(path).read_bytes())
    out = []
    for i, t in enumerate(set_types):
        values = None
        if t == 58 and len(blocks) == len(set_types):
            values = _parse(blocks[i], headers[i])
        if values is None:
            out.append(uff.read_sets(i))
            continue
        s = dict(headers[i])
        s["data"] = values
        s["x"] = float(s["abscissa_min"]) + float(s["abscissa_inc"]) * np.arange(values.size)
        out.append(s)
    return out
