r"""``exudyn-study iterate-drive``: iterate a model's drive to reproduce measured control responses.

Example::

    exudyn-study iterate-drive --model 1 --damping step --measured thesis_white-noise.h5 \
        --control ARFVZ ARFHZ --iterations 10 --tolerance 0.05 --out model1_iterated.h5 \
        --json iteration.json

The drive of the model is iterated (thesis Section 7.1, time waveform replication:
``D_0 = H^+ A_m``, ``D_{k+1} = D_k + H^+ (A_m - A_k)``, H updated from the runs) until the
relative rms error at every control channel is below ``--tolerance`` or after
``--iterations`` updates; the model is simulated with the best drive (linearised model,
``method='linear'``) and that recording is written; the recording and the JSON are staged
and moved into place together at the end. H is the model's own FRF
(``--frf model``, exact) or identified by a white-noise run (``--frf identify``).

The JSON holds ``rms_error`` (one entry per run: control channel -> relative rms error),
``converged``, ``iterations``, ``final_rms_error`` (of the written recording) and
``measured_drive_rms_error`` (the error with the recording's own drive channel, when it has
one: how far the model is from the measured response without iteration).

Damping: ``adams-default``, ``step``, ``constant-1``, ``constant-2``, ``table6`` or
``suggested`` (Model 3: Table 6; Models 1/2: ``--calibration FILE`` from
``exudyn-study calibrate``, else a calibration against thesis Table 1 is run first).

Bad input (unknown model or damping, a missing or non-finite recording, a control channel
missing from the recording or the model, a missing output directory) is reported on one
line with exit code 2 and nothing is written. When the iteration does not reach the
tolerance the best drive's recording is still written and the exit code is 1.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from exudyn_study.cli.options import Bounded, add_cache_dir, add_damping, add_hidden_alias, add_mesh
from exudyn_study.errors import InputError

__all__ = ["configure", "run"]


DAMPINGS = ("adams-default", "step", "constant-1", "constant-2", "table6", "suggested")
ITERATIONS = Bounded(int, 0, 100, "", "each update is one simulation; the iteration converges in a few "
                     "updates or not at all")
TOLERANCE = Bounded(float, 0.0, 1.0, "", "a relative rms error (0.05 = 5 %)", low_open=True)
REGULARIZATION = Bounded(float, 0.0, 10.0, "", "a relative regularisation of H^-1 (0.05 = 5 % of its "
                         "largest singular value)", low_open=True)


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``iterate-drive`` arguments to ``parser``."""
    parser.add_argument("--model", type=int, choices=(1, 2, 3), required=True, help="rig model variant")
    add_damping(parser, DAMPINGS, help_text="damping function (suggested: Table 6 for model 3, a "
                "calibration for models 1/2)")
    parser.add_argument("--calibration", metavar="FILE", default=None,
                        help="calibration JSON (exudyn-study calibrate) for --damping suggested "
                             "(default: none)")
    parser.add_argument("--measured", required=True, metavar="REC", help="measured recording (.h5 or .uff)")
    parser.add_argument("--control", nargs="+", default=["ARFVZ", "ARFHZ"], metavar="NAME",
                        help="control channels")
    parser.add_argument("--iterations", type=ITERATIONS, default=10, metavar="N",
                        help="maximum number of updates")
    parser.add_argument("--tolerance", type=TOLERANCE, default=0.05,
                        help="relative rms error to stop at (0.05 = 5 %%)")
    parser.add_argument("--regularization", type=REGULARIZATION, default=0.05, metavar="ALPHA",
                        help="relative regularisation of H^-1")
    add_hidden_alias(parser, "--reg", "regularization", type=REGULARIZATION)
    parser.add_argument("--frf", choices=("model", "identify"), default="model",
                        help="H: the model's exact FRF or a white-noise identification run")
    add_mesh(parser)
    add_cache_dir(parser)
    parser.add_argument("--out", required=True, metavar="REC_OUT",
                        help="simulated recording with the final drive (.h5 or .uff)")
    parser.add_argument("--json", default=None, metavar="OUT",
                        help="iteration report (JSON; default: not written)")


def _check(args) -> int:
    if len(set(args.control)) != len(args.control):
        raise InputError(f"--control {' '.join(args.control)}: a channel is named twice")
    if Path(args.out).suffix.lower() not in (".h5", ".hdf5", ".uff", ".unv"):
        raise InputError(f"--out {args.out!r}: suffix {Path(args.out).suffix!r}; expected .h5/.hdf5 or "
                         ".uff/.unv")
    if args.calibration is not None and args.damping != "suggested":
        raise InputError("--calibration is used with --damping suggested only")
    return args.model


def run(args: argparse.Namespace) -> int:
    """Iterate the drive, write the recording (and JSON); return 0 (1: not converged)."""
    from exudyn_study.infra.blas import single_threaded_blas

    with single_threaded_blas():
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    from exudyn_study.infra.files import OutputSet

    variant = _check(args)
    with OutputSet(inputs={"--measured": args.measured, "--calibration": args.calibration}) as outputs:
        out = outputs.file(args.out, "--out")
        json_path = outputs.file(args.json, "--json")
        from exudyn_study.infra.cache import cache_dir

        cache_dir(args.cache_dir)
        return _iterate(args, variant, out, json_path)


def _iterate(args: argparse.Namespace, variant: int, out: Path, json_path: Path | None) -> int:
    from exudyn_study.recording.io import read_recording

    measured = read_recording(args.measured)  # one-line InputError: missing file, NaN samples, format
    missing = [c for c in args.control if c not in measured.names]
    if missing:
        raise InputError(
            f"--measured {args.measured!r}: control channel(s) {', '.join(missing)} missing from the "
            "recording; "
            f"it has {', '.join(measured.names[:10])}{', ...' if len(measured) > 10 else ''}")

    t0 = time.perf_counter()
    from exudyn_study.model import build_model
    from exudyn_study.signals.drive_iteration import target_from_recording
    from exudyn_study.signals.drives import resample
    from exudyn_study.simulate.drive import OUTPUT_RATE_HZ
    from exudyn_study.sweep.grid_damping import resolve_damping
    from exudyn_study.sweep.plant import ModelPlant, iterate_model_drive, rms_errors

    mesh = args.mesh

    def build(damping, exudyn_mesh="used"):
        return build_model(variant, damping=damping, mesh_size=mesh, cache_dir=args.cache_dir,
                           exudyn_mesh=exudyn_mesh)

    # the Table 1 calibration of 'suggested' reads sensors at every mesh node: the whole mesh
    spec = resolve_damping(variant, args.damping, args.calibration,
                           probe=lambda: build("adams-default", "all"))
    plant = ModelPlant(build(spec), label=args.damping)
    plant.indices(args.control)
    res = iterate_model_drive(plant, measured, args.control, frf=args.frf, max_iter=args.iterations,
                              tol=args.tolerance, reg=args.regularization)
    rec = plant.recording(res.drive, {"drive": "iterated", "measured": Path(args.measured).name,
                                      "iteration_error": float(res.best_error)})
    target, _ = target_from_recording(measured, args.control, rate_hz=OUTPUT_RATE_HZ)
    final = rms_errors(rec.time_data(list(args.control))[0], target)
    baseline = None
    if measured.drive_channels and len(measured.drive_channels) == 1:
        d = measured.drive
        x = d.data if d.sample_rate_hz == OUTPUT_RATE_HZ else resample(
            d.data, d.sample_rate_hz, OUTPUT_RATE_HZ)
        n = min(x.size, target.shape[1])
        baseline = rms_errors(plant.responses(x[:n], args.control), target[:, :n])

    from exudyn_study.recording.io import write_recording

    write_recording(rec, out)
    report = {
        **res.as_dict(),
        "model": variant,
        "damping": args.damping,
        "measured": str(args.measured),
        "out": str(args.out),
        "frf": args.frf,
        "reg": args.regularization,
        "final_rms_error": dict(zip(args.control, map(float, final), strict=True)),
        "measured_drive_rms_error": (None if baseline is None
                                     else dict(zip(args.control, map(float, baseline), strict=True))),
        "wall_time_s": time.perf_counter() - t0,
    }
    if json_path is not None:
        json_path.write_text(json.dumps(report, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    width = max(len(c) for c in args.control)
    print("run  " + "  ".join(f"{c:>{max(width, 8)}}" for c in args.control))
    for k, row in enumerate(res.errors):
        print(f"{k:>3}  " + "  ".join(f"{100 * e:{max(width, 8) - 1}.2f}%" for e in row))
    if baseline is not None:
        print("measured drive: " + ", ".join(f"{c} {100 * e:.1f}%" for c, e in zip(args.control, baseline,
                                                                                    strict=True)))
    state = "converged" if res.converged else "NOT converged"
    print(f"{state} (tolerance {100 * args.tolerance:g} %) after {res.n_iterations} update(s); "
          f"wrote {args.out} in {report['wall_time_s']:.1f} s")
    return 0 if res.converged else 1
