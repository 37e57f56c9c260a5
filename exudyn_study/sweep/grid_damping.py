"""The damping columns of the damage grid: names resolved to per-body damping functions.

``adams-default``, ``step``, ``constant-1``/``constant-2`` and ``table6`` (thesis Table 6) are
fixed functions of mode frequency. ``suggested`` is the thesis's question: flexible-body damping
chosen so that the model's system modes carry the damping identified on the rig. It comes from
:func:`calibrate_model` against a target (:func:`ema_target`: the EMA of the white-noise
recording, frequencies, damping and shapes at the sensors, paired by MAC and frequency; thesis
Table 1 by frequency alone when no recording is at hand) or from a calibration file
(:func:`damping_from_calibration`). Every model gets one variable per body mode below 500 Hz
(Model 3: the modes of each of its bodies). One ratio per body, the thesis's Table 6 layout,
cannot give two system modes that one body dominates different damping: the fit then drives
whole bodies to a bound, and the pseudo damage at that body's sensors goes orders of magnitude
off; ``design='per-body'`` keeps that layout. ``diagnosed`` is the model a rig diagnosis
fitted (its findings applied, :func:`exudyn_study.diagnose.fitted.apply_diagnosis`) with its body
damping calibrated the same way: it shows what modelling the missing physics adds to what
calibration alone can do.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from exudyn_study.errors import InputError

log = logging.getLogger(__name__)



#: damping names accepted by :func:`resolve_damping`
DAMPING_NAMES = ("adams-default", "step", "constant-1", "constant-2", "table6", "suggested", "diagnosed")
#: damping names whose ratios come from a calibration of the model against identified modes
CALIBRATED = ("suggested", "diagnosed")


_CALIBRATION_FORMAT = "exudyn_study.calibration"


_CAL_FREQ_RTOL = 0.01  # a calibration belongs to the same mesh: mode frequencies agree to 1 %


#: bounds of a calibrated body-mode damping ratio: what a body mode of a bolted steel structure
#: carries (thesis Table 6: 1.5-8 %; the thesis EMA: 0.6-5.4 %). Where the model's modes are not the
#: rig's (missing physics), an unbounded fit drives body modes to 0 % or 100 % to move the wrong
#: system modes, and a body mode at 0 % turns that into pseudo damage orders of magnitude off
CALIBRATION_BOUNDS = (0.005, 0.20)
#: largest relative frequency difference of a calibrated pair (MAC >= 0.5 too). The nominal models'
#: modes sit up to ~20 % off the rig's where they lack physics; a tighter limit leaves those modes
#: unpaired at the prior damping, which on the thesis scenario predicts the damage worse
CALIBRATION_MAX_FREQUENCY_ERROR = 0.30
#: calibrate_cli's default cut-off: lower ones leave a damping floor that no variable removes
_SUGGESTED_CUTOFF_HZ = 500.0


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


def table1_target():
    """Return thesis Table 1 as a target without shapes (pairing by frequency alone)."""
    from exudyn_study.identify.model import ModalModel, Mode
    from exudyn_study.identify.synthetic import TABLE1_DAMPING, TABLE1_FREQUENCY_HZ

    return ModalModel(tuple(
        Mode(f, z, description=f"thesis Table 1 mode {k + 1}")
        for k, (f, z) in enumerate(zip(TABLE1_FREQUENCY_HZ, TABLE1_DAMPING, strict=True))),
        {"source": "thesis Table 1"})


def ema_target(recording, references=None, *, band_hz=(3.0, 50.0), resolution_hz: float = 0.2,
               estimator: str = "Hv", rtol: float = 0.01):
    """Identify the target modes of a calibration from a white-noise recording (thesis Section 5.1).

    As the thesis did, the modes are identified once per reference (``ARFVZ`` and ``ARFHZ``,
    the frame at the drive linkage) and a mode is kept when every identification has it
    within ``rtol`` in frequency; its frequency and damping ratio are the means over the
    identifications, its shape (at every response sensor) that of the first reference.

    Parameters
    ----------
    recording : Recording
        The white-noise recording (response accelerations; a drive channel is not needed).
    references : sequence of str, optional
        Reference channels (default :data:`exudyn_study.model.sensors.REFERENCES`).
    band_hz : (float, float)
        Identification band in Hz (default 3-50 Hz, thesis Section 5.1).
    resolution_hz : float
        FRF resolution in Hz.
    estimator : str
        FRF estimator (``'H1'``, ``'H2'``, ``'Hv'``).
    rtol : float
        Largest relative frequency difference of one mode between the identifications.

    Returns
    -------
    ModalModel
        Modes with ``shape`` at the response sensors; metadata ``source`` 'EMA',
        ``references``, ``band_hz``.

    Raises
    ------
    InputError
        A reference missing from the recording, no mode found by every identification.
    """
    from exudyn_study.identify.model import ModalModel, Mode
    from exudyn_study.identify.pipeline import identify_recording
    from exudyn_study.model.sensors import REFERENCES

    refs = tuple(REFERENCES if references is None else references)
    missing = [r for r in refs if r not in recording.names]
    if not refs or missing:
        raise InputError(f"EMA references {missing or list(refs)}: not channels of the white-noise recording")
    runs = [identify_recording(recording, [r], band_hz=tuple(band_hz), resolution_hz=resolution_hz,
                               estimator=estimator).model for r in refs]
    kept = []
    used = [set() for _ in runs]
    for mode in runs[0].modes:
        group = [mode]
        for k, run in enumerate(runs[1:], start=1):
            near = [(abs(m.frequency_hz / mode.frequency_hz - 1.0), i) for i, m in enumerate(run.modes)
                    if i not in used[k]]
            near = [d for d in near if d[0] <= rtol]
            if not near:
                break
            used[k].add(min(near)[1])
            group.append(run.modes[min(near)[1]])
        else:
            kept.append(Mode(float(np.mean([m.frequency_hz for m in group])),
                             float(np.mean([m.damping_ratio for m in group])),
                             mpc=mode.mpc, shape=dict(mode.shape),
                             description=f"EMA, references {' and '.join(refs)}"))
    if not kept:
        raise InputError(f"EMA of the white-noise recording: no mode found with every reference "
                         f"({', '.join(refs)}) "
                         f"in {band_hz[0]:g}-{band_hz[1]:g} Hz")
    return ModalModel(tuple(kept), {"source": "EMA", "references": list(refs), "band_hz": list(band_hz),
                                    "estimator": estimator})


def calibrate_model(model, target, cutoff_hz: float = _SUGGESTED_CUTOFF_HZ, hold=None,
                    bounds=CALIBRATION_BOUNDS, max_frequency_error: float = CALIBRATION_MAX_FREQUENCY_ERROR,
                    design: str = "per-mode"):
    """Calibrate a rig model's flexible-body damping so that its system modes carry the target's.

    Parameters
    ----------
    model : exudyn_study.model.Model
        Built with the whole Exudyn mesh (the sensor shapes are read at the sensors' mesh
        nodes); assembled here if not yet. The rear foundation keeps its damping.
    target : ModalModel
        Target modes; with shapes, pairs need MAC >= 0.5 at the common sensors
        (:func:`exudyn_study.linear.pairing.pair_modes`).
    cutoff_hz : float
        With ``design='per-mode'``: one variable per body mode below it, 100 % above.
    hold : sequence of str, optional
        Sensors held in the model's modes. Default: the target's first EMA reference
        (``metadata['references']``, else ``ARFVZ``): an EMA on transmissibilities sees the
        chassis with its reference held (:func:`exudyn_study.virtual_rig.thesis.references_held`;
        the two references move together, so holding one is what the identification sees).
    bounds : (float, float)
        Bounds of every calibrated ratio (default :data:`CALIBRATION_BOUNDS`).
    max_frequency_error : float
        Largest relative frequency difference of a pair (default
        :data:`CALIBRATION_MAX_FREQUENCY_ERROR`); pairs also need MAC >= 0.5.
    design : {'per-mode', 'per-body'}
        One variable per body mode below ``cutoff_hz`` (default, every model), or one per body
        for all of its modes (thesis Table 6 layout).

    Returns
    -------
    exudyn_study.calibrate.CalibrationResult
        The chosen ratios and the pairing (Tables 5/7 analogue with MAC; unpaired targets).

    Raises
    ------
    InputError
        No target mode pairs with a model mode; an unknown ``design``.
    """
    from exudyn_study.calibrate.design import CALIBRATION_DESIGNS, DampingDesign
    from exudyn_study.calibrate.optimise import calibrate
    from exudyn_study.calibrate.system import system_from_model

    if not model.assembled:
        model.assemble()
    bodies = {n: h for n, h in model.bodies.items() if n != "rear_foundation"}
    if design not in CALIBRATION_DESIGNS:
        raise InputError(f"design={design!r}: expected one of {list(CALIBRATION_DESIGNS)}")
    design = (DampingDesign.per_body(bodies) if design == "per-body"
              else DampingDesign.per_mode(bodies, cutoff_hz))
    design = dataclasses.replace(design, lower=float(bounds[0]), upper=float(bounds[1]))
    if hold is None:
        from exudyn_study.model.sensors import REFERENCES

        hold = tuple(target.metadata.get("references") or REFERENCES)[:1]
    system = system_from_model(model)
    hold = tuple(h for h in hold if h in system.sensors)
    result = calibrate(system, design, target, hold=hold, freq_tol=max_frequency_error)
    log.info("damping of model %s calibrated on %s: %d of %d target modes paired, max |error| %.3f pp",
             model.variant, target.metadata.get("source", "the target"), len(result.paired), len(target),
             100 * result.max_abs_error)
    return result


def calibration_dict(result, model, target) -> dict:
    """Return the calibration's JSON content for :func:`damping_from_calibration`.

    The metadata name the model, the target's source and the rear foundation's damping
    (``other_damping``: the model's damping name when it is a named function, else Adams default).

    Parameters
    ----------
    result : CalibrationResult
        The calibration of the model's flexible-body damping.
    model : exudyn_study.model.Model
        The model calibrated (its metadata name the variant and the damping it was built with).
    target : ModalModel
        The identified modes the calibration matched (their metadata name the source).

    Returns
    -------
    dict
        The ``exudyn_study.calibration`` JSON content.
    """
    other = str(model.metadata.get("damping", ""))
    if other not in ("adams-default", "step", "constant-1", "constant-2"):
        other = "adams-default"
    return result.to_dict({"model": int(model.variant), "target": target.metadata.get("source", "target"),
                           "other_damping": other})


def resolve_damping(variant: int, name: str, calibration=None, probe: Callable | None = None, target=None):
    """Return the damping argument of ``build_model`` for a damping name of the grid.

    Parameters
    ----------
    variant : {1, 2, 3}
    name : str
        One of :data:`DAMPING_NAMES`.
    calibration : path or mapping, optional
        A calibration for ``'suggested'``/``'diagnosed'`` (see :func:`damping_from_calibration`).
    probe : callable, optional
        ``probe() -> Model`` (built with any damping, with the whole Exudyn mesh; for
        ``'diagnosed'`` with the diagnosis applied): without a calibration the model is
        calibrated on it (:func:`calibrate_model`) against ``target``.
    target : ModalModel, optional
        Target of that calibration (default thesis Table 1, :func:`table1_target`).

    Returns
    -------
    str, PerBody or dict
        A damping name, thesis Table 6, or a mapping body -> damping function.

    Raises
    ------
    InputError
        Unknown name; a calibrated name with neither a calibration nor a probe.
    """
    from exudyn_study.bodies.damping import THESIS_TABLE6

    if name not in DAMPING_NAMES:
        raise InputError(f"damping {name!r} is unknown; expected one of {list(DAMPING_NAMES)}")
    if name == "table6":
        return THESIS_TABLE6
    if name not in CALIBRATED:
        return name
    if calibration is not None:
        return damping_from_calibration(calibration)
    if probe is None:
        raise InputError(
            f"damping {name!r} for model {variant} needs a calibration "
            "(exudyn-study calibrate --json FILE) or a model to calibrate")
    model = probe()
    target = table1_target() if target is None else target
    return damping_from_calibration(calibration_dict(calibrate_model(model, target), model, target))
