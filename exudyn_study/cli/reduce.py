"""``exudyn-study reduce``: mesh, assemble and reduce a flexible body (cached)."""

from __future__ import annotations

import argparse
import json
import os
import tempfile

from exudyn_study.errors import InputError


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the arguments of ``reduce``."""
    parser.add_argument("--body", choices=["chassis", "rear_foundation"], default="chassis")
    parser.add_argument("--joints", choices=["simple", "detailed"], default="simple",
                        help="bolted-joint representation: simple (Model 1) or detailed (Model 2)")
    parser.add_argument("--component", default=None,
                        help="a Model-3 component (frame, tank_left, tank_right, bracket_left, bracket_right)")
    parser.add_argument("--mesh", default="production", help="production (default), coarse or a max element size in m")
    parser.add_argument("--max-frequency", type=float, default=300.0,
                        help="fixed-interface modes kept up to this frequency in Hz (default 300)")
    parser.add_argument("--no-cache", action="store_true", help="rebuild and do not touch the cache")
    parser.add_argument("--json", default=None, help="write frequencies and timings to this JSON file")


def run(args: argparse.Namespace) -> int:
    """Build the body and print its frequencies."""
    from exudyn_study.bodies.reduction import ReductionSettings
    from exudyn_study.bodies.spec import BodySpec, flexible_body

    try:
        mesh = args.mesh if args.mesh in ("coarse", "production") else float(args.mesh)
    except ValueError:
        raise InputError(f"--mesh {args.mesh!r}: expected coarse, production or a size in m") from None
    spec = BodySpec(kind=args.body, joint_model=args.joints, component=args.component, mesh_size=mesh,
                    reduction=ReductionSettings(max_frequency_hz=args.max_frequency))
    data = flexible_body(spec, use_cache=not args.no_cache)
    body = data.body
    print(f"{spec.name}: {body.n_nodes} nodes ({3 * body.n_nodes} DOF), {body.total_mass_kg:.1f} kg, "
          f"{body.n_static_modes} static + {body.fixed_interface_frequencies_hz.size} fixed-interface "
          f"modes -> {body.n_modes} flexible modes ({'cache hit' if data.from_cache else 'built'})")
    print("interfaces:", ", ".join(body.interface_names))
    print("first ten flexible-body (free-free) frequencies [Hz]:",
          " ".join(f"{f:.2f}" for f in body.frequencies_hz[:10]))
    print("first ten mounted (interfaces clamped) frequencies [Hz]:",
          " ".join(f"{f:.2f}" for f in body.fixed_interface_frequencies_hz[:10]))
    print("timings [s]:", ", ".join(f"{k} {v:.1f}" for k, v in data.timings_s.items()))
    if args.json:
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
        directory = os.path.dirname(os.path.abspath(args.json))
        os.makedirs(directory, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=directory, suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            json.dump(payload, fh, indent=1)
        os.replace(tmp, args.json)
    return 0
