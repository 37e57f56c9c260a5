"""Thesis Section 7 end to end: Models 1-3 x damping x signals -> relative pseudo damage per z sensor.

Usage::

    exudyn-study virtual-test --scenario thesis --signal white-noise test test-50 --out meas/
    python studies/damage_grid.py --measured-dir meas/ --out results/damage_grid

``--measured-dir`` holds one recording per signal named ``<anything>_<signal>.h5``
(``thesis_white-noise.h5``, ``thesis_test.h5``, ``thesis_test-50.h5``). For every cell the
drive is iterated on the control sensors (ARFVZ, ARFHZ), the model simulated and the
relative pseudo damage of every z sensor computed against the measured recording (beta 5,
counted at 204.8 Hz). The ``suggested`` column is each model's flexible-body damping
calibrated against the EMA of the white-noise recording (modes with shapes, paired by MAC
and frequency); with ``--diagnosis FILE`` (``exudyn-study diagnose --json``) a ``diagnosed``
column adds the model the diagnosis fitted, calibrated the same way. Writes
``damage_grid.csv`` (one row per cell and sensor), ``drive_iterations.csv`` (error per
iteration run), ``calibration_model<m>_<damping>.json`` and ``pairing.txt`` (model and
EMA modes paired: MAC, frequency error, unpaired modes), ``reading.txt`` (per sensor group
the damping that predicts best and by how much), bar plots like thesis Figures 22-27 and a
summary figure per model into ``--out``, and prints the summary, the reading and the wall
time. The physics is in :mod:`exudyn_study.sweep.damage_grid`.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path


def _calibration(text: str) -> tuple[int, str]:
    model, sep, path = text.partition("=")
    if not sep or model not in ("1", "2", "3") or not path:
        raise argparse.ArgumentTypeError(f"{text!r}: expected MODEL=FILE, e.g. 1=calibration_model1.json")
    return int(model), path


def parse_args(argv=None) -> argparse.Namespace:
    from exudyn_study.sweep.damage_grid import GRID_DAMPINGS, GRID_SIGNALS
    from exudyn_study.sweep.grid_damping import DAMPING_NAMES

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--measured-dir", required=True, metavar="DIR", help="one <name>_<signal>.h5 per signal")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.add_argument("--models", type=int, nargs="+", default=[1, 2, 3], help="model variants (default 1 2 3)")
    p.add_argument("--dampings", nargs="+", default=None, metavar="NAME",
                   help=f"damping names of {', '.join(DAMPING_NAMES)} (default: {' '.join(GRID_DAMPINGS)}, "
                        "and diagnosed with --diagnosis)")
    p.add_argument("--signals", nargs="+", default=None, metavar="SIGNAL",
                   help=f"signals (default: all found in --measured-dir, of {' '.join(GRID_SIGNALS)})")
    p.add_argument("--calibration", type=_calibration, action="append", default=[], metavar="MODEL=FILE",
                   help="calibration JSON for 'suggested' of a model (default: calibrated here against "
                        "the EMA of the white-noise recording)")
    p.add_argument("--target", default=None, metavar="MODES.json",
                   help="target modes of the calibration (exudyn-study identify --json; default: the EMA "
                        "of the white-noise recording, identified here)")
    p.add_argument("--diagnosis", default=None, metavar="FILE",
                   help="rig diagnosis JSON (exudyn-study diagnose --json): adds the 'diagnosed' column")
    p.add_argument("--no-iterate", action="store_true",
                   help="drive the models with the measured drive channel")
    p.add_argument("--iterations", type=int, default=5, help="maximum drive iteration updates (default 5)")
    p.add_argument("--tolerance", type=float, default=0.05,
                   help="control rms error to stop at (default 0.05)")
    p.add_argument("--beta", type=float, default=5.0, help="Basquin exponent (default 5)")
    p.add_argument("--rate-hz", type=float, default=204.8, help="damage counting rate (default 204.8 Hz)")
    p.add_argument("--mesh-size", default="production",
                   help="'production' (default), 'coarse' or a size in m")
    p.add_argument("--cache-dir", default=None, help="flexible-body cache directory")
    p.add_argument("--no-plots", action="store_true", help="CSV only")
    return p.parse_args(argv)


def main(argv=None) -> int:
    from exudyn_study.bodies.spec import parse_mesh
    from exudyn_study.errors import InputError
    from exudyn_study.infra.progress import write_line
    from exudyn_study.sweep.damage_grid import measured_recordings, run_grid

    args = parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    t0 = time.perf_counter()

    def progress(text: str) -> None:  # a line above the grid's status bar (stderr)
        write_line(f"[{time.perf_counter() - t0:7.1f} s] {text}")

    try:
        measured = measured_recordings(args.measured_dir, args.signals)
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        for signal, path in measured.items():
            print(f"measured {signal:<12} {path}")
        target = None
        if args.target is not None:
            from exudyn_study.identify.model import read_modes_json

            target = read_modes_json(args.target)
        result = run_grid(
            measured, models=args.models, dampings=args.dampings, iterate=not args.no_iterate, out_dir=out,
            target=target, diagnosis=args.diagnosis,
            beta=args.beta, rate_hz=args.rate_hz, max_iter=args.iterations, tol=args.tolerance,
            calibrations=dict(args.calibration), mesh_size=parse_mesh(args.mesh_size),
            cache_dir=args.cache_dir, plots=not args.no_plots, progress=progress)
    except InputError as exc:
        print(f"damage_grid: error: {exc}", file=sys.stderr)
        return 2
    print()
    print(result.summary())
    print()
    if result.calibrations:
        print(result.pairing_report())
        print()
    print(result.reading())
    print()
    for f in result.files:
        print(f"wrote {f}")
    print(f"grid of {len(result.cells)} cells: wall time {result.wall_time_s:.1f} s "
          f"(total {time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
