"""``exudyn-study simulate``: run a model variant on the rig into a recording file."""

from __future__ import annotations

import argparse

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``simulate`` arguments."""
    parser.add_argument("--model", type=int, required=True, help="model variant: 1, 2 or 3")
    parser.add_argument("--damping", default="adams-default",
                        help="adams-default, step, constant-1, constant-2 or table6 (model 3)")
    parser.add_argument("--signal", default="white-noise",
                        help="white-noise, test, test-50, or a recording file whose drive channel is replayed")
    parser.add_argument("--duration", type=float, default=80.0, help="duration in s (named signals)")
    parser.add_argument("--rms", type=float, default=None, help="drive rms in m (named signals)")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the drive signal")
    parser.add_argument("--method", default="exudyn", choices=("exudyn", "exudyn-reduced", "linear"),
                        help="exudyn: time integration of the full model; exudyn-reduced: Exudyn time integration "
                             "of the constraint-projected linearisation; linear: exact discretisation of the "
                             "linearised model")
    parser.add_argument("--step", type=float, default=None,
                        help="Exudyn time step in s (default 1/10 ms; exudyn-reduced 1/16 ms)")
    parser.add_argument("--mesh", default="production", help="mesh size: production (default), coarse or a size in m")
    parser.add_argument("--bushing", action="store_true", help="model 3: bushings instead of fixed joints")
    parser.add_argument("--element", default="matrix", choices=("matrix", "superelement"),
                        help="Exudyn element of the flexible bodies: matrix (constant matrices, ~8x faster "
                             "integration) or superelement (ObjectFFRFreducedOrder); same linearised system")
    parser.add_argument("--cache-dir", default=None, help="flexible-body cache directory")
    parser.add_argument("--out", required=True, help="output recording (.h5 native, .uff UFF58)")


def run(args: argparse.Namespace) -> int:
    """Build the model, simulate, write the recording (nothing is written on failure)."""
    from pathlib import Path

    from exudyn_study.bodies.damping import parse_damping
    from exudyn_study.bodies.spec import parse_mesh
    from exudyn_study.errors import InputError
    from exudyn_study.model import BushingParameters, build_model
    from exudyn_study.recording.io import read_recording, write_recording
    from exudyn_study.simulate.exudyn_path import IntegratorSettings
    from exudyn_study.simulate.reduced import REDUCED_STEP_S
    from exudyn_study.simulate.run import simulate

    out = Path(args.out)
    if not out.parent.is_dir():
        raise InputError(f"--out {args.out!r}: directory {str(out.parent)!r} does not exist")
    signal, rate = args.signal, None
    if Path(args.signal).suffix.lower() in (".h5", ".hdf5", ".uff", ".unv"):
        drive = read_recording(args.signal).drive
        signal, rate = drive.data, drive.sample_rate_hz
    default_step = REDUCED_STEP_S if args.method == "exudyn-reduced" else IntegratorSettings().step_s
    settings = IntegratorSettings(step_s=default_step if args.step is None else args.step)
    model = build_model(args.model, damping=parse_damping(args.damping), mesh_size=parse_mesh(args.mesh),
                        bushing=BushingParameters() if args.bushing else None, cache_dir=args.cache_dir,
                        exudyn_mesh="used", element=args.element)
    rec = simulate(model, signal, args.duration, method=args.method, seed=args.seed, rms_m=args.rms,
                   drive_rate_hz=rate, settings=settings, progress=True)
    write_recording(rec, out)
    print(f"wrote {out} ({len(rec)} channels, {rec.metadata['duration_s']:.1f} s, "
          f"{rec.metadata['wall_s']:.1f} s wall)")
    return 0
