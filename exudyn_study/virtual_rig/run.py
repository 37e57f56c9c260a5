"""Play a scenario on the virtual rig: truth model, servo drive, simulation, acquisition, files.

:func:`virtual_recording` does, for one signal at one excitation level:

1. the commanded drive (:mod:`exudyn_study.signals`, the scenario's seed and rms times ``level``);
2. the achieved piston displacement: the command through the servo drive
   (:func:`~exudyn_study.virtual_rig.measurement.servo_response`, drop-offs near 12 and 26 Hz,
   tracking error);
3. the truth model: the scenario's nominal variant with its augmentations applied
   (:func:`build_truth`), simulated with the achieved drive (linear model + local
   nonlinearities, exact between sub-steps);
4. the acquisition chain (:func:`~exudyn_study.virtual_rig.measurement.measure`: noise, sensitivity,
   anti-alias filter at 4x oversampling, quantisation) and the drive channel as the
   controller records it (204.8 Hz).

The recording's metadata names the scenario, signal, level and seed, never the physics.
:func:`run_virtual_test` writes the recording ``<scenario>_<signal>[_L<level>].h5`` and the
truth ``<scenario>_truth.json`` (a separate file the rest of the tool never reads), both
atomically.
"""

from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path

from exudyn_study.errors import InputError
from exudyn_study.infra.progress import StageProgress
from exudyn_study.virtual_rig.scenario import Scenario
from exudyn_study.virtual_rig.scenarios import scenario

__all__ = [
    "build_truth",
    "virtual_recording",
    "run_virtual_test",
    "DEFAULT_DURATION_S",
    "recording_name",
    "truth_name",
]

log = logging.getLogger(__name__)

#: default duration per signal (s): 120 s of white noise gives Hv FRFs at 0.2 Hz with 23 averages
DEFAULT_DURATION_S = {"white-noise": 120.0, "test": 60.0, "test-50": 60.0}


def build_truth(sc: Scenario, bodies=None, sensors=None, cache_dir=None):
    """Build the truth model of ``sc`` (not assembled) and the :class:`~exudyn_study.physics.Applied` records.

    Parameters
    ----------
    sc : Scenario
    bodies : mapping, optional
        Reduced bodies for :func:`~exudyn_study.model.build_model_from_bodies` (tests use
        small ones); default: the variant's chassis bodies from the cache.
    sensors : sequence of str, optional
        Sensors to attach (default all 42).
    cache_dir : path, optional
        Flexible-body cache when ``bodies`` is None (default ``$EXUDYN_STUDY_CACHE`` or
        ``~/.cache/exudyn_study``).

    Returns
    -------
    model : exudyn_study.model.Model
        The nominal variant with the scenario's augmentations applied.
    applied : list of Applied
        One record per augmentation, in the scenario's order.
    """
    from exudyn_study.bodies.damping import parse_damping
    from exudyn_study.model import BushingParameters, build_model, build_model_from_bodies
    from exudyn_study.physics.catalogue import entry

    sc.validate()
    damping = parse_damping(sc.damping)
    bushing = BushingParameters() if sc.bushing else None
    if bodies is None:
        model = build_model(
            sc.variant,
            damping=damping,
            bushing=bushing,
            sensors=sensors,
            cache_dir=cache_dir,
            exudyn_mesh="used",
        )
    else:
        model = build_model_from_bodies(
            bodies, sc.variant, damping=damping, bushing=bushing, sensors=sensors, exudyn_mesh="used"
        )
    applied = [entry(a.physics).apply(model, a.location, **dict(a.parameters)) for a in sc.augmentations]
    return model, applied


def virtual_recording(
    sc: Scenario | str,
    signal: str = "white-noise",
    duration_s: float | None = None,
    level: float = 1.0,
    bodies=None,
    sensors=None,
    cache_dir=None,
    model=None,
):
    """Simulate and measure one recording of scenario ``sc``.

    Parameters
    ----------
    sc : Scenario or str
    signal : {'white-noise', 'test', 'test-50'}
    duration_s : float, optional
        Default :data:`DEFAULT_DURATION_S`.
    level : float
        Drive amplitude relative to the scenario's (0.01 to 4).
    bodies, sensors, cache_dir
        See :func:`build_truth`.
    model : exudyn_study.model.Model, optional
        A truth model already built by :func:`build_truth` (reused across signals/levels).

    Returns
    -------
    Recording
    """
    from exudyn_study.signals.drives import SIGNALS, drive_signal
    from exudyn_study.simulate.drive import OUTPUT_RATE_HZ
    from exudyn_study.simulate.run import simulate
    from exudyn_study.virtual_rig.measurement import measure, servo_response

    sc = scenario(sc) if isinstance(sc, str) else sc
    if signal not in SIGNALS:
        raise InputError(f"signal {signal!r} is unknown; expected one of {list(SIGNALS)}")
    if not (isinstance(level, (int, float)) and math.isfinite(level) and 0.01 <= level <= 4.0):
        raise InputError(f"level {level!r}; expected a drive amplitude factor in [0.01, 4]")
    duration = DEFAULT_DURATION_S[signal] if duration_s is None else float(duration_s)
    if not (math.isfinite(duration) and 1.0 <= duration <= 3600.0):
        raise InputError(f"duration {duration_s!r} s; expected 1 to 3600 s")
    t0 = time.perf_counter()
    if model is None:
        model, _ = build_truth(sc, bodies=bodies, sensors=sensors, cache_dir=cache_dir)
    command = drive_signal(signal, duration, OUTPUT_RATE_HZ, sc.rms_m * level, sc.seed)
    achieved = servo_response(command, OUTPUT_RATE_HZ, sc.servo)
    ideal = simulate(model, achieved, method="linear", drive_rate_hz=OUTPUT_RATE_HZ, seed=sc.seed)
    measured = measure(ideal, sc.acquisition)
    from exudyn_study.recording.types import Recording

    meta = {
        "source": "virtual-rig",
        "scenario": sc.name,
        "signal": signal,
        "level": float(level),
        "seed": int(sc.seed),
        "duration_s": float(ideal.metadata["duration_s"]),
        "measurement_chain": measured.metadata.get("measurement_chain", ""),
        "wall_s": float(time.perf_counter() - t0),
    }
    return Recording(tuple(measured), meta)


def recording_name(sc_name: str, signal: str, level: float = 1.0) -> str:
    """File name of a virtual recording: ``<scenario>_<signal>.h5`` (``_L<level>`` if level != 1).

    Parameters
    ----------
    sc_name : str
        Scenario name.
    signal : str
        Drive signal name (e.g. 'white-noise').
    level : float
        Drive amplitude relative to the scenario's.

    Returns
    -------
    str
    """
    tag = "" if level == 1.0 else f"_L{level:g}"
    return f"{sc_name}_{signal}{tag}.h5"


def truth_name(sc_name: str) -> str:
    """File name of a scenario's truth: ``<scenario>_truth.json``.

    Parameters
    ----------
    sc_name : str
        Scenario name.

    Returns
    -------
    str
    """
    return f"{sc_name}_truth.json"


def _write_json_atomic(data: dict, path: Path) -> None:
    from exudyn_study.infra.atomic import write_text_atomic

    write_text_atomic(path, json.dumps(data, indent=2, sort_keys=True), "truth file")


def run_virtual_test(
    sc: Scenario | str,
    signals=("white-noise",),
    out_dir=".",
    duration_s: float | None = None,
    levels=(1.0,),
    bodies=None,
    sensors=None,
    cache_dir=None,
) -> list[Path]:
    """Write the recordings of ``sc`` for each signal and level, and its truth file, into ``out_dir``.

    Parameters
    ----------
    sc : Scenario or str
        The scenario, or the name of a registered one.
    signals : sequence of {'white-noise', 'test', 'test-50'}
        Drive signals, one recording each (per level).
    out_dir : path
        Existing output directory.
    duration_s : float, optional
        Length of every recording (s); default :data:`DEFAULT_DURATION_S` per signal.
    levels : sequence of float
        Drive amplitudes relative to the scenario's (0.01 to 4), one recording each (per signal).
    bodies, sensors, cache_dir
        See :func:`build_truth`.

    Returns
    -------
    list of Path
        The recordings written (the truth file is ``out_dir / truth_name(sc.name)``).

    Raises
    ------
    InputError
        Unknown scenario or signal, a missing output directory, bad parameters.
    """
    from exudyn_study.recording.io import write_recording

    sc = scenario(sc) if isinstance(sc, str) else sc
    out = Path(out_dir)
    if not out.is_dir():
        raise InputError(f"--out {str(out_dir)!r}: directory does not exist; create it first")
    sc.validate()
    runs = [(signal, level) for signal in signals for level in levels]
    stages = ["truth model"] + [recording_name(sc.name, signal, level) for signal, level in runs]
    written = []
    with StageProgress(f"virtual test {sc.name}", stages) as progress:
        progress.stage("truth model")
        model, applied = build_truth(sc, bodies=bodies, sensors=sensors, cache_dir=cache_dir)
        for signal, level in runs:
            progress.stage(recording_name(sc.name, signal, level))
            rec = virtual_recording(sc, signal, duration_s, level, model=model)
            path = out / recording_name(sc.name, signal, level)
            write_recording(rec, path)
            written.append(path)
            log.info("wrote %s (%.1f s wall)", path, rec.metadata["wall_s"])
    truth = sc.truth()
    truth["applied"] = [a.describe() for a in applied]
    truth["recordings"] = [p.name for p in written]
    _write_json_atomic(truth, out / truth_name(sc.name))
    return written
