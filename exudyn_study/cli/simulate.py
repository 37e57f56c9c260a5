"""``exudyn-study simulate``: run a model variant on the rig into a recording file.

Every option is checked before the model is built, the output is declared first (it may not
be the ``--signal`` recording it replays, its directory must be writable) and written to a
staged file that is moved into place only when the simulation has finished.
"""

from __future__ import annotations

import argparse

from exudyn_study.cli.options import (
    DURATION_MAX_S,
    Bounded,
    add_cache_dir,
    add_damping,
    add_mesh,
    add_seed,
)

__all__ = ["configure", "run"]

DAMPINGS = ("adams-default", "step", "constant-1", "constant-2", "table6")
DURATION = Bounded(float, 0.0, DURATION_MAX_S, "s", "43 channels at 1000 Hz hold 1.2 GB per hour in memory; "
                   "a rig test record is 60-120 s", low_open=True)
RMS = Bounded(float, 0.0, 0.05, "m", "the models are linearised for the rig's small motion; a drive rms of "
              "50 mm is beyond any servo-hydraulic rig stroke", low_open=True)
STEP = Bounded(float, 1e-6, 1e-2, "s", "below 1 us one second of simulation takes hours; above 10 ms the "
               "modes below 60 Hz are not resolved")


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``simulate`` arguments."""
    parser.add_argument("--model", type=int, choices=(1, 2, 3), required=True, help="rig model variant")
    add_damping(parser, DAMPINGS, help_text="damping function of the flexible bodies (table6: model 3)")
    parser.add_argument("--signal", default="white-noise", metavar="{white-noise,test,test-50,FILE}",
                        help="white-noise, test, test-50, or a recording file whose drive channel is "
                             "replayed")
    parser.add_argument("--duration", type=DURATION, default=80.0, metavar="S",
                        help="duration in s (named signals)")
    parser.add_argument("--rms", type=RMS, default=None, metavar="M",
                        help="drive rms in m (named signals; default: the signal's own)")
    add_seed(parser, 0, "random seed of the drive signal")
    parser.add_argument("--method", default="exudyn", choices=("exudyn", "exudyn-reduced", "linear"),
                        help="exudyn: time integration of the full model (slowest); exudyn-reduced: "
                             "Exudyn time integration of the constraint-projected linearisation; "
                             "linear: exact discretisation of the linearised model (fastest)")
    parser.add_argument("--step", type=STEP, default=None, metavar="S",
                        help="Exudyn time step in s (default 1/10 ms; exudyn-reduced 1/16 ms)")
    add_mesh(parser)
    parser.add_argument("--bushing", action="store_true", help="model 3: bushings instead of fixed joints")
    parser.add_argument("--element", default="matrix", choices=("matrix", "superelement"),
                        help="Exudyn element of the flexible bodies: matrix (constant matrices, ~8x faster "
                             "integration) or superelement (ObjectFFRFreducedOrder); same linearised system")
    add_cache_dir(parser)
    parser.add_argument("--out", required=True, metavar="REC_OUT",
                        help="output recording (.h5 native, .uff UFF58)")


def run(args: argparse.Namespace) -> int:
    """Build the model, simulate, write the recording (nothing is written on failure)."""
    from pathlib import Path

    from exudyn_study.bodies.damping import parse_damping
    from exudyn_study.errors import InputError
    from exudyn_study.infra.cache import cache_dir
    from exudyn_study.infra.files import OutputSet
    from exudyn_study.model import BushingParameters, build_model
    from exudyn_study.recording.io import read_recording, write_recording
    from exudyn_study.simulate.exudyn_path import IntegratorSettings
    from exudyn_study.simulate.reduced import REDUCED_STEP_S
    from exudyn_study.simulate.run import simulate

    if Path(args.out).suffix.lower() not in (".h5", ".hdf5", ".uff", ".unv"):
        raise InputError(f"--out {args.out!r}: suffix {Path(args.out).suffix!r}; expected .h5/.hdf5 or "
                         ".uff/.unv")
    signal, rate = args.signal, None
    is_file = Path(args.signal).suffix.lower() in (".h5", ".hdf5", ".uff", ".unv")
    if not is_file and signal not in ("white-noise", "test", "test-50"):
        raise InputError(f"--signal {signal!r}: expected white-noise, test, test-50 or a recording file "
                         "(.h5/.hdf5/.uff/.unv)")
    with OutputSet(inputs={"--signal": args.signal if is_file else None}) as outputs:
        out = outputs.file(args.out, "--out")
        cache_dir(args.cache_dir)
        if is_file:
            drive = read_recording(args.signal).drive
            signal, rate = drive.data, drive.sample_rate_hz
        default_step = REDUCED_STEP_S if args.method == "exudyn-reduced" else IntegratorSettings().step_s
        settings = IntegratorSettings(step_s=default_step if args.step is None else args.step)
        model = build_model(args.model, damping=parse_damping(args.damping), mesh_size=args.mesh,
                            bushing=BushingParameters() if args.bushing else None, cache_dir=args.cache_dir,
                            exudyn_mesh="used", element=args.element)
        rec = simulate(model, signal, args.duration, method=args.method, seed=args.seed, rms_m=args.rms,
                       drive_rate_hz=rate, settings=settings, progress=not getattr(args, "quiet", False))
        write_recording(rec, out)
    print(f"wrote {args.out} ({len(rec)} channels, {rec.metadata['duration_s']:.1f} s, "
          f"{rec.metadata['wall_s']:.1f} s wall)")
    return 0
