"""``exudyn-study reduce``: mesh, assemble and reduce a flexible body (cached)."""

from __future__ import annotations

import argparse
import json

from exudyn_study.cli.options import Bounded, add_cache_dir, add_mesh
from exudyn_study.errors import InputError

__all__ = ["configure", "run"]

COMPONENTS = ("frame", "tank_left", "tank_right", "bracket_left", "bracket_right")
MAX_FREQUENCY = Bounded(float, 0.0, 2000.0, "Hz", "fixed-interface modes above 2000 Hz add DOF and "
                        "eigen-solve time but nothing to a rig band below a few 100 Hz", low_open=True)


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``reduce``."""
    parser.add_argument("--body", choices=("chassis", "rear_foundation"), default="chassis",
                        help="which body: the truck chassis or the rig's rear foundation")
    parser.add_argument("--joints", choices=("simple", "detailed"), default="simple",
                        help="bolted-joint representation of the chassis: simple (Model 1) or "
                             "detailed (Model 2)")
    parser.add_argument("--component", choices=COMPONENTS, default=None,
                        help="a Model-3 component of the chassis (default: the whole chassis)")
    add_mesh(parser)
    parser.add_argument("--max-frequency", type=MAX_FREQUENCY, default=300.0, metavar="HZ",
                        help="fixed-interface modes kept up to this frequency in Hz")
    parser.add_argument("--no-cache", action="store_true", help="rebuild and do not touch the cache")
    add_cache_dir(parser)
    parser.add_argument("--json", default=None, metavar="OUT",
                        help="write frequencies and timings to this JSON file (default: not written)")


def run(args: argparse.Namespace) -> int:
    """Build the body and print its frequencies."""
    from exudyn_study.bodies.reduction import ReductionSettings
    from exudyn_study.bodies.spec import BodySpec, flexible_body
    from exudyn_study.infra.cache import cache_dir
    from exudyn_study.infra.files import OutputSet

    if args.body == "rear_foundation" and args.component is not None:
        raise InputError(f"--component {args.component}: components belong to the chassis; "
                         "drop --component or use --body chassis")
    spec = BodySpec(kind=args.body, joint_model=args.joints, component=args.component, mesh_size=args.mesh,
                    reduction=ReductionSettings(max_frequency_hz=args.max_frequency))
    with OutputSet() as outputs:
        out = outputs.file(args.json, "--json")
        if not args.no_cache:
            cache_dir(args.cache_dir)
        data = flexible_body(spec, cache_dir=args.cache_dir, use_cache=not args.no_cache)
        body = data.body
        if out is not None:
            payload = {
                "body": spec.name,
                "dof": 3 * body.n_nodes,
                "mass_kg": body.total_mass_kg,
                "free_free_frequencies_hz": body.frequencies_hz.tolist(),
                "mounted_frequencies_hz": body.fixed_interface_frequencies_hz.tolist(),
                "interfaces": list(body.interface_names),
                "timings_s": data.timings_s,
                "from_cache": data.from_cache,
            }
            out.write_text(json.dumps(payload, indent=1), encoding="utf-8")
    print(f"{spec.name}: {body.n_nodes} nodes ({3 * body.n_nodes} DOF), {body.total_mass_kg:.1f} kg, "
          f"{body.n_static_modes} static + {body.fixed_interface_frequencies_hz.size} fixed-interface "
          f"modes -> {body.n_modes} flexible modes ({'cache hit' if data.from_cache else 'built'})")
    print("interfaces:", ", ".join(body.interface_names))
    print("first ten flexible-body (free-free) frequencies [Hz]:",
          " ".join(f"{f:.2f}" for f in body.frequencies_hz[:10]))
    print("first ten mounted (interfaces clamped) frequencies [Hz]:",
          " ".join(f"{f:.2f}" for f in body.fixed_interface_frequencies_hz[:10]))
    print("timings [s]:", ", ".join(f"{k} {v:.1f}" for k, v in data.timings_s.items()))
    return 0
