"""The modal model type and its JSON file, shared by identification, rig and calibration.

Schema (``format`` 'exudyn_study.modes', ``format_version`` 1)::

    {
      "format": "exudyn_study.modes",
      "format_version": 1,
      "metadata": {...},                    # free-form: source, estimator, band, ...
      "modes": [
        {
          "frequency_hz": 12.05,            # undamped natural frequency, Hz
          "damping_ratio": 0.0181,          # viscous damping ratio, - (not percent)
          "frequency_std_hz": 0.01,         # uncertainty (spread over orders) or null
          "damping_std": 0.0004,            # uncertainty, - , or null
          "mpc": 0.998,                     # modal phase collinearity 0..1, or null
          "description": "",                # optional text
          "shape": {"ARFMZ": [re, im], ...} # channel/sensor name -> complex coefficient
        }, ...
      ]
    }

The identification writes every field; the rig's ``exudyn-study modes`` writes at
least ``frequency_hz``, ``damping_ratio``, ``description`` and ``shape``: the
missing fields read as None. Shapes are scaled so that the largest-magnitude
coefficient is 1 + 0j (MAC is scale-free).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError

__all__ = [
    "Mode",
    "ModalModel",
    "read_modes_json",
    "write_modes_json",
    "FORMAT_NAME",
    "FORMAT_VERSION",
]

FORMAT_NAME = "exudyn_study.modes"
FORMAT_VERSION = 1


def _opt_float(value, name: str, who: str, lo=None, hi=None):
    if value is None:
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{who}: {name}={value!r}: expected a number or null") from None
    if not math.isfinite(v) or (lo is not None and v < lo) or (hi is not None and v > hi):
        rng = f" in [{lo}, {hi}]" if hi is not None else (f" >= {lo}" if lo is not None else "")
        raise InputError(f"{who}: {name}={value!r}: expected a finite number{rng}")
    return v


@dataclass(frozen=True, eq=False)
class Mode:
    """One mode: pole, uncertainty, complexity and shape at named channels.

    Parameters
    ----------
    frequency_hz : float
        Undamped natural frequency in Hz, > 0.
    damping_ratio : float
        Viscous damping ratio (-), in [0, 1).
    frequency_std_hz : float or None
        Standard deviation of the frequency in Hz (spread over model orders).
    damping_std : float or None
        Standard deviation of the damping ratio (-).
    mpc : float or None
        Modal phase collinearity in [0, 1].
    shape : mapping of str to complex
        Shape coefficient per channel name.
    description : str
        Free text (e.g. which component moves most).
    """

    frequency_hz: float
    damping_ratio: float
    frequency_std_hz: float | None = None
    damping_std: float | None = None
    mpc: float | None = None
    shape: Mapping[str, complex] = field(default_factory=dict)
    description: str = ""

    def __post_init__(self) -> None:
        who = "mode"
        f = _opt_float(self.frequency_hz, "frequency_hz", who, lo=0.0)
        if f is None or f <= 0:
            raise InputError(f"mode: frequency_hz={self.frequency_hz!r}: expected > 0 Hz")
        who = f"mode at {f:.4g} Hz"
        z = _opt_float(self.damping_ratio, "damping_ratio", who, lo=0.0, hi=1.0)
        if z is None or z >= 1.0:
            raise InputError(f"{who}: damping_ratio={self.damping_ratio!r}: expected in [0, 1)")
        object.__setattr__(self, "frequency_hz", f)
        object.__setattr__(self, "damping_ratio", z)
        object.__setattr__(self, "frequency_std_hz",
                           _opt_float(self.frequency_std_hz, "frequency_std_hz", who, lo=0.0))
        object.__setattr__(self, "damping_std",
                           _opt_float(self.damping_std, "damping_std", who, lo=0.0))
        object.__setattr__(self, "mpc", _opt_float(self.mpc, "mpc", who, lo=0.0, hi=1.0))
        shape = {}
        for k, v in dict(self.shape).items():
            if not isinstance(k, str) or not k:
                raise InputError(f"{who}: shape key {k!r}: expected a channel name")
            c = complex(v)
            if not (math.isfinite(c.real) and math.isfinite(c.imag)):
                raise InputError(f"{who}: shape[{k!r}]={v!r}: expected a finite value")
            shape[k] = c
        object.__setattr__(self, "shape", shape)
        if not isinstance(self.description, str):
            raise InputError(f"{who}: description {self.description!r}: expected a string")

    def shape_vector(self, names: Sequence[str]) -> np.ndarray:
        """Return the shape at ``names`` as a complex vector (InputError on a missing name)."""
        missing = [n for n in names if n not in self.shape]
        if missing:
            raise InputError(
                f"mode at {self.frequency_hz:.4g} Hz has no shape value for {missing[:5]}; "
                f"it has {sorted(self.shape)[:10]}"
            )
        return np.array([self.shape[n] for n in names], dtype=complex)

    def to_dict(self) -> dict:
        """JSON-ready dict (see module schema)."""
        return {
            "frequency_hz": self.frequency_hz,
            "damping_ratio": self.damping_ratio,
            "frequency_std_hz": self.frequency_std_hz,
            "damping_std": self.damping_std,
            "mpc": self.mpc,
            "description": self.description,
            "shape": {k: [v.real, v.imag] for k, v in self.shape.items()},
        }

    @classmethod
    def from_dict(cls, d: Mapping) -> Mode:
        """Build from a dict of the module schema (missing optional fields -> None)."""
        if not isinstance(d, Mapping):
            raise InputError(f"mode entry {d!r}: expected an object")
        for key in ("frequency_hz", "damping_ratio"):
            if key not in d:
                raise InputError(f"mode entry without {key!r}: expected keys frequency_hz, "
                                 "damping_ratio, shape")
        shape = {}
        for k, v in dict(d.get("shape") or {}).items():
            if isinstance(v, (list, tuple)) and len(v) == 2:
                shape[k] = complex(float(v[0]), float(v[1]))
            elif isinstance(v, (int, float)):
                shape[k] = complex(float(v), 0.0)
            else:
                raise InputError(f"mode shape[{k!r}]={v!r}: expected [real, imag]")
        return cls(
            frequency_hz=d["frequency_hz"],
            damping_ratio=d["damping_ratio"],
            frequency_std_hz=d.get("frequency_std_hz"),
            damping_std=d.get("damping_std"),
            mpc=d.get("mpc"),
            shape=shape,
            description=d.get("description") or "",
        )


@dataclass(frozen=True, eq=False)
class ModalModel:
    """A set of modes with metadata; the unit of exchange between modules.

    Parameters
    ----------
    modes : tuple of Mode
        Modes, sorted by frequency on construction.
    metadata : mapping
        JSON-serialisable metadata (source file, estimator, band, reference, ...).
    """

    modes: tuple[Mode, ...]
    metadata: Mapping = field(default_factory=dict)

    def __post_init__(self) -> None:
        modes = tuple(self.modes)
        if not all(isinstance(m, Mode) for m in modes):
            raise InputError("modes: expected a sequence of Mode")
        object.__setattr__(self, "modes", tuple(sorted(modes, key=lambda m: m.frequency_hz)))
        try:
            json.dumps(dict(self.metadata))
        except (TypeError, ValueError) as exc:
            raise InputError(f"metadata: expected JSON-serialisable values ({exc})") from None
        object.__setattr__(self, "metadata", dict(self.metadata))

    def __len__(self) -> int:
        return len(self.modes)

    @property
    def frequency_hz(self) -> np.ndarray:
        """Frequencies in Hz, shape (n_modes,)."""
        return np.array([m.frequency_hz for m in self.modes])

    @property
    def damping_ratio(self) -> np.ndarray:
        """Damping ratios (-), shape (n_modes,)."""
        return np.array([m.damping_ratio for m in self.modes])

    @property
    def channels(self) -> tuple[str, ...]:
        """Channel names present in every mode's shape, in the first mode's order."""
        if not self.modes:
            return ()
        first = list(self.modes[0].shape)
        return tuple(n for n in first if all(n in m.shape for m in self.modes))

    def shapes(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Shape matrix ``phi[n_channels, n_modes]`` at ``names`` (default :attr:`channels`)."""
        names = self.channels if names is None else tuple(names)
        if not self.modes:
            return np.zeros((len(names), 0), complex)
        return np.column_stack([m.shape_vector(names) for m in self.modes])

    def to_json(self) -> str:
        """Serialise to a JSON string of the module schema."""
        doc = {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "metadata": dict(self.metadata),
            "modes": [m.to_dict() for m in self.modes],
        }
        return json.dumps(doc, indent=1)

    @classmethod
    def from_json(cls, text: str) -> ModalModel:
        """Parse a JSON string of the module schema.

        A document without ``format`` is accepted if it has a ``modes`` list (e.g.
        written by another tool); a different ``format`` or a newer
        ``format_version`` raises :class:`InputError`.
        """
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"modes JSON: not valid JSON ({exc})") from None
        if not isinstance(doc, Mapping) or not isinstance(doc.get("modes"), list):
            raise InputError("modes JSON: expected an object with a 'modes' list")
        fmt = doc.get("format", FORMAT_NAME)
        if fmt != FORMAT_NAME:
            raise InputError(f"modes JSON: format {fmt!r}: expected {FORMAT_NAME!r}")
        ver = doc.get("format_version", FORMAT_VERSION)
        if not isinstance(ver, int) or ver > FORMAT_VERSION:
            raise InputError(
                f"modes JSON: format_version {ver!r}: this version reads up to {FORMAT_VERSION}"
            )
        return cls(tuple(Mode.from_dict(m) for m in doc["modes"]),
                   dict(doc.get("metadata") or {}))


def write_modes_json(model: ModalModel, path: str | os.PathLike) -> Path:
    """Write ``model`` to ``path`` atomically (temporary file, then ``os.replace``).

    Parameters
    ----------
    model : ModalModel
        The modes to write.
    path : str or path-like
        Destination ``.json`` file; its directory must exist.

    Returns
    -------
    Path
        The written path.

    Raises
    ------
    InputError
        If ``model`` is not a :class:`ModalModel` or the directory does not exist.
    """
    if not isinstance(model, ModalModel):
        raise InputError(f"model of type {type(model).__name__}: expected a ModalModel")
    path = Path(path)
    if not path.parent.is_dir():
        raise InputError(f"modes JSON {str(path)!r}: directory {str(path.parent)!r} does not exist")
    from exudyn_study.infra.atomic import write_text_atomic

    return write_text_atomic(path, model.to_json(), "modes JSON")


def read_modes_json(path: str | os.PathLike) -> ModalModel:
    """Read a modes JSON file (identification or rig output).

    Parameters
    ----------
    path : str or path-like
        The ``.json`` file.

    Returns
    -------
    ModalModel

    Raises
    ------
    InputError
        If the file does not exist or does not follow the schema.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"modes JSON {str(path)!r}: no such file")
    try:
        return ModalModel.from_json(path.read_text(encoding="utf-8"))
    except InputError as exc:
        raise InputError(f"modes JSON {str(path)!r}: {exc}") from None
