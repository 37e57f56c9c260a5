"""``exudyn-study demo``: the main job end to end on shipped settings.

1. The Model-1 chassis flexible body: geometry -> second-order FE -> Craig-Bampton,
   orthogonalised (cached after the first run).
2. A random base-excitation test of a structure with the thesis's Table-1 modes,
   measured at the Appendix-A sensor positions (80 s, 1000 Hz, 2 % noise, seeded),
   written as a native HDF5 recording.
3. Automatic identification (Hv, 0.2 Hz, PolyMAX, LSFD) of that recording: modes JSON,
   stabilisation diagram, FRF fit, AutoMAC and mode-shape figures.
4. With ``--virtual-rig``: the virtual rig's ``thesis`` scenario (Model 3 plus the physics
   it leaves out, through the servo and acquisition chain) for the three signals, EMA of
   its white-noise recording against thesis Table 1 (one identification per reference, the
   modes both found averaged, thesis Section 5.1), and the diagnosis of Model 3 against
   the recordings (JSON and HTML report).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from exudyn_study.cli.options import add_cache_dir, add_mesh, add_seed

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``demo``."""
    parser.add_argument("--out", default="demo_out", metavar="DIR",
                        help="output directory (created when missing)")
    add_mesh(parser, "mesh of the chassis body")
    add_cache_dir(parser)
    parser.add_argument("--skip-fe", action="store_true", help="skip the FE/reduction step")
    add_seed(parser, 1, "seed of the synthetic test")
    parser.add_argument(
        "--virtual-rig",
        action="store_true",
        help="also play the virtual rig's 'thesis' scenario (white noise, test, test at 50 %%; "
        "Model 3 bodies are reduced on the first run), identify its white-noise recording "
        "and diagnose Model 3 against it",
    )


def run(args: argparse.Namespace) -> int:
    """Run the demo; every output is staged and moved into ``--out`` at the end."""
    from exudyn_study.infra.cache import cache_dir
    from exudyn_study.infra.files import OutputSet

    with OutputSet() as outputs:
        out = outputs.directory(args.out, "--out")
        if not args.skip_fe or args.virtual_rig:
            cache_dir(args.cache_dir)
        _demo(args, out, Path(args.out))
    print(f"      outputs in {args.out}")
    return 0


def _demo(args: argparse.Namespace, out: Path, shown: Path) -> None:
    """Run the demo's steps, writing into ``out`` (staging) and naming ``shown`` (the target) in messages."""
    from exudyn_study.identify.model import write_modes_json
    from exudyn_study.identify.pipeline import identify_recording
    from exudyn_study.identify.plots import plot_all
    from exudyn_study.identify.synthetic import simulate, table1_system, to_recording
    from exudyn_study.recording.io import read_recording, write_recording

    summary = {}
    step = _Steps(2 + (not args.skip_fe) + 2 * bool(args.virtual_rig))
    if not args.skip_fe:
        from exudyn_study.bodies.spec import BodySpec, flexible_body

        print(f"{step()} chassis flexible body (Model 1): FE and Craig-Bampton reduction, or the cache")
        data = flexible_body(BodySpec(joint_model="simple", mesh_size=args.mesh), cache_dir=args.cache_dir)
        body = data.body
        print(
            f"      {3 * body.n_nodes} DOF, {body.total_mass_kg:.1f} kg, "
            f"{body.n_modes} flexible modes, {'from cache' if data.from_cache else 'built'} "
            f"in {data.timings_s['total']:.1f} s"
        )
        print(
            "      mounted frequencies [Hz]:",
            " ".join(f"{f:.1f}" for f in body.fixed_interface_frequencies_hz[:10]),
        )
        summary["body"] = {
            "dof": 3 * body.n_nodes,
            "mass_kg": body.total_mass_kg,
            "mounted_frequencies_hz": body.fixed_interface_frequencies_hz[:10].tolist(),
            "free_free_frequencies_hz": body.frequencies_hz[:10].tolist(),
        }
    print(f"{step()} synthetic white-noise test: the thesis's Table-1 modes at the Appendix-A sensors, 80 s")
    system = table1_system(seed=args.seed)
    reference, responses = simulate(system, 80.0, seed=args.seed)
    recording = to_recording(
        system, reference, responses, metadata={"source": "synthetic Table-1 structure", "seed": args.seed}
    )
    rec_path = out / "test_white_noise.h5"
    write_recording(recording, rec_path)
    print(
        f"      written to {shown / rec_path.name} "
        f"({len(recording.channels)} channels, {recording.duration_s:.0f} s)"
    )
    print(f"{step()} identification of that recording (Hv, 0.2 Hz, PolyMAX, LSFD) and its figures")
    result = identify_recording(
        read_recording(rec_path), "ARFVZ", band_hz=(3.0, 50.0), resolution_hz=0.2, estimator="Hv"
    )
    write_modes_json(result.model, out / "modes.json")
    figures = plot_all(result, out / "figures", **_sensor_layout(recording))
    print(f"      identified {len(result.model.modes)} modes -> {shown / 'modes.json'}")
    print("      mode  f [Hz]   zeta [%]   true f [Hz]  true zeta [%]")
    for i, mode in enumerate(result.model.modes):
        j = min(
            range(len(system.frequency_hz)), key=lambda k: abs(system.frequency_hz[k] - mode.frequency_hz)
        )
        print(
            f"      {i + 1:>4}  {mode.frequency_hz:7.3f}  {100 * mode.damping_ratio:8.3f}   "
            f"{system.frequency_hz[j]:10.3f}  {100 * system.damping_ratio[j]:12.3f}"
        )
    print(f"      figures: {', '.join(str(shown / p.relative_to(out)) for p in figures)}")
    summary["identified_modes"] = len(result.model.modes)
    if args.virtual_rig:
        summary["virtual_rig"] = _virtual_rig(
            out / "virtual_rig", shown / "virtual_rig", step, args.cache_dir
        )
    (out / "demo_summary.json").write_text(json.dumps(summary, indent=1), encoding="utf-8")


def _sensor_layout(recording) -> dict:
    """Sensor positions (m) and directions of a recording, for the mode-shape figure."""
    chans = [c for c in recording.channels if c.position_m is not None]
    return {"positions_m": {c.name: c.position_m for c in chans},
            "directions": {c.name: c.direction for c in chans}}


class _Steps:
    """The demo's step counter: each call returns the next ``[k/N]``."""

    def __init__(self, total: int):
        self.total, self.done = total, 0

    def __call__(self) -> str:
        self.done += 1
        return f"[{self.done}/{self.total}]"


def _virtual_rig(out: Path, shown: Path, step: _Steps, cache_dir=None) -> dict:
    """Play the thesis scenario on the virtual rig, identify its white-noise recording, diagnose Model 3."""
    import dataclasses
    import time

    from exudyn_study.diagnose.report import write_report
    from exudyn_study.diagnose.rig import diagnose_rig
    from exudyn_study.identify.model import write_modes_json
    from exudyn_study.identify.pipeline import identify_recording
    from exudyn_study.identify.plots import plot_all
    from exudyn_study.recording.io import read_recording
    from exudyn_study.virtual_rig.run import run_virtual_test
    from exudyn_study.virtual_rig.thesis import EMA_REFERENCES, average_identifications, compare_table1

    out.mkdir(parents=True, exist_ok=True)
    print(f"{step()} virtual rig, scenario 'thesis' (white noise, test, test at 50 %), then EMA of its "
          "white-noise recording")
    t0 = time.perf_counter()
    paths = run_virtual_test("thesis", ["white-noise", "test", "test-50"], out, cache_dir=cache_dir)
    print(
        f"      recordings {', '.join(p.name for p in paths)} in "
        f"{time.perf_counter() - t0:.0f} s (the truth is in thesis_truth.json; nothing else reads it)"
    )
    # the thesis's procedure (Section 5.1): one identification per reference, the modes both found averaged
    # (the two references move together, so one identification with both is ill-conditioned)
    recording = read_recording(paths[0])
    runs = []
    for reference in EMA_REFERENCES:
        res = identify_recording(
            recording, [reference], band_hz=(3.0, 50.0), resolution_hz=0.2, estimator="Hv"
        )
        write_modes_json(res.model, out / f"thesis_modes_{reference}.json")
        if not runs:
            plot_all(res, out / "figures", **_sensor_layout(recording))
        runs.append([m.to_dict() for m in res.model.modes])
    modes = average_identifications(runs)
    rows = compare_table1([m["frequency_hz"] for m in modes], [m["damping_ratio"] for m in modes])
    n_both = sum(r["within_10pct"] for r in rows)
    print(
        f"      EMA of the white-noise recording (references {' and '.join(EMA_REFERENCES)} one at a time, "
        f"the modes both found averaged) vs thesis Table 1 (one-to-one pairing): {n_both}/10 within 10 % "
        "in frequency and damping"
    )
    for r in rows:
        ident = (
            f"{r['frequency_hz']:7.2f} Hz {100 * r['damping_ratio']:5.2f} %"
            if r["index"] is not None
            else "      (no mode)  "
        )
        print(
            f"      Table 1 {r['table_hz']:6.2f} Hz {100 * r['table_zeta']:5.2f} % "
            f"({r['description']}): {ident}"
        )
    extra = rows[-1].get("extra", [])
    if extra:
        print(
            "      identified modes Table 1 lacks: "
            + ", ".join(f"{modes[i]['frequency_hz']:.2f} Hz" for i in extra)
        )
    figures: dict = {}
    print(f"{step()} diagnosis of Model 3 (Table 6 damping) against the recordings")
    # named by where they end up (the files are staged until the demo ends)
    named = [
        dataclasses.replace(r, metadata={**r.metadata, "name": str(shown / p.name)})
        for p, r in ((p, read_recording(p)) for p in paths)
    ]
    diagnosis = diagnose_rig(3, [named[0], named[2]], [named[1]], damping="table6", figures=figures,
                             cache_dir=cache_dir)
    diagnosis.write_json(out / "diagnosis.json")
    write_report(diagnosis, out / "diagnosis_report", figures)
    print(
        f"      {diagnosis.summary} -> "
        f"{shown / 'diagnosis_report' / 'index.html'}"
    )
    return {
        "recordings": [p.name for p in paths],
        "identified_modes": len(modes),
        "table1_within_10pct": n_both,
        "diagnosis": diagnosis.summary,
    }
