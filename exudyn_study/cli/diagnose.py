r"""``exudyn-study diagnose``: locate the mismatch between a model and recordings, name and model the physics.

Usage::

    exudyn-study diagnose --model modal:low.h5 --train low.h5 mid.h5 --holdout high.h5 \\
        --json diagnosis.json [--report report/] [--interface A2:B1 ...]
    exudyn-study diagnose --model 2 --train run1.h5 --holdout run2.h5 --json diagnosis.json

``--model modal:REFERENCE`` is the generic path
(:func:`~exudyn_study.diagnose.generic.diagnose_generic`): the nominal model is a linear
modal model identified from the lowest-level recording REFERENCE. ``--model 1|2|3`` is the
chassis on the rig (:func:`exudyn_study.diagnose.rig.diagnose_rig`). The JSON (schema in
:mod:`exudyn_study.diagnose.schema`) and the report are staged and moved into place
together when the diagnosis has finished; on an error neither is written. Heavy imports
happen inside :func:`run`.
"""

from __future__ import annotations

import argparse
import inspect
import sys
from pathlib import Path

from exudyn_study.cli.options import Bounded, add_cache_dir
from exudyn_study.errors import InputError

__all__ = ["configure", "run"]

RESOLUTION = Bounded(float, 0.005, 10.0, "Hz", "finer than 0.005 Hz needs records of hours per average; "
                     "coarser than 10 Hz resolves no structural mode")


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``diagnose`` arguments to ``parser``."""
    parser.add_argument(
        "--model",
        required=True,
        metavar="{1,2,3|modal:REFERENCE}",
        help="nominal model: rig variant 1, 2 or 3, or modal:REC for a linear modal model "
        "identified from the lowest-level recording REC",
    )
    parser.add_argument(
        "--train",
        nargs="+",
        required=True,
        metavar="REC",
        help="training recordings (.h5 or .uff), used for fitting",
    )
    parser.add_argument(
        "--holdout",
        nargs="+",
        default=[],
        metavar="REC",
        help="held-out recordings (other level or signal), never used for fitting",
    )
    parser.add_argument("--json", required=True, metavar="OUT", help="diagnosis JSON to write")
    parser.add_argument("--report", metavar="DIR",
                        help="also write an HTML report with figures into DIR (created when missing)")
    parser.add_argument(
        "--interface",
        action="append",
        default=None,
        metavar="[NAME=]A:B",
        help="generic path: a joint as a sensor pair across it (repeatable; 'drive' is the "
        "table); default: search every sensor pair",
    )
    parser.add_argument(
        "--drive-point",
        default=None,
        metavar="SENSOR",
        help="generic path, force drive: the accelerometer at the force (default: the one at its position)",
    )
    parser.add_argument(
        "--resolution",
        type=RESOLUTION,
        default=None,
        metavar="HZ",
        help="generic path: FRF resolution in Hz (default 0.25)",
    )
    add_cache_dir(parser)


def _parse_model(text: str):
    text = str(text).strip()
    if text in ("1", "2", "3"):
        return int(text), None
    if text.startswith("modal:") and len(text) > len("modal:"):
        return None, Path(text[len("modal:") :])
    raise InputError(
        f"--model {text!r}: expected 1, 2 or 3 (rig variant) or modal:REFERENCE_RECORDING "
        "(e.g. modal:low_level.h5)"
    )


def _parse_interfaces(items):
    if not items:
        return None
    out = {}
    for item in items:
        name, _, pair = item.rpartition("=")
        a, sep, b = pair.partition(":")
        if not sep or not a or not b:
            raise InputError(
                f"--interface {item!r}: expected A:B or NAME=A:B with two sensor names (e.g. A2:B1)"
            )
        out[name or f"{a}-{b}"] = (a, b)
    return out


def _read(paths, option: str):
    from exudyn_study.recording.io import read_recording

    recs = []
    for p in paths:
        try:
            recs.append(read_recording(p))
        except InputError as exc:
            raise InputError(f"{option} {p!r}: {exc}") from None
    return recs


def run(args: argparse.Namespace) -> int:
    """Run the diagnosis and write the JSON (and the report); return the exit code."""
    from exudyn_study.infra.files import OutputSet

    variant, ref_path = _parse_model(args.model)
    if not args.holdout:
        raise InputError(
            "--holdout: no held-out recording given; the improvement must be shown on recordings "
            "not used for fitting (another level or signal): add --holdout REC"
        )
    interfaces = _parse_interfaces(args.interface)
    inputs = {"--train": args.train, "--holdout": args.holdout, "--model modal:": ref_path}
    with OutputSet(inputs=inputs) as outputs:
        json_path = outputs.file(args.json, "--json")
        report = outputs.directory(args.report, "--report")
        diagnosis, figures = _diagnose(args, variant, ref_path, interfaces)
        if report is not None:
            from exudyn_study.diagnose.report import write_report

            write_report(diagnosis, report, figures)
        diagnosis.write_json(json_path)
    print(f"diagnosis: {diagnosis.summary} -> {args.json}")
    for f in diagnosis.findings:
        print(
            f"  {f.physics} at {f.location.get('interface') or ', '.join(f.location['sensors'])}: "
            "held-out error "
            f"{f.fit['holdout_before']:.3g} -> {f.fit['holdout_after']:.3g}"
        )
    return 0


def _diagnose(args: argparse.Namespace, variant, ref_path, interfaces):
    quiet = getattr(args, "quiet", False)
    train = _read(args.train, "--train")
    holdout = _read(args.holdout, "--holdout")
    figures: dict = {}
    if variant is not None:
        try:
            from exudyn_study.diagnose import rig
        except ImportError:
            raise InputError("--model: the chassis path (exudyn_study.diagnose.rig) is not available in "
                             "this version; use --model modal:REFERENCE") from None
        from exudyn_study.infra.cache import cache_dir

        cache_dir(args.cache_dir)
        kwargs = {"progress": None if quiet else (lambda msg: print(msg, file=sys.stderr)),
                  "cache_dir": args.cache_dir}
        if "figures" in inspect.signature(rig.diagnose_rig).parameters:
            kwargs["figures"] = figures
        return rig.diagnose_rig(variant, train, holdout, **kwargs), figures
    from exudyn_study.diagnose.generic import GenericSettings, diagnose_generic

    (reference,) = _read([ref_path], "--model modal:")
    settings = (GenericSettings() if args.resolution is None
                else GenericSettings(resolution_hz=args.resolution))
    labels = {
        "reference": ref_path.name,
        "train": [Path(p).name for p in args.train],
        "holdout": [Path(p).name for p in args.holdout],
    }
    diagnosis = diagnose_generic(
        reference,
        train,
        holdout,
        interfaces,
        settings=settings,
        labels=labels,
        progress=lambda msg: print(msg, file=sys.stderr) if getattr(args, "verbose", False) else None,
        figures=figures,
        drive_point=args.drive_point,
    )
    return diagnosis, figures
