r"""``exudyn-study diagnose``: locate the mismatch between a model and recordings, name and model the physics.

Usage::

    exudyn-study diagnose --model modal:low.h5 --train low.h5 mid.h5 --holdout high.h5 \\
        --json diagnosis.json [--report report/] [--interface A2:B1 ...]
    exudyn-study diagnose --model 2 --train run1.h5 --holdout run2.h5 --json diagnosis.json
    exudyn-study diagnose --model levels --train l1.h5 l3.h5 l5.h5 l7.h5 --holdout l2.h5 l4.h5 l6.h5 \
        --json diagnosis.json [--report report/] [--band 5 160] [--period 20]

``--model levels`` is the level-trend path (:func:`~exudyn_study.diagnose.levels.diagnose_levels`)
for a shaker or base test at several drive levels: FRFs fitted to the excitation (whole periods
of a multisine, or LRM/H1 for random), the reference model from the lowest level checked against
its own recording, modal parameters per level, the level trend, the joint located among the
sensor pairs, a joint law fitted on the training levels and proven on the held-out ones.
``--model modal:REFERENCE`` is the local-element path
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
from pathlib import Path

from exudyn_study.cli.options import Bounded, add_cache_dir, add_hidden_alias
from exudyn_study.errors import InputError

__all__ = ["configure", "run"]

WORKERS = Bounded(int, 1, 1024, "", "a count of local worker processes")
RESOLUTION = Bounded(float, 0.005, 10.0, "Hz", "finer than 0.005 Hz needs records of hours per average; "
                     "coarser than 10 Hz resolves no structural mode")


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``diagnose`` arguments to ``parser``."""
    parser.add_argument(
        "--model",
        required=True,
        metavar="{1,2,3|modal:REFERENCE|levels}",
        help="nominal model: rig variant 1, 2 or 3; modal:REC for a linear modal model identified from the "
        "lowest-level recording REC (local-element fit); levels for the level-trend diagnosis (the lowest "
        "level among --train/--holdout is the reference)",
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
        help="held-out recordings (other level or signal), never used for fitting (default: none)",
    )
    parser.add_argument("--json", required=True, metavar="OUT", help="diagnosis JSON to write")
    parser.add_argument("--report", metavar="DIR",
                        help="also write an HTML report with figures into DIR (created when missing; "
                             "default: no report)")
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
        help="FRF resolution in Hz (modal: default 0.25; levels, random drive: default one LRM estimate "
        "over the record, periodic drive: 1 / period)",
    )
    add_cache_dir(parser)
    parser.add_argument("--band", nargs=2, type=float, default=None, metavar=("FMIN", "FMAX"),
                        help="analysis band in Hz (default: the contiguous excited band of the reference)")
    parser.add_argument("--period", type=float, default=None, metavar="S",
                        help="levels: period of a periodic drive in s (default: detected from the drive)")
    parser.add_argument("--realisations", type=int, default=1, metavar="N",
                        help="levels: the record holds N multisine realisations one after the other, each of "
                        "whole periods")
    parser.add_argument("--excitation", choices=("auto", "periodic", "random"), default="auto",
                        help="levels: FRF estimate for a periodic (multisine) or random drive")
    parser.add_argument("--workers", type=WORKERS, default=None, metavar="N",
                        help="rig path (--model 1|2|3): local worker processes for the fits' residual "
                        "evaluations (default 1: none; the result does not depend on it)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="rig path: run those evaluations on the Dask scheduler at ADDRESS "
                        "(tcp://host:port) instead of local processes (default: local)")
    add_hidden_alias(parser, "--no-progress", "quiet", action="store_true")  # the one name is --quiet


def _parse_model(text: str):
    text = str(text).strip()
    if text in ("1", "2", "3"):
        return int(text), None
    if text == "levels":
        return "levels", None
    if text.startswith("modal:") and len(text) > len("modal:"):
        return None, Path(text[len("modal:") :])
    raise InputError(
        f"--model {text!r}: expected 1, 2 or 3 (rig variant), modal:REFERENCE_RECORDING "
        "(e.g. modal:low_level.h5) or levels"
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
    _check_pool_options(args, variant)
    inputs = {"--train": args.train, "--holdout": args.holdout, "--model modal:": ref_path}
    with OutputSet(inputs=inputs) as outputs:
        json_path = outputs.file(args.json, "--json")
        report = outputs.directory(args.report, "--report")
        if variant == "levels":
            return _run_levels(args, interfaces, json_path, report)
        diagnosis, figures = _diagnose(args, variant, ref_path, interfaces)
        if report is not None:
            from exudyn_study.diagnose.report import write_report

            write_report(diagnosis, report, figures)
        diagnosis.write_json(json_path)
    print(f"diagnosis: {diagnosis.summary} -> {args.json}")
    for f in diagnosis.findings:
        print(
            f"  {f.physics} at {f.place}{'' if f.identifiable else ' (not identifiable, not a finding)'}: "
            f"held-out error {f.fit['holdout_before']:.3g} -> {f.fit['holdout_after']:.3g}"
        )
    return 0


def _diagnose(args: argparse.Namespace, variant, ref_path, interfaces):
    from exudyn_study.infra.progress import write_line

    quiet = _quiet(args)
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
        kwargs = {"progress": None if quiet else write_line,
                  "cache_dir": args.cache_dir}
        if args.workers is not None or args.scheduler is not None:
            from exudyn_study.diagnose.rig_settings import RigDiagnosisSettings

            kwargs["settings"] = RigDiagnosisSettings(workers=args.workers or 1, scheduler=args.scheduler)
        if "figures" in inspect.signature(rig.diagnose_rig).parameters:
            kwargs["figures"] = figures
        return rig.diagnose_rig(variant, train, holdout, **kwargs), figures
    from exudyn_study.diagnose.generic import GenericSettings, diagnose_generic

    (reference,) = _read([ref_path], "--model modal:")
    kw = {} if args.resolution is None else {"resolution_hz": args.resolution}
    if args.band is not None:
        kw["band_hz"] = tuple(args.band)
    settings = GenericSettings(**kw)
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
        progress=None if _quiet(args) else write_line,
        figures=figures,
        drive_point=args.drive_point,
    )
    return diagnosis, figures


def _check_pool_options(args: argparse.Namespace, variant) -> None:
    """Refuse ``--workers``/``--scheduler`` outside the rig path; check the scheduler before any work."""
    if args.workers is None and args.scheduler is None:
        return
    option = "--workers" if args.workers is not None else "--scheduler"
    if not isinstance(variant, int):
        raise InputError(
            f"{option}: only the rig path (--model 1, 2 or 3) runs on worker processes; omit {option} "
            f"with --model {args.model}"
        )
    if args.scheduler is not None:
        from exudyn_study.sweep.config import check_scheduler

        args.scheduler = check_scheduler(args.scheduler)


def _quiet(args: argparse.Namespace) -> bool:
    """Return True when progress lines and bars are off (``--quiet``)."""
    return bool(getattr(args, "quiet", False))


def _run_levels(args, interfaces, json_path, report) -> int:
    """Run the level-trend path: every recording is a level; JSON (and report) staged by the caller."""
    from exudyn_study.diagnose.levels import LevelSettings, diagnose_levels, write_level_report

    settings = LevelSettings(
        excitation=args.excitation,
        period_s=args.period,
        realisations=args.realisations,
        band_hz=None if args.band is None else tuple(args.band),
        resolution_hz=args.resolution,
    )
    train = _read(args.train, "--train")
    holdout = _read(args.holdout, "--holdout")
    recs = list(train) + list(holdout)
    labels = [Path(p).name for p in list(args.train) + list(args.holdout)]
    state: dict = {}
    diagnosis = diagnose_levels(
        recs,
        list(range(len(train))),
        list(range(len(train), len(recs))),
        labels=labels,
        interfaces=None if interfaces is None else list(interfaces.values()),
        settings=settings,
        progress=not _quiet(args),
        state=state,
    )
    if report is not None:
        write_level_report(diagnosis, state, report)
    diagnosis.write_json(json_path)
    print(f"diagnosis: {diagnosis.summary} -> {args.json}")
    for f in diagnosis.findings:
        where = f.location.get("interface") or "not located"
        before, after = f.fit["holdout_before"], f.fit["holdout_after"]
        print(f"  {f.physics} at {where}: held-out error {before:.3g} -> {after:.3g}")
    return 0
