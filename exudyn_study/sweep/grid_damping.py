"""The damping columns of the damage grid: names resolved to per-body damping functions.

``adams-default``, ``step``, ``constant-1``/``constant-2``, ``table6`` (thesis Table 6) and
``suggested`` (a calibration result, :func:`damping_from_calibration`).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError

log = logging.getLogger(__name__)



#: damping names accepted by :func:`resolve_damping`
DAMPING_NAMES = ("adams-default", "step", "constant-1", "constant-2", "table6", "suggested")


_CALIBRATION_FORMAT = "exudyn_study.calibration"


_CAL_FREQ_RTOL = 0.01  # a calibration belongs to the same mesh: mode frequencies agree to 1 %


_SUGGESTED_CUTOFF_HZ = 500.0  # calibrate_cli's default: Table 1 reachable on Models 1/2


@dataclass(frozen=True)
class _CalibratedBody:
    """Per-mode ratios of one body from a calibration, checked against the body's modes."""

    body: str
    frequency_hz: tuple[float, ...]
    ratios: tuple[float, ...]

    def __call__(self, frequencies_hz) -> np.ndarray:
        f = np.asarray(frequencies_hz, dtype=float)
        ref = np.asarray(self.frequency_hz)
        if f.shape != ref.shape or not np.allclose(f, ref, rtol=_CAL_FREQ_RTOL, atol=1e-3):
            raise InputError(
                f"calibration of body {self.body!r}: {ref.size} modes ({_first(ref)} Hz), but the model's "
                f"body has {f.size} ({_first(f)} Hz); calibrate on the same mesh"
            )
        from exudyn_study.bodies.damping import PerModeTable

        return PerModeTable(self.ratios)(f)


def _first(f: np.ndarray, n: int = 3) -> str:
    return ", ".join(f"{v:.2f}" for v in f[:n]) + (", ..." if f.size > n else "")


def damping_from_calibration(source: str | os.PathLike | Mapping) -> dict:
    """Damping mapping body -> function from a calibration (``exudyn-study calibrate --json``).

    Parameters
    ----------
    source : path or mapping
        The calibration JSON file, or its content as a dict.

    Returns
    -------
    dict
        Body name -> damping function (the calibrated ratio of every mode, checked against
        the body's mode frequencies when the model is built); the rear foundation gets the
        calibration's ``other_damping`` (default ``'adams-default'``).

    Raises
    ------
    InputError
        Missing or unreadable file, another format, ratios outside [0, 1).
    """
    from exudyn_study.bodies.damping import validate_ratios

    where = "calibration"
    if isinstance(source, Mapping):
        data = source
    else:
        from exudyn_study.infra.files import load_json_input

        where = f"calibration {str(source)!r}"
        data = load_json_input(Path(source), "calibration")
    if not isinstance(data, Mapping) or data.get("format") != _CALIBRATION_FORMAT:
        raise InputError(f"{where}: expected a {_CALIBRATION_FORMAT!r} JSON (exudyn-study calibrate --json)")
    bodies = data.get("body_damping")
    if not isinstance(bodies, Mapping) or not bodies:
        raise InputError(f"{where}: no 'body_damping' entries")
    out: dict = {}
    for body, entry in bodies.items():
        if not isinstance(entry, Mapping):
            raise InputError(f"{where}: body {body!r} is a {type(entry).__name__}; expected an object")
        try:
            f = tuple(float(v) for v in entry["frequency_hz"])
            r = list(entry["damping_ratio"])
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(
                f"{where}: body {body!r} lacks frequency_hz/damping_ratio lists ({exc})") from None
        r = tuple(float(v) for v in validate_ratios(r, f"{where}: body {body!r} damping ratio"))
        if len(f) != len(r):
            raise InputError(f"{where}: body {body!r} has {len(f)} frequencies and {len(r)} ratios")
        out[body] = _CalibratedBody(str(body), f, r)
    metadata = data.get("metadata") or {}
    if not isinstance(metadata, Mapping):
        raise InputError(f"{where}: 'metadata' is a {type(metadata).__name__}; expected an object")
    other = metadata.get("other_damping", "adams-default")
    if not isinstance(other, str):
        raise InputError(f"{where}: metadata.other_damping = {other!r}; expected a damping name")
    out.setdefault("rear_foundation", other)
    return out


def _table1_calibration(model) -> dict:
    """Calibrate ``model``'s flexible-body damping against thesis Table 1 (Models 1/2)."""
    from exudyn_study.calibrate.design import DampingDesign
    from exudyn_study.calibrate.optimise import calibrate
    from exudyn_study.calibrate.system import system_from_model
    from exudyn_study.identify.model import ModalModel, Mode
    from exudyn_study.identify.synthetic import TABLE1_DAMPING, TABLE1_FREQUENCY_HZ

    target = ModalModel(tuple(
        Mode(f, z, description=f"thesis Table 1 mode {k + 1}")
        for k, (f, z) in enumerate(zip(TABLE1_FREQUENCY_HZ, TABLE1_DAMPING, strict=True))))
    if not model.assembled:
        model.assemble()
    bodies = {n: h for n, h in model.bodies.items() if n != "rear_foundation"}
    result = calibrate(system_from_model(model), DampingDesign.per_mode(bodies, _SUGGESTED_CUTOFF_HZ), target)
    log.info("suggested damping of model %s: calibrated on thesis Table 1, max |error| %.3f pp",
             model.variant, 100 * result.max_abs_error)
    data = result.to_dict({"target": "thesis Table 1", "other_damping": model.metadata.get("damping", "")})
    if data["metadata"]["other_damping"] not in ("adams-default", "step", "constant-1", "constant-2"):
        data["metadata"]["other_damping"] = "adams-default"
    return data


def resolve_damping(variant: int, name: str, calibration=None, probe: Callable | None = None):
    """Return the damping argument of ``build_model`` for a damping name of the grid.

    Parameters
    ----------
    variant : {1, 2, 3}
    name : str
        One of :data:`DAMPING_NAMES`.
    calibration : path or mapping, optional
        A calibration for ``'suggested'`` (see :func:`damping_from_calibration`).
    probe : callable, optional
        ``probe() -> Model`` (built with any damping, with the whole Exudyn mesh); Models 1/2
        ``'suggested'`` without a calibration are calibrated on it against thesis Table 1.

    Returns
    -------
    str, PerBody or dict
        A damping name, thesis Table 6, or a mapping body -> damping function.

    Raises
    ------
    InputError
        Unknown name; ``'suggested'`` for Model 1/2 with neither a calibration nor a probe.
    """
    from exudyn_study.bodies.damping import THESIS_TABLE6

    if name not in DAMPING_NAMES:
        raise InputError(f"damping {name!r} is unknown; expected one of {list(DAMPING_NAMES)}")
    if name == "table6":
        return THESIS_TABLE6
    if name != "suggested":
        return name
    if calibration is not None:
        return damping_from_calibration(calibration)
    if variant == 3:
        return THESIS_TABLE6
    if probe is None:
        raise InputError(
            f"damping 'suggested' for model {variant} needs a calibration "
            "(exudyn-study calibrate --json FILE)")
    return damping_from_calibration(_table1_calibration(probe()))
