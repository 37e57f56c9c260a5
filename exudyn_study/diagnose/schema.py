"""The diagnosis result: :class:`Finding` and :class:`Diagnosis`, and their JSON file.

Both the chassis path (:mod:`exudyn_study.diagnose.rig`) and the generic path
(:mod:`exudyn_study.diagnose.generic`) return a :class:`Diagnosis`. JSON schema
(``format`` 'exudyn_study.diagnosis', ``format_version`` 1)::

    {
      "format": "exudyn_study.diagnosis", "format_version": 1,
      "mismatch_found": true,               # any statistically significant mismatch located
      "findings": [                         # mismatch explained by a modelled physics
        {
          "physics": "joint_friction",      # catalogue / candidate name
          "location": {"sensors": ["A2", "B1"], "component": null, "interface": "A2-B1"},
                                            # optional: "position_m": [x, y, z], "nearest_sensor"
          "band_hz": [8.0, 70.0],
          "level_dependent": true,
          "explanation": "plain language ...",
          "parameters": {"slip_share": {"value": 0.6, "unit": "1", "std": 0.02,
                                        "at_bound": false}, ...},   # at_bound optional (false)
          "flags": ["..."],                 # optional: doubts about the finding (a parameter at a
                                            # bound, not identifiable in the final joint refit,
                                            # drifting between recordings); default []
          "fit": {"train_before": 0.41, "train_after": 0.06, "holdout_before": 0.52,
                  "holdout_after": 0.08, "metric": "...",   # the five required keys
                  "per_channel": {...}}                      # optional detail
        }
      ],
      "unexplained": [                      # located mismatch that nothing explains
        {"location": {...}, "band_hz": [lo, hi], "level_dependent": true, "explanation": "..."}
      ],
      "metadata": {...}                     # optional: model, recordings, levels, timing
    }

``mismatch_found`` is False (and both lists empty) when no statistically significant
mismatch was found: "no missing physics found".
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from exudyn_study.errors import InputError

__all__ = [
    "Finding", "Diagnosis", "read_json", "FORMAT_NAME", "FORMAT_VERSION", "FIT_KEYS", "LOCATION_KEYS",
    "NOT_IDENTIFIABLE",
]

FORMAT_NAME = "exudyn_study.diagnosis"
FORMAT_VERSION = 1
#: keys every ``Finding.fit`` carries
FIT_KEYS = ("train_before", "train_after", "holdout_before", "holdout_after", "metric")
#: keys of a location
LOCATION_KEYS = ("sensors", "component", "interface")
#: optional keys of a location: the place in global coordinates (m) and the sensor nearest to it
LOCATION_OPTIONAL = ("position_m", "nearest_sensor")
#: a flag containing this text marks a finding whose parameters the data do not determine: it is
#: reported apart and not counted as a finding (:attr:`Finding.identifiable`)
NOT_IDENTIFIABLE = "not identifiable"


def _location(loc, who: str) -> dict:
    if not isinstance(loc, Mapping):
        raise InputError(f"{who}: location {loc!r}; expected a mapping with keys {list(LOCATION_KEYS)}")
    unknown = sorted(set(loc) - set(LOCATION_KEYS) - set(LOCATION_OPTIONAL))
    if unknown:
        raise InputError(
            f"{who}: location has unknown keys {unknown}; expected {list(LOCATION_KEYS)} "
            f"(optional {list(LOCATION_OPTIONAL)})"
        )
    sensors = loc.get("sensors") or []
    if isinstance(sensors, str) or not all(isinstance(s, str) for s in sensors):
        raise InputError(f"{who}: location sensors {sensors!r}; expected a list of sensor names")
    out = {"sensors": list(sensors)}
    for key in ("component", "interface"):
        v = loc.get(key)
        if v is not None and not isinstance(v, str):
            raise InputError(f"{who}: location {key} {v!r}; expected a string or null")
        out[key] = v
    if loc.get("position_m") is not None:
        try:
            pos = [float(v) for v in loc["position_m"]]
        except (TypeError, ValueError):
            pos = []
        if len(pos) != 3 or not all(math.isfinite(v) for v in pos):
            raise InputError(f"{who}: location position_m {loc['position_m']!r}; expected [x, y, z] in m")
        out["position_m"] = pos
    if loc.get("nearest_sensor") is not None:
        if not isinstance(loc["nearest_sensor"], str):
            raise InputError(f"{who}: location nearest_sensor {loc['nearest_sensor']!r}; expected a name")
        out["nearest_sensor"] = loc["nearest_sensor"]
    return out


def _band(band, who: str):
    if band is None:
        return None
    try:
        lo, hi = (float(b) for b in band)
    except (TypeError, ValueError):
        raise InputError(f"{who}: band_hz {band!r}; expected [low, high] in Hz or null") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
        raise InputError(f"{who}: band_hz {band!r}; expected 0 <= low <= high (Hz)")
    return (lo, hi)


def _number(v, who: str, allow_none: bool = True):
    if v is None and allow_none:
        return None
    if isinstance(v, bool):
        raise InputError(f"{who}: {v!r}; expected a number")
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{who}: {v!r}; expected a number{' or null' if allow_none else ''}") from None
    return x if math.isfinite(x) else None


def _flag(v, who: str) -> bool:
    if not isinstance(v, bool):
        raise InputError(f"{who}: {v!r}; expected true or false")
    return v


@dataclass(frozen=True)
class Finding:
    """One located mismatch explained by a modelled physics.

    Parameters
    ----------
    physics : str
        Name of the physics (catalogue entry or generic candidate, e.g. 'joint_friction').
    location : mapping
        ``sensors`` (list of str), ``component`` (str or None), ``interface`` (str or None).
    band_hz : (float, float) or None
        Frequency band of the mismatch in Hz.
    level_dependent : bool
        Whether the mismatch changes with the excitation level.
    explanation : str
        Plain-language explanation.
    parameters : mapping name -> {'value', 'unit', 'std', 'at_bound'}
        Fitted parameters (SI; ``std`` None if unknown; ``at_bound`` optional, default False: the fit
        ended at the parameter's bound, so the data do not determine it).
    fit : mapping
        ``train_before``, ``train_after``, ``holdout_before``, ``holdout_after`` (errors of the
        nominal and the augmented model, None if not computed) and ``metric`` (str, what the
        error is); optional extra keys (e.g. ``per_channel``) are kept.
    flags : sequence of str, optional
        Doubts about the finding that did not reject it, one sentence each (a parameter at its
        bound, not identifiable in the final joint refit, drifting between recordings).

    Raises
    ------
    InputError
        On a missing key or a value of the wrong type.
    """

    physics: str
    location: Mapping
    band_hz: tuple | None
    level_dependent: bool
    explanation: str
    parameters: Mapping = field(default_factory=dict)
    fit: Mapping = field(default_factory=dict)
    flags: tuple = ()

    def __post_init__(self) -> None:
        if not isinstance(self.physics, str) or not self.physics:
            raise InputError(f"finding physics {self.physics!r}: expected a non-empty name")
        who = f"finding {self.physics!r}"
        object.__setattr__(self, "location", _location(self.location, who))
        object.__setattr__(self, "band_hz", _band(self.band_hz, who))
        object.__setattr__(self, "level_dependent", bool(self.level_dependent))
        if not isinstance(self.explanation, str):
            raise InputError(f"{who}: explanation {self.explanation!r}; expected a string")
        params = {}
        for name, p in dict(self.parameters).items():
            if not isinstance(p, Mapping) or "value" not in p or "unit" not in p:
                raise InputError(f"{who}: parameter {name!r} = {p!r}; expected {{'value', 'unit', 'std'}}")
            params[str(name)] = {
                "value": _number(p["value"], f"{who}: parameter {name!r} value", False),
                "unit": str(p["unit"]),
                "std": _number(p.get("std"), f"{who}: parameter {name!r} std"),
                "at_bound": _flag(p.get("at_bound", False), f"{who}: parameter {name!r} at_bound"),
            }
        object.__setattr__(self, "parameters", params)
        fit = dict(self.fit)
        missing = [k for k in FIT_KEYS if k not in fit]
        if missing:
            raise InputError(f"{who}: fit lacks {missing}; expected keys {list(FIT_KEYS)}")
        for k in FIT_KEYS[:4]:
            fit[k] = _number(fit[k], f"{who}: fit {k}")
        if not isinstance(fit["metric"], str):
            raise InputError(f"{who}: fit metric {fit['metric']!r}; expected a description string")
        object.__setattr__(self, "fit", fit)
        if isinstance(self.flags, str) or not all(isinstance(t, str) for t in self.flags):
            raise InputError(f"{who}: flags {self.flags!r}; expected a list of sentences (strings)")
        object.__setattr__(self, "flags", tuple(self.flags))

    @property
    def identifiable(self) -> bool:
        """False when a flag says the data do not determine its parameters (:data:`NOT_IDENTIFIABLE`)."""
        return not any(NOT_IDENTIFIABLE in t.lower() for t in self.flags)

    @property
    def place(self) -> str:
        """Where the finding is: its interface, else its component, else its sensors (else ``"-"``)."""
        loc = self.location
        return loc.get("interface") or loc.get("component") or ", ".join(loc["sensors"]) or "-"

    def to_dict(self) -> dict:
        """JSON-ready dict of the module schema."""
        return {
            "physics": self.physics,
            "location": dict(self.location),
            "band_hz": None if self.band_hz is None else list(self.band_hz),
            "level_dependent": self.level_dependent,
            "explanation": self.explanation,
            "parameters": {k: dict(v) for k, v in self.parameters.items()},
            "fit": _jsonable(self.fit),
            "flags": list(self.flags),
        }

    @classmethod
    def from_dict(cls, d: Mapping) -> Finding:
        """Build from a dict of the module schema (InputError naming a missing key).

        Parameters
        ----------
        d : mapping
            A finding of the module schema (``physics``, ``location``, ``band_hz``, ``level_dependent``,
            ``explanation``, ``parameters``, ``fit``; ``flags`` optional).

        Returns
        -------
        Finding
            The finding.

        Raises
        ------
        InputError
            If ``d`` is not a mapping, lacks a key or holds a value of the wrong type.
        """
        if not isinstance(d, Mapping):
            raise InputError(f"finding {d!r}: expected an object")
        keys = ("physics", "location", "band_hz", "level_dependent", "explanation", "parameters", "fit")
        missing = [k for k in keys if k not in d]
        if missing:
            raise InputError(f"finding {d.get('physics', '?')!r}: missing keys {missing}")
        return cls(**{k: d[k] for k in keys}, flags=tuple(d.get("flags", ())))


@dataclass(frozen=True)
class Diagnosis:
    """The diagnosis: whether mismatch was found, what explains it, what is left unexplained.

    Parameters
    ----------
    mismatch_found : bool
        True if any statistically significant mismatch was located.
    findings : sequence of Finding
    unexplained : sequence of mapping
        Located mismatch nothing explains: ``location``, ``band_hz``, ``level_dependent``,
        ``explanation``.
    metadata : mapping, optional
        JSON-serialisable description (model, recordings, levels, wall time).

    Raises
    ------
    InputError
        If ``mismatch_found`` is False but findings or unexplained mismatch are given.
    """

    mismatch_found: bool
    findings: tuple = ()
    unexplained: tuple = ()
    metadata: Mapping = field(default_factory=dict)

    def __post_init__(self) -> None:
        findings = tuple(f if isinstance(f, Finding) else Finding.from_dict(f) for f in self.findings)
        unexplained = []
        for i, u in enumerate(self.unexplained):
            if not isinstance(u, Mapping):
                raise InputError(f"unexplained[{i}] {u!r}: expected an object")
            who = f"unexplained[{i}]"
            item = dict(u)
            item["location"] = _location(u.get("location", {}), who)
            band = _band(u.get("band_hz"), who)
            item["band_hz"] = None if band is None else list(band)
            item["level_dependent"] = bool(u.get("level_dependent", False))
            item["explanation"] = str(u.get("explanation", ""))
            unexplained.append(item)
        mismatch = bool(self.mismatch_found)
        if not mismatch and (findings or unexplained):
            raise InputError(
                "diagnosis: mismatch_found is False but findings or unexplained mismatch are "
                "given; expected both empty"
            )
        try:
            json.dumps(_jsonable(dict(self.metadata)))
        except (TypeError, ValueError) as exc:
            raise InputError(f"diagnosis metadata: expected JSON-serialisable values ({exc})") from None
        object.__setattr__(self, "mismatch_found", mismatch)
        object.__setattr__(self, "findings", findings)
        object.__setattr__(self, "unexplained", tuple(unexplained))
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def summary(self) -> str:
        """One line: 'no missing physics found', or the findings, the unexplained count and what is apart.

        Findings whose parameters are not identifiable (:attr:`Finding.identifiable`) are not
        named as findings: they are counted after the rest as fitted but not identifiable.
        """
        if not self.mismatch_found:
            return "no missing physics found"
        parts = [f"{f.physics} at {f.place}" for f in self.findings if f.identifiable]
        if self.unexplained:
            n = len(self.unexplained)
            parts.append(f"{n} unexplained mismatch{'es' if n > 1 else ''}")
        weak = [f"{f.physics} at {f.place}" for f in self.findings if not f.identifiable]
        if weak:
            parts.append("fitted but not identifiable (not findings): " + ", ".join(weak))
        if not any(f.identifiable for f in self.findings) and not self.unexplained:
            parts.insert(0, "mismatch found, not explained")
        return "; ".join(parts)

    def to_dict(self) -> dict:
        """JSON-ready dict of the module schema."""
        return {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "mismatch_found": self.mismatch_found,
            "findings": [f.to_dict() for f in self.findings],
            "unexplained": _jsonable([dict(u) for u in self.unexplained]),
            "metadata": _jsonable(self.metadata),
        }

    @classmethod
    def from_dict(cls, d: Mapping) -> Diagnosis:
        """Build from a dict of the module schema (a different format or newer version: InputError).

        Parameters
        ----------
        d : mapping
            A diagnosis of the module schema (``mismatch_found``, ``findings``, ``unexplained``, optional
            ``metadata``, ``format`` and ``format_version``).

        Returns
        -------
        Diagnosis
            The diagnosis.

        Raises
        ------
        InputError
            If ``d`` is not of the schema, of another format or of a newer format version.
        """
        if not isinstance(d, Mapping) or "mismatch_found" not in d:
            raise InputError(
                "diagnosis JSON: expected an object with 'mismatch_found', 'findings', 'unexplained'"
            )
        fmt = d.get("format", FORMAT_NAME)
        if fmt != FORMAT_NAME:
            raise InputError(f"diagnosis JSON: format {fmt!r}; expected {FORMAT_NAME!r}")
        ver = d.get("format_version", FORMAT_VERSION)
        if not isinstance(ver, int) or ver > FORMAT_VERSION:
            raise InputError(
                f"diagnosis JSON: format_version {ver!r}; this version reads up to {FORMAT_VERSION}"
            )
        if not isinstance(d.get("findings", []), Sequence) or not isinstance(
            d.get("unexplained", []), Sequence
        ):
            raise InputError("diagnosis JSON: 'findings' and 'unexplained' must be lists")
        return cls(
            bool(d["mismatch_found"]),
            tuple(Finding.from_dict(f) for f in d.get("findings", [])),
            tuple(d.get("unexplained", [])),
            dict(d.get("metadata") or {}),
        )

    def to_json(self) -> str:
        """Return the JSON text (strict: NaN/inf written as null)."""
        return json.dumps(self.to_dict(), indent=1, allow_nan=False)

    def write_json(self, path: str | os.PathLike) -> Path:
        """Write atomically (temporary file in the same directory, then ``os.replace``).

        Parameters
        ----------
        path : str or os.PathLike
            The file to write (its directory must exist).

        Raises
        ------
        InputError
            If the directory does not exist.

        Returns
        -------
        pathlib.Path
            The path written.
        """
        path = Path(path)
        if not path.parent.is_dir():
            raise InputError(f"diagnosis JSON {str(path)!r}: directory {str(path.parent)!r} does not exist")
        from exudyn_study.infra.atomic import write_text_atomic

        return write_text_atomic(path, self.to_json(), "diagnosis JSON")


def read_json(path: str | os.PathLike) -> Diagnosis:
    """Read a diagnosis JSON file (InputError if missing or not of the schema).

    Parameters
    ----------
    path : str or os.PathLike
        The diagnosis JSON file.

    Returns
    -------
    Diagnosis
        The diagnosis.

    Raises
    ------
    InputError
        If the file does not exist, is not valid JSON or not of the schema.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"diagnosis JSON {str(path)!r}: no such file")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise InputError(f"diagnosis JSON {str(path)!r}: not valid JSON ({exc})") from None
    return Diagnosis.from_dict(doc)


def _jsonable(obj):
    """Plain JSON types: tuples to lists, NumPy scalars to Python, non-finite floats to None."""
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if hasattr(obj, "tolist") and not isinstance(obj, (str, bytes)):
        return _jsonable(obj.tolist())
    if isinstance(obj, bool) or obj is None or isinstance(obj, (str, int)):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    return obj
