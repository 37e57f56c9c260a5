"""``exudyn-study modes``: system modes of a model variant on the rig.

Builds (or loads from cache) the flexible bodies of the variant, assembles the rig,
linearises it with Exudyn and writes the damped modes in the modes-JSON schema of the
identification module (``frequency_hz``, ``damping_ratio``, ``description``, ``shape``
per sensor), so computed and identified modes can be compared directly.
"""

from __future__ import annotations

import argparse
import sys

from exudyn_study.bodies.damping import parse_damping
from exudyn_study.bodies.spec import parse_mesh
from exudyn_study.linear.modes import modes_table

__all__ = ["configure", "run", "modes_table"]


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the ``modes`` arguments."""
    parser.add_argument("--model", type=int, required=True, help="model variant: 1, 2 or 3")
    parser.add_argument("--damping", default="adams-default",
                        help="damping function: adams-default, step, constant-1, constant-2, "
                             "or table6 (thesis Table 6 per body, model 3)")
    parser.add_argument("--mesh", default="production", help="mesh size: production (default), coarse or a size in m")
    parser.add_argument("--bushing", action="store_true",
                        help="model 3: join the components by 6-DOF spring-damper bushings (default: fixed joints)")
    parser.add_argument("--max-frequency", type=float, default=100.0, help="highest mode frequency in Hz")
    parser.add_argument("--n-modes", type=int, default=None, help="at most this many modes")
    parser.add_argument("--formulation", default="linear", choices=("linear", "ffrf"),
                        help="flexible-body formulation (same linearised system; default linear)")
    parser.add_argument("--cache-dir", default=None, help="flexible-body cache directory")
    parser.add_argument("--json", required=True, help="output modes JSON file")


def run(args: argparse.Namespace) -> int:
    """Build, linearise, write the modes JSON and print the table."""
    from pathlib import Path

    from tqdm import tqdm

    from exudyn_study.errors import InputError
    from exudyn_study.identify.model import write_modes_json
    from exudyn_study.linear.modes import to_modal_model
    from exudyn_study.model import BushingParameters, build_model
    from exudyn_study.model.linearisation import linearise, system_modes

    out = Path(args.json)
    if not out.parent.is_dir():
        raise InputError(f"--json {args.json!r}: directory {str(out.parent)!r} does not exist")
    damping = parse_damping(args.damping)
    with tqdm(total=3, desc="modes", file=sys.stderr, disable=None) as bar:
        model = build_model(args.model, damping=damping, mesh_size=parse_mesh(args.mesh),
                            bushing=BushingParameters() if args.bushing else None, cache_dir=args.cache_dir,
                            formulation=args.formulation, progress=lambda text: bar.set_postfix_str(text))
        bar.update()
        bar.set_postfix_str("linearising")
        lin = linearise(model)
        bar.update()
        bar.set_postfix_str("eigenvalues")
        modes = system_modes(model, lin, max_frequency_hz=args.max_frequency, n_modes=args.n_modes)
        bar.update()
    write_modes_json(to_modal_model(modes, model.metadata), out)
    print(modes_table(modes))
    return 0
