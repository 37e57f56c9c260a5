"""UFF58 (universal file, dataset 58) reading and writing of recordings, through pyuff.

Integrity: the writer puts the channel count and a SHA-256 of the channels' names and
samples into the description of the file's header set (UFF 151,
``exudyn_study UFF58 channels=N sha256=...``); the reader refuses a file of ours whose
channels or samples do not match (cut short, bytes changed). Any UFF file must end with a
closed dataset (its last line ``-1``): a file cut inside a dataset is refused, not read as
the channels before the cut. Malformed tags (``fs=fast``) and sets pyuff cannot parse are
:class:`~exudyn_study.errors.InputError`.
"""

from __future__ import annotations

import gc
import hashlib
import json
import re
import warnings
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError
from exudyn_study.recording.types import QUANTITY_UNITS, Channel, Recording
from exudyn_study.recording.uff_ascii import read_sets

_UFF_SUFFIXES = (".uff", ".unv")


#: UFF "specific data type" codes (record 9, field 1) for the quantities we carry
_UFF_SPEC_TYPE = {"acceleration": 12, "displacement": 8, "force": 13, "voltage": 1}  # 1: general


_UFF_SPEC_TYPE_INV = {12: "acceleration", 8: "displacement", 9: "force", 13: "force"}


#: (length, force) unit exponents of each quantity (record 9, fields 2-3)
_UFF_EXPONENTS = {"acceleration": (1, 0), "displacement": (1, 0), "force": (0, 1), "voltage": (0, 0)}


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
    "v": ("voltage", 1.0),
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


_INTEGRITY = re.compile(r"exudyn_study UFF58 channels=(\d+) sha256=([0-9a-f]{32})")


def _channels_digest(pairs) -> str:
    """SHA-256 (first 32 hex digits) of (name, samples as float64 little endian) pairs, in order."""
    digest = hashlib.sha256()
    for name, data in pairs:
        digest.update(str(name).encode())
        digest.update(np.ascontiguousarray(np.asarray(data).real, dtype="<f8").tobytes())
    return digest.hexdigest()[:32]


def _write_uff(recording: Recording, path: Path) -> None:
    import pyuff

    from exudyn_study import __version__

    chunks = _meta_chunks(recording)
    check = _channels_digest((ch.name, ch.data) for ch in recording.channels)
    sets: list[dict] = [
        pyuff.prepare_151(
            model_name=str(recording.metadata.get("model", "exudyn_study recording"))[:80],
            description=f"exudyn_study UFF58 channels={len(recording.channels)} sha256={check}",
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


def _float_tag(tags: dict, key: str, where: str, name: str) -> float | None:
    if key not in tags:
        return None
    try:
        value = float(tags[key])
    except ValueError:
        raise InputError(f"{where}: channel {name!r} tag {key}={tags[key]!r} is not a number") from None
    if not np.isfinite(value) or value <= 0:
        raise InputError(f"{where}: channel {name!r} tag {key}={tags[key]!r}; expected a number > 0")
    return value


def _check_closed(path: Path, where: str) -> None:
    """Refuse a file cut inside a dataset: a UFF file ends with the line ``-1``."""
    with open(path, "rb") as fh:
        fh.seek(0, 2)
        size = fh.tell()
        fh.seek(max(0, size - 256))
        tail = fh.read()
    if not tail.rstrip().endswith(b" -1"):  # the delimiter is "-1" right-aligned in 6 columns
        raise InputError(f"{where}: the last dataset is not closed (the file ends inside a dataset: "
                         "cut short or damaged); re-export the file")


def _verify_integrity(sets: list[dict], pairs: list, where: str) -> None:
    """Check the channel count and digest a file of ours carries in its UFF 151 header."""
    for s in sets:
        if s.get("type") != 151:
            continue
        match = _INTEGRITY.search(str(s.get("description", "")))
        if match is None:
            return
        n, digest = int(match.group(1)), match.group(2)
        if len(pairs) != n:
            raise InputError(f"{where}: holds {len(pairs)} of the {n} channels it was written with (cut "
                             "short or edited); re-export the file")
        if _channels_digest(pairs) != digest:
            raise InputError(f"{where}: channel data do not match the file's checksum (damaged or edited "
                             "after writing); re-export the file")
        return


def _read_uff(path: Path) -> Recording:
    try:
        return _read_uff_sets(path)
    except InputError:
        raise
    except (KeyError, ValueError, TypeError, IndexError, OverflowError) as exc:
        raise InputError(f"recording file {str(path)!r}: malformed UFF58 content ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:160]})") from None


def _read_uff_sets(path: Path) -> Recording:
    import pyuff

    where = f"recording file {str(path)!r}"
    _check_closed(path, where)
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
        sets = read_sets(uff, path, set_types)  # ASCII 58 ordinates parsed by NumPy
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

    channels, meta_text, skipped, raw_pairs = [], [], [], []
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
        raw_pairs.append((name, s["data"]))
        rate = _float_tag(tags, "fs", where, name)
        if rate is None:
            inc = float(s.get("abscissa_inc", 0.0))
            if not inc > 0:
                raise InputError(
                    f"{where}: channel {name!r} has abscissa increment {inc!r}; expected "
                    "evenly sampled time data with an increment > 0 s"
                )
            rate = _rate_from_increment(inc)
        sens = _float_tag(tags, "sensitivity", where, name)
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
                sensitivity=sens,
            )
        )
    _verify_integrity(sets, raw_pairs, where)
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
